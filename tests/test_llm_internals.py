"""The start-up check of the llama-cpp-python internals the embedded backend uses
(interllm/llm/llama_internals.py): it finds a missing struct field, a changed constructor or a
missing attribute, falls back to one-sequence scoring with one warning naming both releases, and
refuses when no scoring path works. No model is loaded here (tests/test_llm_embedded.py scores
on the fallback path with the real model)."""

from __future__ import annotations

import ctypes
import logging
import re
from pathlib import Path
from types import SimpleNamespace

import pytest

from interllm.llm import llama_internals as li

llama_cpp = pytest.importorskip("llama_cpp")
ROOT = Path(__file__).resolve().parents[1]


def struct_without(struct_type: type, name: str) -> type:
    """A ctypes struct like ``struct_type`` without field ``name`` (as an older release has it)."""
    return type(struct_type.__name__, (ctypes.Structure,),
                {"_fields_": [f for f in struct_type._fields_ if f[0] != name]})


class FakeContext:
    """Stands in for llama_cpp._internals.LlamaContext: records how it was built and closed."""

    def __init__(self, *, model, params, verbose: bool = True) -> None:
        self.model, self.params, self.verbose = model, params, verbose
        self.ctx, self.memory, self.closed = object(), object(), False

    def kv_cache_seq_rm(self, seq_id: int, p0: int, p1: int) -> bool:
        return True

    def close(self) -> None:
        self.closed = True


def fake_llm(**drop: bool) -> SimpleNamespace:
    """A ``Llama`` with the attributes the check looks at (real structs, no model)."""
    llm = SimpleNamespace(_ctx=FakeContext(model=None, params=None), _batch=SimpleNamespace(batch=llama_cpp.llama_batch()),
                          _input_ids=[], _model=object(), context_params=llama_cpp.llama_context_default_params(),
                          n_tokens=0)
    for name in drop:
        delattr(llm, name)
    return llm


@pytest.fixture(autouse=True)
def fresh_warnings(monkeypatch):
    monkeypatch.setattr(li, "_warned", set())


def test_the_tested_release_is_the_lock_pin():
    pin = re.search(r"^llama_cpp_python==(\S+)$", (ROOT / "requirements.lock").read_text(), re.M)
    assert pin and pin.group(1) == li.TESTED_VERSION


def test_the_installed_release_passes_the_check():
    llm = fake_llm()
    assert li.missing_for_scoring(llm) == []
    assert li.missing_for_multi_sequence(llm) == []


def test_a_struct_without_kv_unified_is_found():
    params = struct_without(llama_cpp.llama_context_params, "kv_unified")
    assert li.missing_fields(params, li.MULTI_SEQUENCE_FIELDS) == ["llama_context_params.kv_unified"]
    assert li.missing_for_multi_sequence(fake_llm(), params_type=params) == ["llama_context_params.kv_unified"]
    batch = struct_without(llama_cpp.llama_batch, "n_seq_id")
    llm = fake_llm()
    llm._batch.batch = batch()
    assert li.missing_for_scoring(llm) == ["llama_batch.n_seq_id"]


def test_a_changed_context_constructor_is_found():
    class Positional:
        def __init__(self, model, params, /, verbose=True): ...

    class WithKwargs:
        def __init__(self, **kw): ...

    assert li.missing_keywords(Positional, li.CONTEXT_KEYWORDS) == ["Positional(model=)", "Positional(params=)"]
    assert li.missing_keywords(WithKwargs, li.CONTEXT_KEYWORDS) == []
    assert li.missing_keywords(None, li.CONTEXT_KEYWORDS) == ["llama_cpp._internals.LlamaContext"]
    assert li.missing_for_multi_sequence(fake_llm(_model=True), context_type=FakeContext) == ["Llama._model"]


def test_a_missing_field_falls_back_to_one_sequence_with_one_warning(monkeypatch, caplog):
    monkeypatch.setattr(li, "_context_params_type",
                        lambda: struct_without(llama_cpp.llama_context_params, "kv_unified"))
    monkeypatch.setattr(li, "_context_type", lambda: FakeContext)
    llm = fake_llm()
    ctx = llm._ctx
    with caplog.at_level(logging.WARNING, logger=li.__name__):
        assert li.prepare(llm, 33) is False
        assert li.prepare(fake_llm(), 33) is False  # a second backend in the process: no second warning
    assert llm._ctx is ctx and not ctx.closed  # the context stays llama-cpp-python's own
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1
    assert f"llama-cpp-python {li.installed_version()} lacks llama_context_params.kv_unified" in warnings[0]
    assert f"tested with llama-cpp-python=={li.TESTED_VERSION}" in warnings[0]


def test_a_complete_release_gets_the_multi_sequence_context(monkeypatch, caplog):
    monkeypatch.setattr(li, "_context_type", lambda: FakeContext)
    llm = fake_llm()
    old = llm._ctx
    with caplog.at_level(logging.WARNING, logger=li.__name__):
        assert li.prepare(llm, 33) is True
    assert not caplog.records
    assert old.closed and isinstance(llm._ctx, FakeContext) and llm._ctx is not old
    assert llm._ctx.params.n_seq_max == 33 and llm._ctx.params.kv_unified and llm._ctx.verbose is False


def test_no_scoring_path_is_an_error_naming_both_releases():
    with pytest.raises(li.LlamaInternalsError, match=rf"lacks Llama._batch.batch.*=={re.escape(li.TESTED_VERSION)}"):
        li.prepare(fake_llm(_batch=True), 33)


def test_a_single_sequence_context_decodes_one_continuation_at_a_time():
    with pytest.raises(ValueError, match="one continuation at a time"):
        li.decode_after_prompt(fake_llm(), [[1], [2]], lambda logits: logits, multi_sequence=False)
