"""Response cache: stable keys, sensitivity to every request field, replay misses, concurrent
writers, corrupt entries, byte-stable entries."""

from __future__ import annotations

import dataclasses
import json
import logging
import subprocess
import sys
from pathlib import Path

import pytest

from interllm.config import LLMConfig
from interllm.llm import (
    CacheMissError,
    LLMOptions,
    LLMRequest,
    Message,
    ResponseCache,
    ScoreRequest,
    make_client,
)
from interllm.llm import prompts as prompts_mod
from interllm.llm.testing import DeterministicBackend

REPO = Path(__file__).resolve().parents[1]
SCHEMA = {"type": "object", "properties": {"a": {"type": "integer", "minimum": 0, "maximum": 9}},
          "required": ["a"]}
BASE = LLMRequest(purpose="candidates", messages=(Message("system", "s"), Message("user", "u")),
                  schema=SCHEMA, options=LLMOptions(temperature=0.8, seed=1, top_p=0.9, max_tokens=40,
                                                    sample_index=0))

KEY_SCRIPT = """
import sys
from interllm.config import LLMConfig
from interllm.llm import LLMOptions, LLMRequest, Message, make_client
from interllm.llm.testing import DeterministicBackend
schema = {"type": "object", "properties": {"a": {"type": "integer", "minimum": 0, "maximum": 9}},
          "required": ["a"]}
req = LLMRequest(purpose="candidates", messages=(Message("system", "s"), Message("user", "u")),
                 schema=schema, options=LLMOptions(temperature=0.8, seed=1, top_p=0.9, max_tokens=40))
c = make_client(LLMConfig(cache_dir=sys.argv[1]), backend=DeterministicBackend())
print(c.complete_key(req)[0])
"""


def _client(tmp_path, mode="readwrite", backend=None, **kw):
    cfg = LLMConfig(cache_dir=str(tmp_path / "cache"), cache_mode=mode, **kw)
    return make_client(cfg, backend=backend or DeterministicBackend())


def test_key_is_stable_across_processes(tmp_path):
    here = _client(tmp_path).complete_key(BASE)[0]
    outs = {subprocess.run([sys.executable, "-c", KEY_SCRIPT, str(tmp_path / "cache")], cwd=REPO,
                           capture_output=True, text=True, check=True,
                           env={"PYTHONHASHSEED": str(i), "PATH": "/usr/bin"}).stdout.strip()
            for i in (1, 2)}
    assert outs == {here}
    assert len(here) == 64 and int(here, 16) >= 0


def _variants():
    o = BASE.options
    yield "messages.content", dataclasses.replace(BASE, messages=(Message("system", "s"), Message("user", "v")))
    yield "messages.role", dataclasses.replace(BASE, messages=(Message("user", "s"), Message("user", "u")))
    yield "messages.count", dataclasses.replace(BASE, messages=BASE.messages[:1])
    yield "schema", dataclasses.replace(BASE, schema={**SCHEMA, "required": []})
    yield "no schema", dataclasses.replace(BASE, schema=None)
    for f, v in (("temperature", 0.7), ("seed", 2), ("top_p", 0.95), ("max_tokens", 41), ("sample_index", 1)):
        yield f"options.{f}", dataclasses.replace(BASE, options=dataclasses.replace(o, **{f: v}))


def test_key_is_sensitive_to_every_field(tmp_path, monkeypatch):
    c = _client(tmp_path)
    base = c.complete_key(BASE)[0]
    keys = {"base": base}
    for name, req in _variants():
        keys[name] = c.complete_key(req)[0]
    # labels and purpose do not change the answer, so they do not change the key
    assert c.complete_key(dataclasses.replace(BASE, purpose="x", context=(("planner", "p"),)))[0] == base
    # template: its name and its file hash
    d = tmp_path / "prompts"
    d.mkdir()
    (d / "t.txt").write_text("Hello {name}")
    monkeypatch.setattr(prompts_mod, "PROMPT_DIR", d)
    keys["template"] = c.complete_key(dataclasses.replace(BASE, template="t"))[0]
    (d / "t.txt").write_text("Hello {name}!")
    keys["template text"] = c.complete_key(dataclasses.replace(BASE, template="t"))[0]
    # model identity and backend
    keys["model"] = _client(tmp_path, backend=DeterministicBackend(model="other")).complete_key(BASE)[0]
    be = DeterministicBackend()
    be.name = "other-backend"
    keys["backend"] = _client(tmp_path, backend=be).complete_key(BASE)[0]
    assert len(set(keys.values())) == len(keys), keys
    # score keys: kind, prompt, continuations (order too), calibration prompt
    s = ScoreRequest(purpose="p", prompt="x", continuations=(" a", " b"), calibration_prompt="c")
    skeys = [c.score_key(r)[0] for r in (
        s, dataclasses.replace(s, prompt="y"), dataclasses.replace(s, continuations=(" b", " a")),
        dataclasses.replace(s, continuations=(" a",)), dataclasses.replace(s, calibration_prompt=None),
        dataclasses.replace(s, calibration_prompt="d"))]
    assert len(set(skeys) | {base}) == len(skeys) + 1


