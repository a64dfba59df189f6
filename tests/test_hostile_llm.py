"""Hostile LLM servers and configs (issue #41, the LLM layer's cases): each ends in one message naming
the problem and the fix, with nothing already written lost and no key written anywhere. The servers
are fakes on 127.0.0.1 (tests/helpers/openai_server.py, tests/helpers/ollama_server.py).

4.  A key pasted as ``llm.api_key_env`` is refused without being echoed or written (config
    validation; ``pipeline.run`` checks its command line before Hydra writes .hydra/).
5.  A transient HTTP 500 changes no structured-output mode: the probe retries like any request, a
    persistent 5xx is a server error (not a missing capability), and a stage's workers use the
    mode its probe recorded.
7.  Log-probabilities that are not finite numbers (NaN, "abc") are a protocol error naming the URL
    and the field, never cached; ``interllm llm probe`` reports them without a traceback.
8.  A cache entry with a valid key and checksum but a foreign response layout is a named miss,
    recomputed and overwritten.
9.  Cached failures: the advised ``llm.cache_mode=retry_failures`` asks again and replaces them, so
    the next default run gets the answer from the cache.
13. Retry-After (seconds or HTTP-date) is honoured on 429/503 by both backends within
    ``llm.timeout_s``; a wait past it stops at once with a message that blames no model.
16. A key echoed by the server (a 400 body quoting the Authorization header) is redacted from the
    message, the log and stderr.
"""

from __future__ import annotations

import email.utils
import json
import logging
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from helpers.ollama_server import FakeOllama  # noqa: E402
from helpers.openai_server import MODEL, REQ, FakeOpenAI, free_port, openai_cfg  # noqa: E402

from interllm.config import ConfigError, LLMConfig, from_dict  # noqa: E402
from interllm.llm import LLMOutputError, ScoreRequest, make_client  # noqa: E402
from interllm.llm import retry as retry_mod  # noqa: E402
from interllm.llm.backend import preflight  # noqa: E402
from interllm.llm.cache import response_checksum  # noqa: E402
from interllm.llm.openai_backend import (  # noqa: E402
    OpenAIBackend,
    OpenAIProtocolError,
    OpenAIServerError,
    OpenAIUnavailable,
)
from interllm.llm.redact import redact  # noqa: E402
from interllm.llm.retry import ServerAskedToWait, retry_after_s  # noqa: E402
from interllm.llm.testing import DeterministicBackend  # noqa: E402
from interllm.llm.types import LLMOptions, Message  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
KEY = "gsk_4bcDEF0123456789ghijKLMNopqrSTUVwxyz"  # looks like a Groq key; fake
SECRET = "sk-test-SECRET-0123456789abcdef"


@pytest.fixture(autouse=True)
def _short_backoff(monkeypatch):
    """Retries without a Retry-After back off 50 ms (not 0.5 s) here, to keep the tests short."""
    monkeypatch.setattr(retry_mod, "BACKOFF_S", 0.05)


