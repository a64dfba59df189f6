"""What a client and all its views share: the counters, the failure share judged mid-stage, and
the backend's model identity pinned for offline replay.

The model identity (a cache-key part) is pinned in ``<cache_dir>/models.json`` (backend:model ->
identity), so a replay finds its cache entries without the backend (e.g. with no Ollama server).
"""

from __future__ import annotations

import json
import logging
import threading
from dataclasses import dataclass
from typing import Optional

from interllm.config import LLMConfig
from interllm.io import atomic_write_text
from interllm.llm.backend import Backend
from interllm.llm.cache import ResponseCache
from interllm.llm.calllog import CallLog
from interllm.llm.errors import LLMQualityError
from interllm.llm.health import MIN_CALLS_FOR_EARLY_STOP, failure_share_message

log = logging.getLogger(__name__)

MODELS_PIN_FILE = "models.json"  # in cache_dir: model name -> identity, for offline replay


@dataclass
class ClientStats:
    """Counters over a client's lifetime (views share them)."""

    calls: int = 0  # complete + score calls
    complete_calls: int = 0
    score_calls: int = 0
    cache_hits: int = 0
    backend_calls: int = 0  # backend round trips incl. repair attempts
    tokens_in: int = 0  # prompt tokens of backend calls (0 for cache hits)
    tokens_out: int = 0
    prompt_tokens_reused: int = 0  # of tokens_in, served from the backend's KV prefix cache
    repairs: int = 0  # re-asks after invalid output
    failures: int = 0
    backend_seconds: float = 0.0  # wall time in the backend [s] (diagnostics only)


class ClientCore:
    """State shared by a client and its views."""

    def __init__(self, cfg: LLMConfig, backend: Backend, cache: ResponseCache,
                 call_log: Optional[CallLog]) -> None:
        self.cfg = cfg
        self.backend = backend
        self.cache = cache
        self.call_log = call_log
        self.stats = ClientStats()
        self.lock = threading.RLock()
        self._model_id: Optional[str] = None
        self.failed_calls = 0  # calls that ended in an error (unparseable after repairs, backend error)
        self.failed_cached = 0  # of them, failures the cache replayed (stored by an earlier run)
        self.last_failed_answer = ""

    def note_failure(self, answer: str, cached: bool = False) -> Optional[LLMQualityError]:
        """Count a failed call (``cached``: a failure the cache replayed); the error to raise instead when
        the failure share is over its bound."""
        self.failed_calls += 1
        self.failed_cached += cached
        self.last_failed_answer = answer
        n, bound = self.stats.calls, self.cfg.max_failure_share
        if n >= MIN_CALLS_FOR_EARLY_STOP and self.failed_calls > bound * n:
            return LLMQualityError(failure_share_message(
                backend=self.backend.name, model=self.backend.model_name(), n_calls=n,
                n_failed=self.failed_calls, bound=bound, sample=answer, where="stopping early",
                n_cached=self.failed_cached, cache_dir=str(self.cache.dir)))
        return None

    def model_id(self) -> str:
        """Backend model identity for cache keys; pinned in ``<cache_dir>/models.json`` so
        replay works offline (e.g. without the Ollama server)."""
        if self._model_id is not None:
            return self._model_id
        name = f"{self.backend.name}:{self.backend.model_name()}"
        pin_path = self.cache.dir / MODELS_PIN_FILE
        pins: dict = {}
        try:
            pins = json.loads(pin_path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            pins = {}
        try:
            mid = self.backend.model_id()
        except Exception as e:  # noqa: BLE001 - backend unreachable
            if self.cache.mode == "replay" and name in pins:
                mid = pins[name]
                log.info("model identity of %s from %s (backend unavailable: %s)", name, pin_path, e)
            else:
                raise
        if self.cache.writes and self.cache.writable and pins.get(name) != mid:
            pins[name] = mid
            try:
                atomic_write_text(pin_path, json.dumps(pins, indent=1, sort_keys=True) + "\n")
            except OSError as e:
                self.cache.writable = False
                log.warning("LLM cache %s cannot be written (%s: %s); answers of this run are not cached",
                            self.cache.dir, pin_path, e.strerror or e)
        self._model_id = mid
        return mid
