"""Every llama-cpp-python name below its public API that the embedded backend uses, in one place,
behind one start-up check.

``llama_cpp.Llama`` evaluates one sequence and has no batched decode of several. The embedded
backend needs more, so it reaches into llama-cpp-python's internals, which change between releases
without notice; a ctypes struct even takes an assignment to a field it lacks without complaint.
What is used, in two groups:

- every scoring path (:data:`CORE_ATTRIBUTES`, :data:`CORE_BINDINGS`, :data:`BATCH_FIELDS`): the
  ``Llama`` object's ``_ctx`` (``ctx``, ``memory``, ``kv_cache_seq_rm``), ``_batch.batch`` (a
  ``llama_batch`` struct, filled here) and ``_input_ids``, and the bindings ``llama_decode``,
  ``llama_get_logits`` and ``llama_memory_seq_rm``;
- batched scoring only (:data:`MULTI_SEQUENCE_FIELDS`, :data:`MULTI_SEQUENCE_ATTRIBUTES`,
  :data:`MULTI_SEQUENCE_BINDINGS`): the
  context-params struct's ``n_seq_max`` and ``kv_unified`` fields,
  ``llama_cpp._internals.LlamaContext(model=, params=, verbose=)`` (a context of several sequences
  over one unified KV cache, swapped into ``Llama._ctx``), ``Llama._model``, ``Llama.context_params``
  and the bindings ``llama_memory_seq_cp``, ``llama_batch_init`` and ``llama_batch_free`` (a batch
  whose tokens may belong to several sequences: :class:`SharedPrefixBatch`).

:func:`prepare` checks both groups once the model is loaded. A gap in the first is an
:class:`LlamaInternalsError` naming the installed and the tested release. A gap in the second
logs one warning (once per process) naming both releases and leaves the context as
llama-cpp-python built it (one sequence); the backend then scores one continuation per decode on
the prompt's own sequence 0 (``multi_sequence=False`` below). llama.cpp's kernels round
differently by batch size, so those scores differ slightly from batched ones: results are
comparable bit for bit only on the tested release.
"""

from __future__ import annotations

import inspect
import logging
from collections.abc import Callable, Sequence
from importlib import metadata
from typing import Any, Optional, TypeVar

import numpy as np

from interllm.errors import UserError

log = logging.getLogger(__name__)

T = TypeVar("T")

# the llama-cpp-python release this module is tested with: the pin in requirements.lock
# (tests/test_llm_internals.py checks that they agree)
TESTED_VERSION = "0.3.36"

CORE_ATTRIBUTES = ("_ctx.ctx", "_ctx.memory", "_ctx.kv_cache_seq_rm", "_batch.batch", "_input_ids")
CORE_BINDINGS = ("llama_decode", "llama_get_logits", "llama_memory_seq_rm")
BATCH_FIELDS = ("n_tokens", "token", "pos", "n_seq_id", "seq_id", "logits")
MULTI_SEQUENCE_ATTRIBUTES = ("_model", "context_params")
MULTI_SEQUENCE_FIELDS = ("n_seq_max", "kv_unified")
MULTI_SEQUENCE_BINDINGS = ("llama_memory_seq_cp", "llama_batch_init", "llama_batch_free")
CONTEXT_KEYWORDS = ("model", "params", "verbose")  # LlamaContext(model=..., params=..., verbose=...)


class LlamaInternalsError(UserError, RuntimeError):
    """The installed llama-cpp-python lacks internals that every scoring path needs."""


def installed_version() -> str:
    try:
        return metadata.version("llama_cpp_python")
    except metadata.PackageNotFoundError:
        return "unknown"


# -- the check ---------------------------------------------------------------------------------
def _bindings():
    from llama_cpp import llama_cpp as bindings  # lazy: loads the llama.cpp library

    return bindings


def _context_params_type() -> type:
    from llama_cpp import llama_cpp as bindings  # lazy: loads the llama.cpp library

    return bindings.llama_context_params


