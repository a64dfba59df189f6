"""LLM client behaviour with a scripted backend: repair retries, call log, labels, counters,
scoring arithmetic, seeds, templates, schema-valid test answers."""

from __future__ import annotations

import json
import random
import subprocess
import sys
from pathlib import Path

import jsonschema
import pytest

from interllm.config import LLMConfig
from interllm.core.seeding import llm_sample_seed
from interllm.llm import (
    LLMOutputError,
    LLMRequest,
    Message,
    ScoreRequest,
    TemplateError,
    load_template,
    make_client,
)
from interllm.llm.calllog import CallLog
from interllm.llm.testing import DeterministicBackend, schema_instance

REPO = Path(__file__).resolve().parents[1]
SCHEMA = {"type": "object", "properties": {"objects": {"type": "array", "items": {"enum": ["cup", "book"]},
                                                       "minItems": 1}}, "required": ["objects"]}


def _req(**kw):
    base = dict(purpose="candidates", messages=(Message("user", "pick"),), schema=SCHEMA)
    base.update(kw)
    return LLMRequest(**base)


def test_repair_retry_feeds_error_back(tmp_path):
    seen = []
    answers = iter(['{"objects": ["cup"', '{"objects": ["plate"]}', '{"objects": ["book"]}'])

    def gen(messages, schema, options, seed):
        seen.append((list(messages), seed))
        return next(answers)

    cfg = LLMConfig(cache_dir=str(tmp_path / "c"), repair_retries=2)
    c = make_client(cfg, call_log_path=tmp_path / "calls.jsonl", backend=DeterministicBackend(gen))
    r = c.complete(_req())
    assert r.parsed == {"objects": ["book"]} and len(r.errors) == 2
    assert "not valid JSON" in r.errors[0] and "objects/0" in r.errors[1] and "plate" in r.errors[1]
    # attempt 2 saw: user, assistant(bad1), user(error1), assistant(bad2), user(error2)
    msgs = seen[2][0]
    assert [m.role for m in msgs] == ["user", "assistant", "user", "assistant", "user"]
    assert r.errors[1] in msgs[4].content
    # each attempt has its own derived seed
    assert [s for _, s in seen] == [llm_sample_seed(0, 0, a) for a in range(3)]
    assert c.stats.repairs == 2 and c.stats.backend_calls == 3
    rec = json.loads((tmp_path / "calls.jsonl").read_text().splitlines()[-1])
    assert rec["errors"] == list(r.errors) and rec["cache_hit"] is False and rec["error"] is None


def test_retries_exhausted_raise_and_are_logged(tmp_path):
    cfg = LLMConfig(cache_dir=str(tmp_path / "c"), repair_retries=1)
    be = DeterministicBackend(lambda *a: "not json")
    c = make_client(cfg, call_log_path=tmp_path / "calls.jsonl", backend=be)
    with pytest.raises(LLMOutputError, match="llm.repair_retries") as e:
        c.complete(_req())
    assert be.generate_calls == 2 and len(e.value.errors) == 2
    rec = json.loads((tmp_path / "calls.jsonl").read_text().splitlines()[-1])
    assert "stayed invalid" in rec["error"]
    entries = list((tmp_path / "c").glob("??/*.json"))  # the failed outcome is cached like an answer,
    assert len(entries) == 1 and json.loads(entries[0].read_text())["response"]["failed"] is True
    with pytest.raises(LLMOutputError, match="llm.repair_retries") as again:  # so a replay meets the same failure
        make_client(LLMConfig(cache_dir=str(tmp_path / "c"), cache_mode="replay"), backend=be).complete(_req())
    assert str(again.value) == str(e.value) and be.generate_calls == 2  # without asking the model again


def test_call_log_labels_views_counters_and_callback(tmp_path):
    got = []
    c = make_client(LLMConfig(cache_dir=str(tmp_path / "c")), call_log_path=tmp_path / "log" / "calls.jsonl",
                    context={"stage": "candidates"}, backend=DeterministicBackend(),
                    call_log_callback=got.append)
    v = c.with_context(planner="inter_llm", scene="s0", mission="m1")
    v2 = v.with_context(command=2)
    r1 = v2.complete(_req())
    r2 = v.complete(_req())
    v.score(ScoreRequest(purpose="proposal", prompt="p", continuations=(" a", " b")))
    lines = (tmp_path / "log" / "calls.jsonl").read_text().splitlines()
    assert len(lines) == 3 and [json.loads(x) for x in lines] == got
    a, b, s = got
    assert (a["stage"], a["planner"], a["scene"], a["mission"], a["command"]) == \
        ("candidates", "inter_llm", "s0", "m1", "2")
    assert b["command"] is None and a["cache_hit"] is False and b["cache_hit"] is True
    assert s["kind"] == "score" and s["purpose"] == "proposal"
    assert r2.cached and r2.text == r1.text and r2.latency == 0.0
    st = c.stats  # views share counters
    assert (st.calls, st.cache_hits, st.complete_calls, st.score_calls) == (3, 1, 2, 1)
    assert st.tokens_in == r1.tokens_in + s["tokens_in"] and st.tokens_out == r1.tokens_out
    assert c.tokens == st.tokens_in + st.tokens_out
    c.close()


