"""The OpenAI-compatible backend: faults against a server we control, the probe, the key kept
secret; and the paper's generate loop end to end against a real server (llama-cpp-python's own
OpenAI-compatible server on the embedded GGUF), replayed byte for byte from the cache."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from helpers.openai_server import MODEL, REQ, FakeOpenAI, free_port, llama_server, openai_cfg  # noqa: E402

from interllm.config import LLMConfig, from_dict  # noqa: E402
from interllm.llm import LLMOutputError, ScoreRequest, make_client  # noqa: E402
from interllm.llm.deadline import DeadlineExceeded  # noqa: E402
from interllm.llm.openai_backend import OpenAIBackend, OpenAIUnavailable  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def _entries(cache: Path) -> list[Path]:
    return [p for p in cache.rglob("*.json") if p.name != "models.json"]


def _chats(srv) -> list:
    return [b for path, b in srv.requests if path.endswith("/chat/completions")]


def test_a_429_is_retried_and_cached_once(tmp_path):
    with FakeOpenAI(fault="429_once") as srv:
        client = make_client(openai_cfg(srv.base_url, tmp_path))
        assert client.backend.probe().json_schema == "json_schema"  # its first chat got the 429, then a retry
        assert len(_chats(srv)) == 1 + 1 + 2  # the 429, the retried schema check, the seed check twice
        r = client.complete(REQ)
        assert r.parsed["room"] in ("kitchen", "bedroom") and not r.cached
        assert client.complete(REQ).cached and len(_chats(srv)) == 5
    assert len(_entries(tmp_path / "cache")) == 1


def test_a_hang_past_timeout_is_a_clear_error_within_the_bound(tmp_path):
    with FakeOpenAI(fault="hang", hang_s=20) as srv:
        client = make_client(openai_cfg(srv.base_url, tmp_path, timeout_s=1.0))
        client.backend._schema_mode = "json_schema"
        t0 = time.monotonic()
        with pytest.raises(DeadlineExceeded) as e:
            client.complete(REQ)
        took = time.monotonic() - t0
    assert took < 5, took
    assert f"{srv.base_url}/chat/completions (llm.base_url)" in str(e.value) and "llm.timeout_s=1" in str(e.value)
    assert not _entries(tmp_path / "cache")  # nothing half-written


def test_invalid_json_despite_the_schema_is_repaired_then_named(tmp_path):
    with FakeOpenAI(fault="bad_json") as srv:
        client = make_client(openai_cfg(srv.base_url, tmp_path, repair_retries=2))
        with pytest.raises(LLMOutputError, match=r"stayed invalid after 2 repair retries .*not valid JSON"):
            client.complete(REQ)
        probe_chats = 4  # the probe's three schema forms (none keeps to the schema) and its seed check twice
        assert len(_chats(srv)) - probe_chats - 1 == 3  # the answer and two repairs
        assert client.backend.probe().json_schema == "prompt"  # the server keeps to no schema
        last = _chats(srv)[-1]
        assert "JSON Schema" in last["messages"][-1]["content"] or "invalid" in last["messages"][-1]["content"]
    stored = [json.loads(p.read_text())["response"] for p in _entries(tmp_path / "cache")]
    assert [r.get("failed") for r in stored] == [True]  # the outcome is kept whole, as a failure


def test_the_probe_reports_what_the_server_does(tmp_path):
    with FakeOpenAI() as srv:
        p = OpenAIBackend(openai_cfg(srv.base_url, tmp_path)).probe()
    assert (p.models_listed, p.json_schema, p.logprobs, p.seed_honoured, p.context_length, p.fingerprint) == (
        [MODEL], "json_schema", True, True, 4096, "fp_fixture")


def test_the_cache_key_follows_model_and_fingerprint_not_the_url(tmp_path):
    ids = {}
    for name, fp in (("a", "fp_1"), ("b", "fp_1"), ("c", "fp_2")):
        with FakeOpenAI(fingerprint=fp) as srv:
            ids[name] = OpenAIBackend(openai_cfg(srv.base_url, tmp_path)).model_id()
    assert ids["a"] == ids["b"] != ids["c"]  # a and b differ only by their port


def test_score_mode_without_prompt_logprobs_stops_with_the_mode_to_use(tmp_path):
    with FakeOpenAI(fault="no_logprobs") as srv:
        be = OpenAIBackend(openai_cfg(srv.base_url, tmp_path, proposal_mode="score"))
        with pytest.raises(OpenAIUnavailable, match=r"no prompt log-probabilities .*use llm.proposal_mode=generate "
                                                     r"llm.cost_inference_mode=generate"):
            be.check()


def test_score_reads_the_continuations_log_probabilities(tmp_path):
    with FakeOpenAI() as srv:
        client = make_client(openai_cfg(srv.base_url, tmp_path, proposal_mode="score"))
        r = client.score(ScoreRequest(purpose="score_objects", prompt="Useful item:", continuations=(" apple", " book")))
    from interllm.core.seeding import llm_sample_seed

    assert r.raw == pytest.approx([-1.0 - llm_sample_seed(" apple") / 2**31, -1.0 - llm_sample_seed(" book") / 2**31])


def test_a_missing_model_names_what_the_server_serves(tmp_path):
    with FakeOpenAI() as srv:
        with pytest.raises(OpenAIUnavailable, match=r"'gpt-9' \(llm.model\) is not served .* it serves \['fixture-gpt'\]"):
            OpenAIBackend(openai_cfg(srv.base_url, tmp_path, model="gpt-9")).check()


def test_the_key_is_never_written(tmp_path, monkeypatch):
    secret = "sk-test-0123456789abcdef"
    monkeypatch.setenv("INTERLLM_TEST_KEY", secret)
    with FakeOpenAI() as srv:
        client = make_client(openai_cfg(srv.base_url, tmp_path, api_key_env="INTERLLM_TEST_KEY"),
                             call_log_path=tmp_path / "calls.jsonl")
        client.complete(REQ)
        client.close()
    written = b"".join(p.read_bytes() for p in tmp_path.rglob("*") if p.is_file())
    assert written and secret.encode() not in written


def test_a_server_that_is_down_stops_the_run_before_any_stage_writes(tmp_path):
    url = f"http://127.0.0.1:{free_port()}/v1"
    r = subprocess.run([sys.executable, "-m", "pipeline.run", "experiment=quick", "llm=openai", f"llm.base_url={url}",
                        f"hydra.run.dir={tmp_path / 'run'}"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert r.returncode == 2, r.stderr[-2000:]
    assert f"the OpenAI-compatible server at {url} (llm.base_url) is not reachable" in r.stderr
    assert "python -m llama_cpp.server" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "run" / "data").exists()


def test_llm_probe_command_prints_the_probe(tmp_path):
    with FakeOpenAI() as srv:
        r = subprocess.run([sys.executable, "-m", "interllm.cli", "llm", "probe", "llm.backend=openai",
                            f"llm.model={MODEL}", f"llm.base_url={srv.base_url}"], cwd=ROOT, capture_output=True,
                           text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["json_schema"] == "json_schema" and out["logprobs"] is True and out["fingerprint"] == "fp_fixture"


# -- a real server ------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def real_server():
    from interllm.llm.model_files import resolve_model_path

    with llama_server(str(resolve_model_path(""))) as base:
        yield base


def _generate_loop(real_server, tmp_path, overrides: dict) -> None:
    """The quick experiment in generate mode through the server, then replayed with no server."""
    from interllm.stages.pipeline import run_all

    llm = {"backend": "openai", "model": "gemma3-270m", "base_url": real_server, "proposal_mode": "generate",
           "cost_inference_mode": "generate", "cache_dir": str(tmp_path / "cache"), "max_tokens": 256,
           # the 270M model may ramble past max_tokens in generate mode; this test is about the loop over
           # HTTP, not the model's answers (the failure-share stop has its own tests in test_robustness.py)
           "max_failure_share": 0.5,
           # the server answers the two workers' requests in turn; on a loaded machine a request can wait
           # longer than the default deadline behind the other's, and this test is not about speed
           "timeout_s": 600}
    base = {"jobs": 2, "scene": {"n_scenes": 1}, "mission": {"n_missions": 1}, **overrides}
    run_all(from_dict({**base, "llm": llm}), tmp_path / "live")
    calls = [json.loads(x) for x in (tmp_path / "live" / "candidates" / "llm_calls.jsonl").read_text().splitlines()]
    assert calls and all(c["backend"] == "openai" and not c["cache_hit"] for c in calls)
    assert {c["purpose"] for c in calls} == {"rooms_for_candidates", "candidates"}  # rooms first (expansion)
    runs = [json.loads(x) for x in (tmp_path / "live" / "runs" / "llm_calls.jsonl").read_text().splitlines()]
    assert "regeneration" in {c["purpose"] for c in runs}  # the checker's violations went back to the model
    usage = json.loads((tmp_path / "live" / "metrics" / "llm_usage.json").read_text())
    for planner, u in usage["missions"].items():  # every planner's requests, counted by phase
        assert u["requests"] == sum(1 for c in runs if c["planner"] == planner)
        assert u["requests"] == sum(p["requests"] for p in u["phases"].values())
    assert sum(u["phases"].get("repair", {}).get("requests", 0) for u in usage["missions"].values()) >= 1
    probe = json.loads((tmp_path / "live" / "candidates" / "llm_probe.json").read_text())
    assert probe["json_schema"] == "json_object" and probe["logprobs"] is True
    assert json.loads((tmp_path / "live" / "runs" / "provenance.json").read_text())["llm_probe"] == probe
    gone = f"http://127.0.0.1:{free_port()}/v1"  # no server at all: every answer comes from the cache
    run_all(from_dict({**base, "llm": {**llm, "cache_mode": "replay", "base_url": gone}}), tmp_path / "replayed")
    assert (tmp_path / "replayed" / "metrics" / "metrics.json").read_bytes() == \
        (tmp_path / "live" / "metrics" / "metrics.json").read_bytes()


@pytest.mark.integration
@pytest.mark.embedded
def test_the_paper_generate_loop_through_a_real_server(real_server, tmp_path, monkeypatch):
    """One planner, one candidate, one repair round: the generate loop's every request kind over HTTP
    (candidates, regeneration, replan) in about two minutes; the slow test below runs all of it."""
    monkeypatch.setenv("INTERLLM_PROGRESS", "0")
    _generate_loop(real_server, tmp_path, {"planner": {"names": ["moma_llm"], "M": 1, "max_regenerations": 1,
                                                       "moma_llm": {"max_replans": 1}}})


@pytest.mark.integration
@pytest.mark.slow
@pytest.mark.embedded
def test_the_quick_experiment_in_generate_mode_through_a_real_server(real_server, tmp_path, monkeypatch):
    """All three planners with the default M and bounds (about 15 minutes on 2 cores)."""
    monkeypatch.setenv("INTERLLM_PROGRESS", "0")
    _generate_loop(real_server, tmp_path, {})


@pytest.mark.integration
@pytest.mark.embedded
def test_score_mode_over_http_agrees_with_the_embedded_model(real_server, tmp_path):
    """The same GGUF scored through the server's echoed log-probabilities and in process."""
    import numpy as np

    prompt, conts = "The cat sat on the", (" mat", " moon", " chair")
    cfg = LLMConfig(backend="openai", model="gemma3-270m", base_url=real_server, cache_mode="off",
                    cache_dir=str(tmp_path / "c"), proposal_mode="score", timeout_s=600)
    http = make_client(cfg).score(ScoreRequest(purpose="t", prompt=prompt, continuations=conts))
    local = make_client(LLMConfig(cache_mode="off", cache_dir=str(tmp_path / "c2"))).score(
        ScoreRequest(purpose="t", prompt=prompt, continuations=conts))
    assert np.argsort(http.raw).tolist() == np.argsort(local.raw).tolist()
    assert http.raw == pytest.approx(local.raw, abs=0.5)
    assert OpenAIBackend(cfg).probe().logprobs


def test_keys_are_env_var_names(tmp_path):
    from interllm.config import ConfigError

    with pytest.raises(ConfigError, match="llm.api_key_env"):
        LLMConfig(api_key_env="sk-abc-123").validate()
    assert LLMConfig().api_key_env == "OPENAI_API_KEY"  # the config names the variable, never holds a key
    LLMConfig(api_key_env="MY_VLLM_KEY").validate()