def _context_type() -> Optional[type]:
    try:
        from llama_cpp import _internals  # lazy: loads the llama.cpp library
    except ImportError:
        return None
    return getattr(_internals, "LlamaContext", None)


def missing_fields(struct_type: type, names: Sequence[str]) -> list[str]:
    """``names`` that are not fields of the ctypes struct ``struct_type`` (``Type.field``)."""
    fields = {f[0] for f in getattr(struct_type, "_fields_", ())}
    return [f"{struct_type.__name__}.{n}" for n in names if n not in fields]


def missing_attributes(obj: Any, paths: Sequence[str], owner: str = "Llama") -> list[str]:
    """Dotted attribute ``paths`` that ``obj`` lacks (``owner.path``)."""
    out = []
    for path in paths:
        node = obj
        for part in path.split("."):
            if not hasattr(node, part):
                out.append(f"{owner}.{path}")
                break
            node = getattr(node, part)
    return out


def missing_keywords(fn: Any, names: Sequence[str]) -> list[str]:
    """``names`` that ``fn`` does not accept as keyword arguments (all of them when ``fn`` is None)."""
    if fn is None:
        return ["llama_cpp._internals.LlamaContext"]
    label = getattr(fn, "__name__", repr(fn))
    try:
        params = inspect.signature(fn).parameters
    except (TypeError, ValueError):
        return [f"{label}({', '.join(n + '=' for n in names)})"]
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        return []
    keyword = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    return [f"{label}({n}=)" for n in names if n not in params or params[n].kind not in keyword]


def missing_for_scoring(llm: Any, bindings: Any = None) -> list[str]:
    """What every scoring path needs and ``llm`` or the bindings lack."""
    bindings = bindings if bindings is not None else _bindings()
    missing = missing_attributes(llm, CORE_ATTRIBUTES)
    missing += [f"llama_cpp.{n}" for n in CORE_BINDINGS if not hasattr(bindings, n)]
    batch = getattr(getattr(llm, "_batch", None), "batch", None)
    if batch is not None:
        missing += missing_fields(type(batch), BATCH_FIELDS)
    return missing


def missing_for_multi_sequence(llm: Any, *, params_type: Optional[type] = None, context_type: Any = None,
                               bindings: Any = None) -> list[str]:
    """What batched scoring needs and ``llm``, the context-params struct ``params_type``, the context
    class ``context_type`` or the bindings lack (defaults: the installed llama-cpp-python's)."""
    params_type = params_type if params_type is not None else _context_params_type()
    context_type = context_type if context_type is not None else _context_type()
    bindings = bindings if bindings is not None else _bindings()
    missing = missing_fields(params_type, MULTI_SEQUENCE_FIELDS)
    missing += missing_keywords(context_type, CONTEXT_KEYWORDS)
    missing += missing_attributes(llm, MULTI_SEQUENCE_ATTRIBUTES)
    missing += [f"llama_cpp.{n}" for n in MULTI_SEQUENCE_BINDINGS if not hasattr(bindings, n)]
    return missing


def prepare(llm: Any, n_seq_max: int) -> bool:
    """Check what scoring needs of the loaded ``llm``; give it a context of ``n_seq_max`` sequences
    over one unified KV cache and return True, or return False (one sequence: the caller scores one
    continuation per decode) with a warning, once per process. Raises :class:`LlamaInternalsError`
    when no scoring path works."""
    core = missing_for_scoring(llm)
    if core:
        raise LlamaInternalsError(f"llama-cpp-python {installed_version()} lacks {', '.join(core)}, which the "
                                  f"embedded backend needs; it is tested with llama-cpp-python=={TESTED_VERSION} "
                                  f"(requirements.lock; make install builds it)")
    context_type = _context_type()
    missing = missing_for_multi_sequence(llm, context_type=context_type)
    if missing:
        _warn_once(f"llama-cpp-python {installed_version()} lacks {', '.join(missing)} (tested with "
                   f"llama-cpp-python=={TESTED_VERSION}): the embedded backend scores one continuation per "
                   f"decode instead of up to {n_seq_max - 1} at once, more slowly, and its scores differ "
                   f"slightly from the tested release's; install the tested release (make install)")
        return False
    _swap_in_multi_sequence_context(llm, n_seq_max, context_type)
    return True