def test_replay_miss_names_purpose_key_and_fix(tmp_path):
    c = _client(tmp_path, mode="replay")
    key = c.complete_key(BASE)[0]
    with pytest.raises(CacheMissError) as e:
        c.complete(BASE)
    msg = str(e.value)
    assert "candidates" in msg and key in msg and "llm.cache_mode=readwrite" in msg
    # filled in readwrite mode, replay then answers without the backend
    filled = _client(tmp_path).complete(BASE)
    be = DeterministicBackend()
    r = _client(tmp_path, mode="replay", backend=be).complete(BASE)
    assert r.cached and r.text == filled.text and be.generate_calls == 0


def test_off_mode_neither_reads_nor_writes(tmp_path):
    be = DeterministicBackend()
    c = _client(tmp_path, mode="off", backend=be)
    c.complete(BASE)
    c.complete(BASE)
    assert be.generate_calls == 2 and not (tmp_path / "cache" / "00").exists()
    assert not list((tmp_path / "cache").rglob("*.json"))


def test_entry_layout_is_byte_stable_and_small(tmp_path):
    r = _client(tmp_path).complete(BASE)
    path = tmp_path / "cache" / r.key[:2] / f"{r.key}.json"
    first = path.read_bytes()
    entry = json.loads(first)
    assert set(entry) == {"cache_format", "checksum", "key", "request", "response"}
    assert "latency" not in first.decode() and entry["response"]["tokens_in"] == r.tokens_in
    assert list(entry["response"]) == sorted(entry["response"])
    # a second cache dir filled by another client holds identical bytes
    r2 = make_client(LLMConfig(cache_dir=str(tmp_path / "cache2")), backend=DeterministicBackend()).complete(BASE)
    assert (tmp_path / "cache2" / r.key[:2] / f"{r.key}.json").read_bytes() == first and r2.key == r.key
    assert len(first) < 2000


