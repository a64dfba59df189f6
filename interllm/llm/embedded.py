"""Embedded backend: llama-cpp-python in process, CPU only, lazily loaded.

Model file: ``cfg.model`` = a GGUF path, or "" for the packaged Gemma 3 270M Q4_K_M (see
:mod:`interllm.llm.model_files`). The llama-cpp-python internals used below sit in
:mod:`interllm.llm.llama_internals`, which checks them when the model loads.

Generation: the prompt text is built here (the model is a base model; see :func:`format_messages`)
and decoded with a GBNF grammar compiled from the JSON schema (``LlamaGrammar.from_json_schema``),
so every answer parses. The sampling seed is passed per call.

Scoring: ``score(prompt, continuations)`` evaluates the prompt once (sequence 0) and then the
continuations in groups of up to ``SCORE_SEQS`` (at most ``n_batch`` tokens), one batched decode per
group, as a prefix trie (:data:`SCORER`): each continuation is a llama.cpp sequence of its own that
shares the prompt's KV cells (``llama_memory_seq_cp``, no copy), and every distinct prefix of the
group's continuations (``bread_1`` and ``bread_2`` share ``bread_``) is decoded once, as one token
that belongs to every sequence through it (:func:`prefix_trie`); each continuation's log-probs are
read from its prefixes' rows. Afterwards the continuations' cells are dropped
(``llama_memory_seq_rm``) and the context holds the prompt again. The context is built with
``n_seq_max = SCORE_SEQS + 1`` and a unified KV cache for this; where the installed llama-cpp-python
cannot build that context, each continuation is decoded alone on sequence 0 instead. The groups are
a function of the request alone, so a request's scores do not depend on what ran before. The score
of a continuation is the mean log-prob of its tokens (log-softmax over the vocabulary, vectorised).
The trie decodes fewer rows than one sequence per continuation and is nearer to scoring each
continuation alone (``benchmarks/bench_trie_scoring.py``; docs/benchmarks.md).
Prompt tokens served from the KV prefix cache (the longest common prefix with the tokens already
in the context) are counted and reported as ``prompt_tokens_reused``.

Deadline: ``llm.timeout_s`` bounds every call as a whole. Prompt evaluation checks it between
chunks, generation after every token (a llama.cpp stopping criterion) and scoring between
continuation groups; a call past it raises :class:`~interllm.llm.deadline.DeadlineExceeded` (never a
cut answer, which would make results depend on the machine's speed).

History independence: llama.cpp's CPU kernels give slightly different logits for the same tokens
evaluated in batches of different sizes. So that an answer or a score does not depend on what the
context held before (i.e. on call order and cache hits), every prompt is
evaluated in chunks aligned to absolute positions (multiples of ``CHUNK`` tokens), and only whole
aligned chunks are reused from the KV cache. The split of a prompt is thus a function of the
prompt alone, and the same request gives bit-identical results whatever ran before it.
"""

from __future__ import annotations

import functools
import json
import math
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Optional

import numpy as np

from interllm import llama_build
from interllm.config import LLMConfig
from interllm.llm import llama_internals
from interllm.llm.backend import BACKENDS, Generation, Scores
from interllm.llm.deadline import DeadlineExceeded
from interllm.llm.model_files import PACKAGED_MODEL, gguf_sha256, resolve_model_path
from interllm.llm.types import LLMOptions, Message

CHUNK = 64  # [tokens] prompt evaluation chunk; KV reuse happens in whole aligned chunks
SCORE_SEQS = 32  # continuations scored in one batched decode (llama.cpp sequences 1..SCORE_SEQS)
# how a group of continuations is decoded; part of every embedded score request's cache key, so that
# answers of another layout (the earlier one sequence per continuation) are never mixed in
SCORER = "prefix-trie-1"


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


SOFTMAX_ROWS = 16  # logits rows per block of the log-softmax (its scratch: 16 x vocab float32, 17 MB)
_scratch = threading.local()  # each thread's block scratch, allocated once


def _block_scratch(vocab: int) -> np.ndarray:
    """This thread's [SOFTMAX_ROWS, vocab] float32 scratch (reused: no page faults per call)."""
    buf = getattr(_scratch, "buf", None)
    if buf is None or buf.shape[1] != vocab:
        buf = _scratch.buf = np.empty((SOFTMAX_ROWS, vocab), dtype=np.float32)
    return buf


def _log_softmax_at(logits: np.ndarray, tokens: Sequence[int]) -> np.ndarray:
    """log p(tokens[i]) [nats] under the softmax of row i of ``logits`` [rows, vocab] (float64 sums).

    Bit for bit ``logits[i, t_i] - (log(sum(exp(logits - max))) + max)`` computed on the whole
    array at once; blocks of rows in a reused scratch only spare the two [rows, vocab] temporaries,
    whose page faults cost more than the arithmetic (``tests/test_llm_embedded.py`` checks the
    identity)."""
    return logits[np.arange(len(tokens)), np.asarray(tokens)].astype(np.float64) - _logsumexp_rows(logits)