_warned: set[str] = set()  # fallback warnings given in this process


def _warn_once(message: str) -> None:
    if message not in _warned:
        _warned.add(message)
        log.warning("%s", message)


# -- the private calls -------------------------------------------------------------------------
def _swap_in_multi_sequence_context(llm: Any, n_seq_max: int, context_type: type) -> None:
    """Give ``llm`` a context of the same parameters with ``n_seq_max`` sequences over one unified
    KV cache (llama-cpp-python builds single-sequence contexts); the model frees it on close."""
    params = llm.context_params
    params.n_seq_max = n_seq_max
    params.kv_unified = True
    old, llm._ctx = llm._ctx, context_type(model=llm._model, params=params, verbose=False)
    old.close()


def evaluated_tokens(llm: Any) -> list[int]:
    """The tokens the context holds (positions ``[0, llm.n_tokens)``)."""
    return list(llm._input_ids[: llm.n_tokens]) if llm.n_tokens else []


def truncate(llm: Any, keep: int) -> None:
    """Drop every KV cell from position ``keep`` on: the context holds its first ``keep`` tokens."""
    llm._ctx.kv_cache_seq_rm(-1, keep, -1)
    llm.n_tokens = keep


def eval_prompt(llm: Any, tokens: Sequence[int]) -> None:
    """Append ``tokens`` (at most ``n_batch``) to the context's sequence 0 in one decode that
    computes no logits row. ``Llama.eval`` asks for the last token's row, a vocabulary-wide
    matrix-vector product (262,144 x 640 for Gemma 3 270M) that scoring never reads; the KV cells
    are the same either way (every layer's keys and values are computed for all tokens)."""
    if not 0 < len(tokens) <= llm.n_batch:
        raise ValueError(f"eval_prompt takes 1 to n_batch={llm.n_batch} tokens, got {len(tokens)}")
    n_past = llm.n_tokens
    b = llm._batch.batch
    b.n_tokens = 0
    for i, tok in enumerate(tokens):
        b.token[i], b.pos[i], b.n_seq_id[i], b.logits[i] = tok, n_past + i, 1, False
        b.seq_id[i][0] = 0
        b.n_tokens += 1
    if _bindings().llama_decode(llm._ctx.ctx, b) != 0:
        raise RuntimeError(f"llama_decode failed on {len(tokens)} prompt tokens at position {n_past}")
    llm.input_ids[n_past:n_past + len(tokens)] = tokens
    llm.n_tokens = n_past + len(tokens)


def decode_after_prompt(llm: Any, seqs: Sequence[Sequence[int]], read_logits: Callable[[np.ndarray], T], *,
                        multi_sequence: bool) -> T:
    """Decode ``seqs`` (token lists, each at the positions right after the prompt the context holds)
    in one batch with logits for every token; return ``read_logits(logits)`` (``logits``: [tokens,
    vocab], rows in the order of ``seqs`` and their tokens, valid only during the call) and drop the
    decoded cells again, so the context holds the prompt alone.

    multi_sequence: ``seqs[i]`` is sequence ``i + 1``, sharing the prompt's cells of sequence 0
    (needs the context of :func:`prepare`); False: exactly one seq, decoded on sequence 0 itself.
    """
    bindings = _bindings()
    if not multi_sequence and len(seqs) != 1:
        raise ValueError(f"a single-sequence context decodes one continuation at a time, got {len(seqs)}")
    n_past = llm.n_tokens
    ctx, mem = llm._ctx.ctx, llm._ctx.memory
    sids = range(1, len(seqs) + 1) if multi_sequence else range(0, 1)
    b = llm._batch.batch
    b.n_tokens = 0
    for sid, seq in zip(sids, seqs, strict=True):
        if multi_sequence:
            bindings.llama_memory_seq_cp(mem, 0, sid, 0, n_past)
        for i, tok in enumerate(seq):
            j = b.n_tokens
            b.token[j], b.pos[j], b.n_seq_id[j], b.logits[j] = tok, n_past + i, 1, True
            b.seq_id[j][0] = sid
            b.n_tokens += 1
    rows = sum(len(seq) for seq in seqs)
    try:
        if bindings.llama_decode(ctx, b) != 0:
            raise RuntimeError(f"llama_decode failed on a batch of {rows} continuation tokens")
        nv = llm.n_vocab()
        logits = np.ctypeslib.as_array(bindings.llama_get_logits(ctx), shape=(rows * nv,)).reshape(rows, nv)
        return read_logits(logits)
    finally:  # drop the continuations: the context holds the prompt again
        for sid in sids:
            bindings.llama_memory_seq_rm(mem, sid, -1 if multi_sequence else n_past, -1)