def test_call_log_is_readable_line_by_line_before_close(tmp_path):
    log = CallLog(tmp_path / "x.jsonl")
    log.write({"a": 1})
    assert json.loads((tmp_path / "x.jsonl").read_text()) == {"a": 1}  # flushed, not closed
    log.write({"b": 2})
    log.close()
    assert len((tmp_path / "x.jsonl").read_text().splitlines()) == 2


def test_score_calibration_arithmetic_and_cache(tmp_path):
    table = {("P", " a"): -1.0, ("P", " b"): -3.0, ("C", " a"): -2.5, ("C", " b"): -2.0}
    be = DeterministicBackend(score_fn=lambda p, c: table[(p, c)])
    c = make_client(LLMConfig(cache_dir=str(tmp_path / "c")), backend=be)
    req = ScoreRequest(purpose="proposal", prompt="P", continuations=(" a", " b"), calibration_prompt="C")
    r = c.score(req)
    assert r.raw == [-1.0, -3.0] and r.scores == [1.5, -1.0]
    r2 = c.score(req)
    assert r2.cached and r2.scores == r.scores and be.score_calls == 1
    r3 = c.score(ScoreRequest(purpose="proposal", prompt="P", continuations=(" a", " b")))
    assert r3.scores == r3.raw == [-1.0, -3.0]
    with pytest.raises(ValueError, match="continuations is empty"):
        c.score(ScoreRequest(purpose="proposal", prompt="P", continuations=()))


def test_bad_requests_have_clear_errors(tmp_path):
    c = make_client(LLMConfig(cache_dir=str(tmp_path / "c")), backend=DeterministicBackend())
    with pytest.raises(ValueError, match="messages is empty"):
        c.complete(_req(messages=()))
    with pytest.raises(ValueError, match="not a valid JSON Schema"):
        c.complete(_req(schema={"type": "no-such-type"}))
    with pytest.raises(TemplateError, match="valid templates"):
        c.complete(_req(template="no_such_template_xyz"))


def test_llm_sample_seed_is_deterministic_across_processes():
    here = llm_sample_seed(0, "candidates", "m1/c2", 3)
    code = "from interllm.core.seeding import llm_sample_seed; print(llm_sample_seed(0, 'candidates', 'm1/c2', 3))"
    there = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True,
                           env={"PYTHONHASHSEED": "7", "PATH": "/usr/bin"}).stdout.strip()
    assert int(there) == here and 0 <= here < 2**31
    assert len({llm_sample_seed(0, "candidates", j) for j in range(100)}) == 100
    assert llm_sample_seed("a", "b") != llm_sample_seed("b", "a") and llm_sample_seed(1, "x") != llm_sample_seed(2, "x")


def test_templates_load_render_and_hash(tmp_path):
    (tmp_path / "greet.txt").write_text('Room {room}; answer {{"ok": true}} for {obj}.')
    t = load_template("greet", tmp_path)
    import hashlib
    assert t.sha256 == hashlib.sha256((tmp_path / "greet.txt").read_bytes()).hexdigest()
    assert t.fields == ("room", "obj")
    assert t.render(room="kitchen", obj="cup") == 'Room kitchen; answer {"ok": true} for cup.'
    with pytest.raises(TemplateError, match=r"needs field\(s\) \['obj'\]"):
        t.render(room="kitchen")
    with pytest.raises(TemplateError, match=r"valid templates: \['greet'\]"):
        load_template("nope", tmp_path)


SCHEMAS = [
    SCHEMA,
    {"type": "object", "properties": {"plan": {"type": "array", "minItems": 2, "maxItems": 5, "items": {
        "type": "object", "properties": {"kind": {"enum": ["navigate", "pickup", "place"]},
                                         "furniture": {"type": "string", "minLength": 2},
                                         "cost": {"type": "number", "minimum": 0, "maximum": 20}},
        "required": ["kind", "furniture", "cost"]}}}, "required": ["plan"]},
    {"$defs": {"lvl": {"enum": ["easy", "medium", "hard"]}}, "type": "object",
     "properties": {"x": {"$ref": "#/$defs/lvl"}, "n": {"type": "integer", "minimum": 3, "maximum": 4},
                    "u": {"type": "array", "items": {"enum": [1, 2, 3]}, "minItems": 3, "uniqueItems": True},
                    "b": {"type": "boolean"}, "z": {"anyOf": [{"type": "null"}, {"type": "string"}]}},
     "required": ["x", "n", "u", "b", "z"]},
]


@pytest.mark.parametrize("schema", SCHEMAS)
def test_schema_instance_is_valid(schema):
    for seed in range(30):
        jsonschema.validate(schema_instance(schema, random.Random(seed)), schema)