def _run(module: str, *args: str, env: dict | None = None, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", module, *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout, env={**os.environ, "INTERLLM_PROGRESS": "0", **(env or {})})


def _everything_under(folder: Path) -> bytes:
    return b"".join(p.read_bytes() for p in folder.rglob("*") if p.is_file()) if folder.exists() else b""


def _entries(cache: Path) -> list[Path]:
    return [p for p in cache.rglob("*.json") if p.name != "models.json"]


def _chat_times(srv) -> list[float]:
    return [t for path, t in srv.times if path.endswith("/chat/completions")]


def _asked(srv) -> int:
    """Chat requests for REQ (the probe's own chats left out)."""
    return sum(1 for path, body in srv.requests if path.endswith("/chat/completions") and
               "Where is the bed?" in json.dumps(body))


# -- 4. a key pasted as llm.api_key_env ----------------------------------------------------------------
@pytest.mark.parametrize("value", [KEY, "sk-proj-abc123XYZ", "openai_api_key", "1KEY", "A" * 65, ""])
def test_4_a_key_as_api_key_env_is_refused_without_showing_it(value):
    with pytest.raises(ConfigError) as e:
        LLMConfig(api_key_env=value).validate()
    msg = str(e.value)
    assert "config key 'llm.api_key_env'" in msg and "looks like a key itself" in msg
    assert "not written anywhere" in msg and "set llm.api_key_env=MY_API_KEY" in msg
    assert not value or value not in msg
    with pytest.raises(ConfigError) as e2:  # the params.yaml path (DVC, interllm llm probe)
        from_dict({"llm": {"api_key_env": value}})
    assert not value or value not in str(e2.value)


@pytest.mark.parametrize("name", ["OPENAI_API_KEY", "MY_VLLM_KEY", "_K", "GROQ_API_KEY_2"])
def test_4_environment_variable_names_are_accepted(name):
    LLMConfig(api_key_env=name).validate()


def test_4_pipeline_run_and_llm_probe_refuse_the_key_before_writing_anything(tmp_path):
    url = f"http://127.0.0.1:{free_port()}/v1"  # nothing listens: nothing may be asked anyway
    run = _run("pipeline.run", "experiment=quick", "llm=openai", f"llm.base_url={url}", f"llm.api_key_env={KEY}",
               f"hydra.run.dir={tmp_path / 'run'}")
    probe = _run("interllm.cli", "llm", "probe", "llm.backend=openai", f"llm.base_url={url}",
                 f"llm.api_key_env={KEY}", "--params", str(tmp_path / "none.yaml"), timeout=120)
    for r in (run, probe):
        assert r.returncode == 2, r.stderr[-2000:]
        assert "config key 'llm.api_key_env'" in r.stderr and "looks like a key itself" in r.stderr
        assert KEY not in r.stderr + r.stdout and "Traceback" not in r.stderr
    assert KEY.encode() not in _everything_under(tmp_path)
    assert not (tmp_path / "run" / ".hydra").exists()  # stopped before Hydra wrote its overrides


# -- 5. a transient 500 changes no mode ------------------------------------------------------------------
def test_5_a_transient_500_in_the_probe_is_retried_and_changes_no_mode(tmp_path):
    with FakeOpenAI(fault="status", status=500, fault_n=2) as srv:  # the first two chats get HTTP 500
        p = OpenAIBackend(openai_cfg(srv.base_url, tmp_path)).probe()
    assert p.json_schema == "json_schema" and not [n for n in p.notes if "refused" in n]
    with FakeOpenAI(fault="status", status=503, fault_n=1, fault_path="/completions") as srv:
        p = OpenAIBackend(openai_cfg(srv.base_url, tmp_path)).probe()
    assert p.logprobs is True and not p.notes


def test_5_a_persistent_500_is_a_server_error_not_a_missing_capability(tmp_path):
    with FakeOpenAI(fault="status", status=500, fault_path="/completions") as srv:
        with pytest.raises(OpenAIServerError) as e:  # score mode needs /completions
            OpenAIBackend(openai_cfg(srv.base_url, tmp_path, proposal_mode="score")).check()
        generate = OpenAIBackend(openai_cfg(srv.base_url, tmp_path)).probe()  # generate mode does not
    msg = str(e.value)
    assert f"the server at {srv.base_url}/completions (llm.base_url) failed: HTTP 500 after 4 attempts" in msg
    assert "not a capability the server lacks" in msg and "no prompt log-probabilities" not in msg
    assert generate.logprobs is False and "failed" in generate.notes[-1] and "HTTP 500" in generate.notes[-1]
    with FakeOpenAI(fault="status", status=502) as srv:  # every chat fails: no form is "refused"
        with pytest.raises(OpenAIServerError, match=rf"{srv.base_url}/chat/completions \(llm.base_url\) failed: "
                                                    r"HTTP 502"):
            OpenAIBackend(openai_cfg(srv.base_url, tmp_path)).probe()


def test_5_every_worker_uses_the_mode_the_stage_s_probe_recorded(tmp_path):
    from interllm.stages.inputs import stage_client
    from interllm.stages.missions import MissionWorker

    with FakeOpenAI() as srv:
        llm = {"backend": "openai", "model": MODEL, "base_url": srv.base_url, "cache_dir": str(tmp_path / "cache"),
               "proposal_mode": "generate", "cost_inference_mode": "generate"}
        cfg = from_dict({"llm": llm})
        recorded = {**preflight(cfg.llm), "json_schema": "json_object"}  # as if the stage's probe found json_object
        srv.requests.clear()
        client = stage_client(cfg, None, "candidates", probe=recorded)
        assert client.complete(REQ).parsed["room"] in ("kitchen", "bedroom")
        sent = list(srv.requests)
        worker = MissionWorker(cfg, tmp_path, tmp_path, tmp_path / "runs", {"llm_probe": recorded}, tmp_path / "c.jsonl")
        worker_mode = worker.client.backend.probe().json_schema
        worker.client.close()
        other = OpenAIBackend(cfg.llm)
        assert not other.adopt_probe({**recorded, "base_url": "http://127.0.0.1:1/v1"})  # another server's record
    assert [path for path, _ in sent] == ["POST /v1/chat/completions"]  # no probe of its own
    assert sent[0][1]["response_format"]["type"] == "json_object"
    assert worker_mode == "json_object"


# -- 7. log-probabilities that are not finite numbers -------------------------------------------------
@pytest.mark.parametrize("bad", [float("nan"), "abc", float("inf")])
def test_7_bad_logprobs_are_a_named_protocol_error_and_never_cached(tmp_path, bad):
    with FakeOpenAI(fault="bad_logprobs", bad_logprob=bad) as srv:
        client = make_client(openai_cfg(srv.base_url, tmp_path))  # generate mode: the probe only notes them
        with pytest.raises(OpenAIProtocolError) as e:
            client.score(ScoreRequest(purpose="score_objects", prompt="Useful item:", continuations=(" book",)))
        with pytest.raises(OpenAIProtocolError):  # score mode: refused before the experiment
            OpenAIBackend(openai_cfg(srv.base_url, tmp_path, proposal_mode="score")).check()
    msg = str(e.value)
    assert f"the server answered {srv.base_url}/completions (llm.base_url) with log-probabilities" in msg
    assert "choices[0].logprobs.token_logprobs[1] is " in msg and "not a finite number" in msg
    assert "nothing was cached" in msg and "llm.proposal_mode=generate" in msg
    assert not _entries(tmp_path / "cache")
    assert any("token_logprobs" in n for n in client.backend.probe().notes)


def test_7_llm_probe_reports_text_logprobs_without_a_traceback(tmp_path):
    params = tmp_path / "params.yaml"
    params.write_text("llm:\n  backend: openai\n  proposal_mode: score\n  cost_inference_mode: score\n")
    with FakeOpenAI(fault="bad_logprobs", bad_logprob="abc") as srv:
        r = _run("interllm.cli", "llm", "probe", f"llm.model={MODEL}", f"llm.base_url={srv.base_url}",
                 f"llm.cache_dir={tmp_path / 'cache'}", "--params", str(params), timeout=120)
    assert r.returncode == 2, r.stderr[-2000:]
    assert "Traceback" not in r.stderr
    assert "choices[0].logprobs.token_logprobs[1] is 'abc' (str), not a finite number" in r.stderr


# -- 8. a foreign layout behind a valid checksum ------------------------------------------------------
def _forge(path: Path, response: dict) -> None:
    """Give the entry at ``path`` another response, with its checksum redone (a valid entry of a foreign
    layout)."""
    e = json.loads(path.read_text())
    e["response"], e["checksum"] = response, response_checksum(response)
    path.write_text(json.dumps(e))


@pytest.mark.parametrize("kind", ["score", "complete"])
def test_8_a_foreign_layout_is_a_named_miss_recomputed_and_overwritten(tmp_path, caplog, kind):
    def ask(client):
        if kind == "score":
            return client.score(ScoreRequest(purpose="score_objects", prompt="Useful item:",
                                             continuations=(" book", " cup")))
        return client.complete(REQ)

    first = ask(make_client(LLMConfig(cache_dir=str(tmp_path / "cache")), backend=DeterministicBackend()))
    path = tmp_path / "cache" / first.key[:2] / f"{first.key}.json"
    good = path.read_bytes()
    _forge(path, {"answer": [0.1, 0.2], "format": "someone else's"})
    with caplog.at_level(logging.WARNING, logger="interllm.llm.cache"):
        again = ask(make_client(LLMConfig(cache_dir=str(tmp_path / "cache")), backend=DeterministicBackend()))
    assert not again.cached
    assert str(path) in caplog.text and "treating it as a miss and overwriting it" in caplog.text
    assert path.read_bytes() == good  # recomputed and overwritten


# -- 9. cached failures, and the advised way to ask again ----------------------------------------------
def test_9_retry_failures_replaces_cached_failures_so_the_next_default_run_gets_the_answer(tmp_path):
    with FakeOpenAI(fault="bad_json") as srv:  # the broken server: the failure is cached
        with pytest.raises(LLMOutputError):
            make_client(openai_cfg(srv.base_url, tmp_path, repair_retries=0)).complete(REQ)
    [entry] = _entries(tmp_path / "cache")
    assert json.loads(entry.read_text())["response"]["failed"] is True
    with FakeOpenAI() as srv:  # fixed
        with pytest.raises(LLMOutputError):  # a default run replays the failure without asking
            make_client(openai_cfg(srv.base_url, tmp_path, repair_retries=0)).complete(REQ)
        asked_default = _asked(srv)
        off = make_client(openai_cfg(srv.base_url, tmp_path, repair_retries=0, cache_mode="off")).complete(REQ)
        assert json.loads(entry.read_text())["response"]["failed"] is True  # off writes nothing
        retried = make_client(openai_cfg(srv.base_url, tmp_path, repair_retries=0,
                                         cache_mode="retry_failures")).complete(REQ)
        asked_retry = _asked(srv)
        again = make_client(openai_cfg(srv.base_url, tmp_path, repair_retries=0)).complete(REQ)
        asked_after = _asked(srv)
    assert not retried.cached and retried.text == off.text
    assert "failed" not in json.loads(entry.read_text())["response"]
    assert again.cached and again.text == retried.text and asked_after == asked_retry == 2  # off, retry_failures
    assert asked_default == 0  # the failure came from the cache
    from interllm.llm.health import failure_share_message

    advice = failure_share_message(backend="openai", model=MODEL, n_calls=20, n_failed=20, bound=0.05, sample="x",
                                   where="candidates stage", n_cached=20, cache_dir="c")
    assert "rerun once with llm.cache_mode=retry_failures to ask it again" in advice


# -- 13. Retry-After --------------------------------------------------------------------------------
def _gen(backend) -> str:
    opts = LLMOptions(temperature=0.0, max_tokens=16)
    return backend.generate((Message("user", "Where is the bed?"),), REQ.schema, opts, seed=1).text


def test_13_openai_waits_as_long_as_retry_after_asks(tmp_path):
    for retry_after, n in (("1", 2), (None, 1)):
        retry_after = retry_after or email.utils.formatdate(time.time() + 2.0, usegmt=True)  # a date 1-2 s ahead
        with FakeOpenAI(fault="status", status=429, fault_n=n, retry_after=retry_after) as srv:
            be = OpenAIBackend(openai_cfg(srv.base_url, tmp_path, timeout_s=10.0))
            be._schema_mode = "json_schema"
            assert json.loads(_gen(be))["room"] in ("kitchen", "bedroom")
            times = _chat_times(srv)
        assert len(times) == n + 1
        assert all(b - a >= 0.9 for a, b in zip(times, times[1:], strict=False)), (retry_after, times)


@pytest.mark.parametrize("status", [429, 503])
def test_13_openai_a_retry_after_past_the_deadline_stops_at_once(tmp_path, status):
    with FakeOpenAI(fault="status", status=status, retry_after="30") as srv:
        be = OpenAIBackend(openai_cfg(srv.base_url, tmp_path, timeout_s=2.0))
        be._schema_mode = "json_schema"
        t0 = time.monotonic()
        with pytest.raises(ServerAskedToWait) as e:
            _gen(be)
        took = time.monotonic() - t0
        asked = len(_chat_times(srv))
    msg = str(e.value)
    assert took < 1.5 and asked == 1
    assert f"the server at {srv.base_url}/chat/completions (llm.base_url) answered HTTP {status}" in msg
    assert "asked to wait 30 s" in msg and "beyond llm.timeout_s=2 s" in msg and "raise llm.timeout_s" in msg
    assert "model" not in msg  # a rate limit is no model's fault


def test_13_retries_stay_within_llm_timeout_s(tmp_path):
    with FakeOpenAI(fault="status", status=500) as srv:  # a backoff past the deadline ends the retries
        be = OpenAIBackend(openai_cfg(srv.base_url, tmp_path, timeout_s=0.5, max_retries=10))
        be._schema_mode = "json_schema"
        t0 = time.monotonic()
        with pytest.raises(OpenAIServerError, match=r"HTTP 500 after \d+ attempts \(llm.max_retries=10, within "
                                                    r"llm.timeout_s=0.5 s\)"):
            _gen(be)
    assert time.monotonic() - t0 < 1.0


def _ollama(host: str, tmp_path, **kw):
    from interllm.llm.ollama_backend import OllamaBackend

    return OllamaBackend(LLMConfig(backend="ollama", model="fixture-model", host=host,
                                   cache_dir=str(tmp_path / "cache"), **kw))


def test_13_ollama_waits_as_long_as_retry_after_asks(tmp_path):
    with FakeOllama(fault="status", status=503, fault_n=2, retry_after="1") as srv:
        assert json.loads(_gen(_ollama(srv.host, tmp_path, timeout_s=10.0)))["room"] in ("kitchen", "bedroom")
        times = list(srv.times)
    assert len(times) == 3 and all(b - a >= 0.9 for a, b in zip(times, times[1:], strict=False)), times


def test_13_ollama_a_retry_after_past_the_deadline_stops_at_once(tmp_path):
    with FakeOllama(fault="status", status=429, retry_after="30") as srv:
        t0 = time.monotonic()
        with pytest.raises(ServerAskedToWait) as e:
            _gen(_ollama(srv.host, tmp_path, timeout_s=2.0))
        took, asked = time.monotonic() - t0, len(srv.times)
    msg = str(e.value)
    assert took < 1.5 and asked == 1
    assert f"the Ollama server at {srv.host}/api/chat (llm.host) answered HTTP 429" in msg
    assert "asked to wait 30 s" in msg and "beyond llm.timeout_s=2 s" in msg and "model" not in msg


def test_13_retry_after_reads_seconds_dates_and_milliseconds():
    now = 1_700_000_000.0
    assert retry_after_s({"retry-after": "7"}, now) == 7.0
    assert retry_after_s({"Retry-After": email.utils.formatdate(now + 5, usegmt=True)}, now) == pytest.approx(5.0)
    assert retry_after_s({"retry-after": email.utils.formatdate(now - 60, usegmt=True)}, now) == 0.0
    assert retry_after_s({"retry-after-ms": "250", "retry-after": "9"}, now) == 0.25
    assert retry_after_s({"retry-after": "soon"}, now) is None and retry_after_s({}, now) is None


# -- 16. a key echoed by the server ------------------------------------------------------------------
def test_16_a_key_echoed_in_a_400_body_is_redacted_everywhere(tmp_path, monkeypatch, caplog, capsys):
    monkeypatch.setenv("INTERLLM_TEST_KEY", SECRET)
    with FakeOpenAI(fault="echo_key_400") as srv:
        cfg = openai_cfg(srv.base_url, tmp_path, api_key_env="INTERLLM_TEST_KEY")
        client = make_client(cfg, call_log_path=tmp_path / "calls.jsonl")
        client.backend._schema_mode = "json_schema"
        with caplog.at_level(logging.DEBUG):
            with pytest.raises(OpenAIUnavailable) as e:
                client.complete(REQ)
            with pytest.raises(OpenAIUnavailable) as probe_error:  # the probe: every chat gets the 400
                OpenAIBackend(cfg).probe()
        client.close()
        r = _run("interllm.cli", "llm", "probe", "llm.backend=openai", f"llm.model={MODEL}",
                 f"llm.base_url={srv.base_url}", "llm.api_key_env=INTERLLM_TEST_KEY", "--params",
                 str(tmp_path / "none.yaml"), env={"INTERLLM_TEST_KEY": SECRET}, timeout=120)
    out = capsys.readouterr()
    assert "answered HTTP 400" in str(e.value) and "Bearer [redacted]" in str(e.value)
    assert r.returncode == 2 and "answered HTTP 400" in r.stderr and "Traceback" not in r.stderr
    for text in (str(e.value), str(probe_error.value), caplog.text, out.out, out.err, r.stdout, r.stderr):
        assert SECRET not in text
    assert SECRET.encode() not in _everything_under(tmp_path)


def test_16_redaction_covers_bearer_tokens_and_the_key_and_is_idempotent():
    text = 'headers: {"Authorization": "Bearer tok-from-elsewhere-123"} and the key sk-test-SECRET-0123456789abcdef'
    once = redact(text, [SECRET])
    assert "tok-from-elsewhere-123" not in once and SECRET not in once
    assert once == 'headers: {"Authorization": "Bearer [redacted]"} and the key [redacted]'
    assert redact(once, [SECRET]) == once