class SharedPrefixBatch:
    """A ``llama_batch`` of up to ``n_tokens`` tokens, each of which may belong to up to ``n_seq_max``
    sequences (``Llama``'s own batch gives every token one sequence). Owned by one backend; freed by
    :meth:`close`."""

    def __init__(self, n_tokens: int, n_seq_max: int) -> None:
        self.n_tokens, self.n_seq_max = n_tokens, n_seq_max
        self.batch = _bindings().llama_batch_init(n_tokens, 0, n_seq_max)

    def close(self) -> None:
        if self.batch is not None:
            _bindings().llama_batch_free(self.batch)
            self.batch = None


def decode_shared_prefixes(llm: Any, shared: SharedPrefixBatch, rows: Sequence[tuple[int, int, Sequence[int]]],
                           n_seqs: int, read_logits: Callable[[np.ndarray], T]) -> T:
    """Decode, in one batch with logits for every row, tokens that several continuations share.

    ``rows[j] = (token, offset, sequence ids)``: the token sits at position ``llm.n_tokens + offset``
    (right after the prompt the context holds) in each of the given sequences (ids in
    ``1..n_seqs``, each a copy of the prompt's cells of sequence 0). Returns ``read_logits(logits)``
    (``logits``: [rows, vocab] in the order of ``rows``, valid only during the call) and drops the
    decoded cells again, so the context holds the prompt alone. Needs the context of :func:`prepare`.
    """
    if not 0 < len(rows) <= shared.n_tokens:
        raise ValueError(f"decode_shared_prefixes takes 1 to {shared.n_tokens} rows, got {len(rows)}")
    if not 0 < n_seqs <= shared.n_seq_max:
        raise ValueError(f"decode_shared_prefixes takes 1 to {shared.n_seq_max} sequences, got {n_seqs}")
    bindings = _bindings()
    n_past = llm.n_tokens
    ctx, mem = llm._ctx.ctx, llm._ctx.memory
    b = shared.batch
    for sid in range(1, n_seqs + 1):
        bindings.llama_memory_seq_cp(mem, 0, sid, 0, n_past)
    b.n_tokens = 0
    for j, (tok, offset, sids) in enumerate(rows):
        b.token[j], b.pos[j], b.n_seq_id[j], b.logits[j] = tok, n_past + offset, len(sids), True
        for q, sid in enumerate(sids):
            b.seq_id[j][q] = sid
        b.n_tokens += 1
    try:
        if bindings.llama_decode(ctx, b) != 0:
            raise RuntimeError(f"llama_decode failed on a batch of {len(rows)} shared continuation tokens")
        nv = llm.n_vocab()
        logits = np.ctypeslib.as_array(bindings.llama_get_logits(ctx), shape=(len(rows) * nv,)).reshape(len(rows), nv)
        return read_logits(logits)
    finally:  # drop the continuations: the context holds the prompt again
        for sid in range(1, n_seqs + 1):
            bindings.llama_memory_seq_rm(mem, sid, -1, -1)