@pytest.mark.parametrize("damage", ["truncate", "checksum", "wrong_key"])
def test_corrupt_entry_is_a_reported_miss_then_overwritten(tmp_path, caplog, damage):
    c = _client(tmp_path)
    r = c.complete(BASE)
    path = tmp_path / "cache" / r.key[:2] / f"{r.key}.json"
    good = path.read_bytes()
    if damage == "truncate":
        path.write_bytes(good[: len(good) // 2])
    elif damage == "checksum":
        e = json.loads(good)
        e["response"]["text"] = '{"a": 7}' if e["response"]["text"] != '{"a": 7}' else '{"a": 8}'
        path.write_text(json.dumps(e))
    else:
        e = json.loads(good)
        e["key"] = "0" * 64
        path.write_text(json.dumps(e))
    be = DeterministicBackend()
    c2 = _client(tmp_path, backend=be)
    with caplog.at_level(logging.WARNING, logger="interllm.llm.cache"):
        r2 = c2.complete(BASE)
    assert not r2.cached and be.generate_calls == 1
    assert any("corrupt" in rec.getMessage() for rec in caplog.records)
    assert path.read_bytes() == good  # overwritten with the regenerated (deterministic) entry
    # replay mode never returns a corrupt entry
    path.write_bytes(b"{not json")
    with pytest.raises(CacheMissError):
        _client(tmp_path, mode="replay").complete(BASE)


WRITER = """
import os, sys, time
from interllm.config import LLMConfig
from interllm.llm import LLMOptions, LLMRequest, Message, make_client
from interllm.llm.testing import DeterministicBackend
cache, a, b, ready, go = sys.argv[1:]
c = make_client(LLMConfig(cache_dir=cache), backend=DeterministicBackend())
open(ready, "w").close()  # set up; both writers start writing together, when the test says go
deadline = time.monotonic() + 120
while not os.path.exists(go):
    if time.monotonic() > deadline:
        sys.exit("writer: no go within 120 s")
    time.sleep(0.001)
for i in range(int(a), int(b)):
    c.complete(LLMRequest(purpose="w", messages=(Message("user", f"q{i}"),),
                          schema={"type": "object", "properties": {"n": {"type": "integer"}}, "required": ["n"]},
                          options=LLMOptions(sample_index=i % 3)))
print(c.stats.cache_hits)
"""


def test_concurrent_writers_lose_nothing(tmp_path):
    from helpers.waits import assert_running, wait_until

    # process 0 writes q0..q59, process 1 q30..q89: 30 shared keys written by both at once (both set up
    # first, then started together: a writer's start-up does not decide whether they overlap)
    ready, go = [tmp_path / "ready0", tmp_path / "ready1"], tmp_path / "go"
    procs = [subprocess.Popen([sys.executable, "-c", WRITER, str(tmp_path / "cache"), str(a), str(b), str(r), str(go)],
                              cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for (a, b), r in zip(((0, 60), (30, 90)), ready, strict=True)]
    try:
        wait_until(lambda: all(r.exists() for r in ready), timeout=120, what="both cache writers set up",
                   gone=lambda: any(p.poll() is not None for p in procs))
        for p in procs:
            assert_running(p, "a cache writer waiting for the go")
        go.touch()
        outs = [p.communicate(timeout=120) for p in procs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait(timeout=30)
    assert all(p.returncode == 0 for p in procs), outs
    cache = ResponseCache(tmp_path / "cache")
    entries = list((tmp_path / "cache").glob("??/*.json"))
    assert len(entries) == 90
    assert all(cache.get(p.stem) is not None for p in entries) and cache.corrupt == 0
    assert not list((tmp_path / "cache").rglob("*.tmp"))


def test_the_first_answer_stored_wins_and_every_process_goes_on_with_it(tmp_path):
    """Two workers ask the same request of a server whose answers vary; the second to finish must
    use the first one's answer (the one a replay will give), not its own."""
    answers = iter(['{"a": 1}', '{"a": 2}'])
    slow = make_client(LLMConfig(cache_dir=str(tmp_path / "cache")),
                       backend=DeterministicBackend(generate_fn=lambda *a: next(answers)))
    first = slow.complete(BASE)  # stored: {"a": 1}
    path = slow.cache.path_for(first.key)
    other = make_client(LLMConfig(cache_dir=str(tmp_path / "cache")),
                        backend=DeterministicBackend(generate_fn=lambda *a: '{"a": 7}'))
    # the other worker started before the entry existed: it asks the backend, then finds the entry
    resp = other._core.cache.put(first.key, {}, {"text": '{"a": 7}', "tokens_in": 1, "tokens_out": 1, "errors": [],
                                                 "attempts": 1})
    assert resp["text"] == '{"a": 1}' and json.loads(path.read_text())["response"]["text"] == '{"a": 1}'
    path.unlink()
    path.parent.mkdir(exist_ok=True)
    path.write_text("not json")  # a corrupt entry is replaced by the next answer
    assert other._core.cache.put(first.key, {}, {"text": "x", "tokens_in": 0, "tokens_out": 0, "errors": [],
                                                 "attempts": 1})["text"] == "x"
    assert json.loads(path.read_text())["response"]["text"] == "x"


def test_a_client_that_loses_the_race_returns_the_stored_answer(tmp_path):
    a = make_client(LLMConfig(cache_dir=str(tmp_path / "cache")),
                    backend=DeterministicBackend(generate_fn=lambda *x: '{"a": 1}'))

    def meanwhile(*x):  # while B's backend works, A answers the same request and stores it
        a.complete(BASE)
        return '{"a": 7}'

    b = make_client(LLMConfig(cache_dir=str(tmp_path / "cache")), backend=DeterministicBackend(generate_fn=meanwhile))
    r = b.complete(BASE)
    assert not r.cached and r.parsed == {"a": 1} and r.text == '{"a": 1}'


def test_prune_keeps_exactly_the_entries_the_call_logs_name(tmp_path, monkeypatch):
    from interllm.cli import main

    cache = ResponseCache(tmp_path / "cache")
    for key in ("a" * 64, "b" * 64, "c" * 64):
        cache.put(key, {"purpose": "test"}, {"text": key[0]})
    log = tmp_path / "run" / "llm_calls.jsonl"
    log.parent.mkdir()
    log.write_text(json.dumps({"key": "a" * 64}) + "\n" + json.dumps({"key": "c" * 64}) + "\n{torn", encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    assert main(["cache", "prune", "--dir", "cache", "--keep", "run/*.jsonl"]) == 0  # a dry run
    assert len(list((tmp_path / "cache").glob("*/*.json"))) == 3
    assert main(["cache", "prune", "--dir", "cache", "--keep", "run/*.jsonl", "--delete"]) == 0
    assert sorted(p.stem[0] for p in (tmp_path / "cache").glob("*/*.json")) == ["a", "c"]
    assert main(["cache", "prune", "--dir", "cache", "--keep", "nothing/*.jsonl", "--delete"]) == 2  # keeps all
    assert len(list((tmp_path / "cache").glob("*/*.json"))) == 2


def test_every_answer_the_tests_replay_is_committed():
    """tests/replayed_llm_calls.jsonl lists the committed cache entries the test suite reads (made
    with tests/helpers/cache_reads); `interllm cache prune` keeps them only if the list is complete
    and each listed entry is still in data/llm_cache."""
    from interllm.llm.cache import keys_in_call_logs

    root = Path(__file__).resolve().parent.parent
    listed = keys_in_call_logs([root / "tests" / "replayed_llm_calls.jsonl"])
    assert len(listed) > 100  # the quick experiment, the ProcTHOR house, the default run's replays
    missing = sorted(k for k in listed if not (root / "data" / "llm_cache" / k[:2] / f"{k}.json").is_file())
    assert not missing, f"{len(missing)} listed entries are not in data/llm_cache, e.g. {missing[:3]}"
