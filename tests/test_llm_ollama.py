"""Ollama backend over real HTTP on 127.0.0.1 against the protocol fixture (and a real Ollama
if one answers on 127.0.0.1:11434)."""

from __future__ import annotations

import math
import sys
import urllib.request
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from helpers.ollama_server import FakeOllama, free_port  # noqa: E402

from interllm.config import LLMConfig  # noqa: E402
from interllm.core.seeding import llm_sample_seed  # noqa: E402
from interllm.llm import LLMRequest, Message, ScoreRequest, make_client  # noqa: E402
from interllm.llm.ollama_backend import OllamaBackend, OllamaUnavailable  # noqa: E402
from interllm.llm.schema import check_answer  # noqa: E402

SCHEMA = {"type": "object", "properties": {
    "objects": {"type": "array", "items": {"type": "string", "enum": ["cup", "book", "laptop"]},
                "minItems": 1, "maxItems": 3},
    "room": {"type": "string", "enum": ["kitchen", "bedroom"]}}, "required": ["objects", "room"]}


def _cfg(host: str, tmp_path: Path, **kw) -> LLMConfig:
    return LLMConfig(backend="ollama", model="fixture-model", host=host, cache_dir=str(tmp_path / "cache"),
                     timeout_s=10.0, **kw)


def test_check_reports_digest_and_missing_model(tmp_path):
    with FakeOllama(models=("fixture-model:latest",)) as srv:
        be = OllamaBackend(_cfg(srv.host, tmp_path))
        assert be.check() == srv.models["fixture-model:latest"]
        missing = OllamaBackend(LLMConfig(backend="ollama", model="qwen2.5:7b", host=srv.host))
        with pytest.raises(OllamaUnavailable, match=r"ollama pull qwen2\.5:7b"):
            missing.check()
        assert ("GET", "/api/tags", None) in srv.requests


def test_server_down_names_ollama_serve(tmp_path):
    be = OllamaBackend(_cfg(f"http://127.0.0.1:{free_port()}", tmp_path))
    with pytest.raises(OllamaUnavailable, match="ollama serve"):
        be.check()


def test_complete_over_http_sends_schema_and_options(tmp_path):
    with FakeOllama() as srv:
        client = make_client(_cfg(srv.host, tmp_path), call_log_path=tmp_path / "calls.jsonl")
        opts = client.default_options(temperature=0.7, max_tokens=50, sample_index=2,
                                      seed=llm_sample_seed(0, "candidates", 2))
        req = LLMRequest(purpose="candidates", messages=(Message("system", "You plan."),
                                                         Message("user", "Make breakfast.")),
                         schema=SCHEMA, options=opts)
        r1 = client.complete(req)
        assert not r1.cached and check_answer(r1.text, SCHEMA)[1] is None
        assert r1.parsed["room"] in ("kitchen", "bedroom")
        chats = [b for m, p, b in srv.requests if p == "/api/chat"]
        assert len(chats) == 1
        body = chats[0]
        assert body["format"] == SCHEMA and body["model"] == "fixture-model"
        assert body["options"]["temperature"] == 0.7 and body["options"]["num_predict"] == 50
        assert body["options"]["num_ctx"] == 8192 and body["options"]["top_p"] == 0.95
        assert body["options"]["seed"] == llm_sample_seed(opts.seed, 2, 0)
        assert [m["role"] for m in body["messages"]] == ["system", "user"]
        # second identical request: served from the cache, no new HTTP chat
        r2 = client.complete(req)
        assert r2.cached and r2.text == r1.text and r2.key == r1.key
        assert len([1 for m, p, b in srv.requests if p == "/api/chat"]) == 1
        client.close()
    # replay offline: the server is gone, the pinned digest + cache answer
    replay = make_client(_cfg(srv.host, tmp_path, cache_mode="replay"))
    r3 = replay.complete(req)
    assert r3.cached and r3.text == r1.text


def test_score_by_ratings(tmp_path):
    with FakeOllama() as srv:
        client = make_client(_cfg(srv.host, tmp_path))
        r = client.score(ScoreRequest(purpose="proposal", prompt="Useful item for breakfast:",
                                      continuations=(" cup", " laptop", " book"),
                                      calibration_prompt="Useful item:"))
        assert len(r.scores) == 3
        for s in r.raw:  # ln((rating + 1) / 11) for an integer rating 0..10
            rating = math.exp(s) * 11 - 1
            assert abs(rating - round(rating)) < 1e-9 and 0 <= round(rating) <= 10
        assert r.scores == r.raw  # ratings are not calibrated


def _real_ollama_up() -> bool:
    try:
        with urllib.request.urlopen("http://127.0.0.1:11434/api/version", timeout=0.5):
            return True
    except OSError:
        return False


@pytest.mark.needs_ollama
@pytest.mark.skipif(not _real_ollama_up(), reason="no Ollama server answers on 127.0.0.1:11434")
def test_real_ollama_structured_answer(tmp_path):
    import ollama

    models = [m.model for m in ollama.Client(host="http://127.0.0.1:11434").list().models]
    if not models:
        pytest.skip("the Ollama server has no model; `ollama pull` one")
    cfg = LLMConfig(backend="ollama", model=models[0], cache_dir=str(tmp_path / "c"), max_tokens=64)
    client = make_client(cfg)
    r = client.complete(LLMRequest(purpose="test", messages=(Message("user", "Pick objects for breakfast."),),
                                   schema=SCHEMA, options=client.default_options(max_tokens=64)))
    assert check_answer(r.text, SCHEMA)[1] is None