def _logsumexp_rows(logits: np.ndarray) -> np.ndarray:
    """log(sum(exp(row))) of every row of ``logits`` [rows, vocab], float64 (each row alone: the
    value of a row does not depend on the rows beside it)."""
    rows, vocab = logits.shape
    buf = _block_scratch(vocab)
    lse = np.empty(rows, dtype=np.float64)
    for start in range(0, rows, SOFTMAX_ROWS):
        block = logits[start:start + SOFTMAX_ROWS]
        m = block.max(axis=1, keepdims=True)
        shifted = buf[:len(block)]
        np.subtract(block, m, out=shifted)
        np.exp(shifted, out=shifted)
        lse[start:start + len(block)] = np.log(shifted.sum(axis=1, dtype=np.float64)) + m[:, 0].astype(np.float64)
    return lse


def prefix_trie(conts: Sequence[Sequence[int]], group: range) -> list[tuple[tuple[int, ...], list[int]]]:
    """Every distinct prefix that ``conts[group]`` decode (``conts[k][:i]`` for ``i < len(conts[k])``,
    the empty one included), in first-seen order, each with the sequence ids through it (sequence
    ``1 + j`` is ``group[j]``). Continuation ``k``'s token ``i`` is predicted from prefix
    ``conts[k][:i]``'s row."""
    members: dict[tuple[int, ...], list[int]] = {}
    for sid, k in enumerate(group, start=1):
        for i in range(len(conts[k])):
            members.setdefault(tuple(conts[k][:i]), []).append(sid)
    return list(members.items())


def score_groups(lengths: Sequence[int], max_seqs: int, max_tokens: int) -> list[range]:
    """Consecutive groups of continuations (by index) of at most ``max_seqs`` continuations and
    ``max_tokens`` tokens (``lengths``: tokens each decodes); a function of the lengths alone."""
    groups: list[range] = []
    start, total = 0, 0
    for i, n in enumerate(lengths):
        if n > max_tokens:
            raise ValueError(f"continuation of {n} tokens exceeds n_batch={max_tokens}")
        if i > start and (i - start >= max_seqs or total + n > max_tokens):
            groups.append(range(start, i))
            start, total = i, 0
        total += n
    if start < len(lengths):
        groups.append(range(start, len(lengths)))
    return groups


