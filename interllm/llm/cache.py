"""Content-addressed LLM response cache.

The key is the sha256 of a canonical JSON of the full request (backend, model sha256 or Ollama
digest, messages or prompt, schema, options incl. sample_index, template hash, kind, continuations,
calibration prompt). Entries live at ``<cache_dir>/<key[:2]>/<key>.json`` and hold the request
summary, the response and a sha256 checksum of the canonical response JSON. They contain no
timestamps and no latencies, so they are byte-stable and small enough to commit to git.

Modes: ``readwrite`` (default: hit -> stored response, miss -> backend then store), ``replay``
(a miss raises :class:`CacheMissError`), ``off`` (neither read nor written), ``retry_failures``
(readwrite, except that a stored *failure* — an answer that stayed invalid, ``"failed": true`` — is
a miss: the backend is asked again and its new outcome replaces the failure, so that a later
readwrite run gets the new answer). A failure is stored like an answer so that a replay and every
process meet the same outcome; after the model or server has been fixed, one run with
``llm.cache_mode=retry_failures`` asks again for exactly the failed requests (the failure-share
stop advises it when failures came from the cache). ``off`` changes no entry. Within one
``retry_failures`` run, a request that fails again in one stage and succeeds when a later stage or
worker asks it again ends with the success stored, while the earlier stage used the failure: that
run replays exactly only after one more run (readwrite) that meets the stored outcome everywhere.

Writes are atomic (temp file in the same folder + ``os.replace``), so several processes writing
at once lose nothing. A corrupt entry (bad JSON, checksum mismatch, or a response whose layout is
not the one the reader expects: ``layout`` of :meth:`ResponseCache.get`, see
:mod:`interllm.llm.entry_layout`) is reported with ``logging.warning`` naming the entry file,
treated as a miss and overwritten by the next store.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Optional

from interllm.config import CACHE_MODES
from interllm.core import jsonfmt
from interllm.errors import UserError
from interllm.io import atomic_create_bytes, atomic_write_bytes

log = logging.getLogger(__name__)

CACHE_FORMAT = 1  # bump when the entry layout or the key recipe changes
WRITING_MODES = ("readwrite", "retry_failures")
# a response's layout check: what is wrong with it (for the warning), or None
Layout = Callable[[dict], Optional[str]]


class CacheMissError(UserError, RuntimeError):
    """Replay mode found no entry for a request."""


class CacheCorruptError(ValueError):
    """An entry failed to parse or its checksum does not match."""


def cache_key(payload: dict) -> str:
    """sha256 hex of the canonical JSON of ``payload`` (plus the cache format version)."""
    body = jsonfmt.compact({"cache_format": CACHE_FORMAT, "request": payload})
    return hashlib.sha256(body.encode("utf-8")).hexdigest()


def response_checksum(response: dict) -> str:
    return hashlib.sha256(jsonfmt.compact(response).encode("utf-8")).hexdigest()


def keys_in_call_logs(paths: Iterable[str | os.PathLike]) -> set[str]:
    """The cache keys of every call in some ``llm_calls.jsonl`` call logs (unreadable lines, e.g. the
    torn last line of a killed run, are skipped)."""
    keys: set[str] = set()
    for p in paths:
        with open(p, encoding="utf-8") as f:
            for line in f:
                try:
                    k = json.loads(line).get("key")
                except (json.JSONDecodeError, AttributeError):
                    continue
                if isinstance(k, str) and k:
                    keys.add(k)
    return keys


def stale_entries(cache_dir: str | os.PathLike, keep: set[str]) -> list[Path]:
    """Entries of ``cache_dir`` whose key is not in ``keep``, sorted."""
    return sorted(p for p in Path(cache_dir).glob("*/*.json") if p.stem not in keep)


class ResponseCache:
    """cache_dir: folder of entries; mode: one of ``readwrite|replay|off``."""

    def __init__(self, cache_dir: str | os.PathLike, mode: str = "readwrite") -> None:
        if mode not in CACHE_MODES:
            raise ValueError(f"config key 'llm.cache_mode': {mode!r} is not valid; "
                             f"choose one of {list(CACHE_MODES)}")
        self.dir = Path(cache_dir)
        self.mode = mode
        self.hits = 0
        self.misses = 0
        self.corrupt = 0
        self.writable = True  # False after a failed write: the run goes on without caching
        self._retrying: dict[str, str] = {}  # retry_failures: key -> checksum of the failure asked again

    @property
    def writes(self) -> bool:
        """Whether this mode stores answers (readwrite, retry_failures)."""
        return self.mode in WRITING_MODES

    def path_for(self, key: str) -> Path:
        return self.dir / key[:2] / f"{key}.json"

    def _read(self, key: str, layout: Optional[Layout] = None) -> Optional[dict]:
        path = self.path_for(key)
        try:
            data = path.read_bytes()
        except FileNotFoundError:
            return None
        except OSError as e:  # a directory where the entry should be, no permission, ...
            self.corrupt += 1
            log.warning("LLM cache entry %s cannot be read (%s); treating it as a miss", path,
                        e.strerror or e)
            return None
        try:
            entry = json.loads(data.decode("utf-8"))
            if not isinstance(entry, dict) or entry.get("key") != key:
                raise CacheCorruptError("entry key does not match its file name")
            resp = entry["response"]
            if response_checksum(resp) != entry["checksum"]:
                raise CacheCorruptError("response checksum mismatch")
            problem = layout(resp) if layout is not None else None
            if problem is not None:
                raise CacheCorruptError(f"a response layout this reader does not know: {problem}")
            return resp
        except (ValueError, KeyError, TypeError, RecursionError) as e:  # UnicodeDecodeError is a ValueError
            self.corrupt += 1
            log.warning("LLM cache entry %s is corrupt (%s); treating it as a miss and "
                        "overwriting it", path, e)
            return None

    def get(self, key: str, purpose: str = "", describe: str = "", layout: Optional[Layout] = None) -> Optional[dict]:
        """Stored response dict for ``key`` or ``None`` on a miss.

        layout: the reader's check of the response (an entry that fails it is a corrupt one). In
        replay mode a miss raises :class:`CacheMissError` naming the purpose and key; in
        retry_failures mode a stored failure is a miss, which the next :meth:`put` of ``key`` replaces.
        """
        if self.mode == "off":
            return None
        resp = self._read(key, layout)
        if resp is not None and self.mode == "retry_failures" and resp.get("failed") is True:
            self._retrying[key] = response_checksum(resp)
            resp = None
        if resp is not None:
            self.hits += 1
            return resp
        self.misses += 1
        if self.mode == "replay":
            raise CacheMissError(
                f"LLM cache miss in replay mode: purpose={purpose!r} key={key} "
                f"({self.path_for(key)} is absent or corrupt){': ' + describe if describe else ''}. "
                f"Fill the cache by rerunning with llm.cache_mode=readwrite (needs the model/backend), "
                f"or restore {self.dir} from git/DVC.")
        return None

    def put(self, key: str, request_summary: dict, response: dict, layout: Optional[Layout] = None) -> dict:
        """Store an entry atomically (no-op unless the mode writes) and return the response the
        cache holds for ``key``: the first writer wins, so when another process (a mission worker,
        a parallel job) stored an answer to the same request meanwhile, that answer is returned and
        kept, and every process goes on with the answer a replay will give. The one entry replaced
        is a corrupt one (``layout`` as in :meth:`get`), or in retry_failures mode the failure this
        cache's :meth:`get` found for ``key`` (unless another process has replaced it meanwhile: then
        its answer wins). A cache folder that cannot be written (read-only, full, an entry path taken
        by a folder) costs the caching, never the answer: one warning, and this cache stops writing
        for the rest of the run."""
        retried = self._retrying.pop(key, None)
        if not self.writes or not self.writable:
            return response
        entry = {"cache_format": CACHE_FORMAT, "key": key, "request": request_summary,
                 "response": response, "checksum": response_checksum(response)}
        data = jsonfmt.pretty(entry).encode("utf-8")
        path = self.path_for(key)
        try:
            if atomic_create_bytes(path, data):
                return response
            held = self._read(key, layout)
            if held is not None and (retried is None or response_checksum(held) != retried):
                return held
            atomic_write_bytes(path, data)  # a corrupt entry, or the failure asked again: this answer replaces it
        except OSError as e:
            self.writable = False
            log.warning("LLM cache %s cannot be written (%s: %s); answers of this run are not cached. Make "
                        "the folder writable or point llm.cache_dir elsewhere", self.dir, path, e.strerror or e)
        return response