@functools.cache
def _check_build_once() -> dict:
    """:func:`interllm.llama_build.check` once per process, before the first model load: a build
    the CPU cannot run would crash on the first decode, a native one would move cold answers."""
    return llama_build.check()


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
        self._calib_memo: dict[tuple[str, tuple[str, ...]], tuple[list[float], int]] = {}
        self._aligned = 0  # context positions [0, _aligned) were evaluated in aligned whole chunks
        self.load_seconds = 0.0  # wall time of the model load [s] (diagnostics only)
        self._deadline = math.inf  # time.monotonic() by which the current call must end [s]
        self._what = ""
        self.multi_sequence = False  # the context scores SCORE_SEQS continuations per decode (set on load)
        self._shared_batch: Optional[llama_internals.SharedPrefixBatch] = None  # the trie's batch (on load)

    # -- identity ---------------------------------------------------------------------------
    def model_name(self) -> str:
        return self.cfg.model or PACKAGED_MODEL

    def model_id(self) -> str:
        """sha256 of the GGUF (cache-key identity; no model load needed)."""
        return gguf_sha256(self.cfg.model)

    @property
    def scorer(self) -> str:
        """How continuations are decoded (:data:`SCORER`): part of the score requests' cache keys."""
        return SCORER

    def check(self) -> None:
        resolve_model_path(self.cfg.model)

    # -- lazy model ---------------------------------------------------------------------------
    @property
    def llm(self):
        if self._llm is None:
            from llama_cpp import Llama  # lazy: loads the llama.cpp library

            t0 = time.perf_counter()
            _check_build_once()
            self._path = resolve_model_path(self.cfg.model)
            llm = Llama(model_path=str(self._path), n_ctx=self.cfg.n_ctx,
                        n_threads=self.cfg.n_threads, n_threads_batch=self.cfg.n_threads,
                        seed=self.cfg.seed, logits_all=False, verbose=False)
            try:
                self.multi_sequence = llama_internals.prepare(llm, SCORE_SEQS + 1)
                if self.multi_sequence:
                    self._shared_batch = llama_internals.SharedPrefixBatch(llm.n_batch, SCORE_SEQS)
            except BaseException:
                llm.close()
                raise
            self._llm = llm
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
        return llama_internals.evaluated_tokens(self.llm)

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
        llama_internals.truncate(llm, keep)
        self._aligned = keep
        pos = keep
        while pos < len(want):
            self._check_deadline()
            end = min(len(want), (pos // CHUNK + 1) * CHUNK)
            llama_internals.eval_prompt(llm, want[pos:end])
            pos = end
            self._aligned = (pos // CHUNK) * CHUNK
        self._aligned = (len(want) // CHUNK) * CHUNK
        return keep

    def _score_group(self, last_prompt_token: int, conts: list[list[int]], group: range) -> list[float]:
        """Mean log-probs [nats/token] of ``conts[group]`` after the context + ``last_prompt_token``,
        decoded in one batch (a prefix trie over the prompt's cells, or sequence 0 for a group of one
        on a single-sequence context); the context holds the prompt again afterwards."""
        llm = self.llm
        n_past = llm.n_tokens
        longest = max(len(conts[k]) for k in group)
        if n_past + longest > self.cfg.n_ctx:  # checked before any sequence is copied: nothing to undo
            raise ValueError(f"prompt ({n_past + 1} tokens) + a continuation of {longest} tokens exceed "
                             f"llm.n_ctx={self.cfg.n_ctx}; raise llm.n_ctx or shorten the request")
        if self._shared_batch is not None:
            return self._score_trie(last_prompt_token, conts, group)
        return self._score_sequences(last_prompt_token, conts, group)

    def _score_sequences(self, last_prompt_token: int, conts: list[list[int]], group: range) -> list[float]:
        """:meth:`_score_group` as one sequence per continuation (the layout before the trie; the
        only one a single-sequence context has, with a group of one)."""
        llm = self.llm
        seqs = [[last_prompt_token] + conts[k][:-1] for k in group]
        rows = [(k, i) for k in group for i in range(len(conts[k]))]  # one per decoded token, in batch order
        lps = llama_internals.decode_after_prompt(
            llm, seqs, lambda logits: _log_softmax_at(logits, [conts[k][i] for k, i in rows]),
            multi_sequence=self.multi_sequence)
        sums: dict[int, list[float]] = {k: [] for k in group}
        for (k, _), lp in zip(rows, lps, strict=True):
            sums[k].append(float(lp))
        return [sum(sums[k]) / len(sums[k]) for k in group]

    def _score_trie(self, last_prompt_token: int, conts: list[list[int]], group: range) -> list[float]:
        """:meth:`_score_group` through the prefix trie (one row per distinct prefix)."""
        trie = prefix_trie(conts, group)
        row_of = {prefix: j for j, (prefix, _) in enumerate(trie)}
        rows = [(prefix[-1] if prefix else last_prompt_token, len(prefix), sids) for prefix, sids in trie]

        def means(logits: np.ndarray) -> list[float]:
            lse = _logsumexp_rows(logits)
            out = []
            for k in group:
                js = [row_of[tuple(conts[k][:i])] for i in range(len(conts[k]))]
                lp = logits[js, conts[k]].astype(np.float64) - lse[js]
                out.append(sum(float(x) for x in lp) / len(lp))
            return out

        return llama_internals.decode_shared_prefixes(self.llm, self._shared_batch, rows, len(group), means)

    def _score_prompt(self, prompt: str, conts: list[list[int]]) -> tuple[list[float], int, int]:
        tokens = self.tokenize(prompt)
        if len(tokens) < 1:
            raise ValueError("scoring needs a non-empty prompt")
        reused = self._prefill(tokens[:-1])
        means: list[float] = []
        max_seqs = SCORE_SEQS if self.multi_sequence else 1
        for group in score_groups([len(c) for c in conts], max_seqs, self.llm.n_batch):
            self._check_deadline()
            means += self._score_group(tokens[-1], conts, group)
        return means, len(tokens), reused

    def score(self, prompt: str, continuations: Sequence[str],
              calibration_prompt: Optional[str] = None) -> Scores:
        """Mean token log-prob [nats/token] of each continuation after ``prompt`` (and after
        ``calibration_prompt`` when given; memoised per (calibration prompt, continuations))."""
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
                memo = (calibration_prompt, tuple(continuations))  # scores depend on the whole group
                if memo not in self._calib_memo:
                    scores, n, _ = self._score_prompt(calibration_prompt, conts)
                    self._calib_memo[memo] = (scores, n)
                scores, n = self._calib_memo[memo]
                calib = list(scores)
                tokens_in += n  # counted when memoised too: tokens_in is a function of the request
            raw, n, reused = self._score_prompt(prompt, conts)
            tokens_in += n
            return Scores(raw=raw, calibration=calib, tokens_in=tokens_in, prompt_tokens_reused=reused)

    def close(self) -> None:
        self._aligned = 0
        if self._shared_batch is not None:
            self._shared_batch.close()
            self._shared_batch = None
        if self._llm is not None:
            try:
                self._llm.close()
            except Exception:  # noqa: BLE001 - best effort on shutdown
                pass
            self._llm = None
