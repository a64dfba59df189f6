"""Servers speaking the OpenAI API on 127.0.0.1 for the tests.

``FakeOpenAI``: a small server we control, for the fault cases (``GET /v1/models``,
``POST /v1/chat/completions``, ``POST /v1/completions``). Answers are schema-valid JSON drawn from
the request's ``response_format`` schema with the request's seed; echoed completions carry
deterministic log-probabilities. ``fault``: ``"429_once"`` (the first chat request gets HTTP 429),
``"hang"`` (chat requests never answer; the handler gives up after ``hang_s``), ``"bad_json"``
(chat answers are not JSON whatever the schema), ``"no_logprobs"`` (completions without
log-probabilities, like OpenAI's chat models), ``"not_json_models"`` / ``"not_json_chat"`` (``/v1/models``
/ ``/v1/chat/completions`` answer 200 with an HTML page sent as ``content_type``, like a proxy or a web
server at the wrong URL), ``"status"`` (the first ``fault_n`` requests to ``/v1<fault_path>``, all of them
when ``fault_n`` is None, answer HTTP ``status``, with a ``Retry-After: <retry_after>`` header when it is
set), ``"bad_logprobs"`` (echoed completions carry ``bad_logprob``, e.g. NaN or "abc", as the
log-probability of every token after the first), ``"echo_key_400"`` (chat requests answer HTTP 400 with
a body that echoes the request's Authorization header, as some proxies do). ``times`` holds each
request's (path, time.monotonic()).

``llama_server``: llama-cpp-python's own OpenAI-compatible server on the embedded GGUF (real HTTP,
real grammar-constrained decoding), started in a subprocess and stopped when the test ends.
"""

from __future__ import annotations

import contextlib
import json
import random
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any, Optional

from interllm.config import LLMConfig
from interllm.core.seeding import llm_sample_seed
from interllm.llm.testing import schema_instance
from interllm.llm.types import LLMRequest, Message

MODEL = "fixture-gpt"
SCHEMA = {"type": "object", "properties": {"room": {"type": "string", "enum": ["kitchen", "bedroom"]}},
          "required": ["room"], "additionalProperties": False}
REQ = LLMRequest(purpose="candidates", messages=(Message("user", "Where is the bed?"),), schema=SCHEMA)


def openai_cfg(base_url: str, tmp_path, **kw) -> LLMConfig:
    """An ``llm=openai`` config in generate mode against ``base_url``, caching under ``tmp_path``."""
    base = dict(backend="openai", model=MODEL, base_url=base_url, cache_dir=str(tmp_path / "cache"),
                timeout_s=10.0, proposal_mode="generate", cost_inference_mode="generate")
    return LLMConfig(**{**base, **kw})


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class FakeOpenAI:
    """Context manager: ``with FakeOpenAI(fault=...) as srv: srv.base_url``."""

    FAULTS = (None, "429_once", "hang", "bad_json", "no_logprobs", "not_json_models", "not_json_chat", "status",
              "bad_logprobs", "echo_key_400")

    def __init__(self, fault: Optional[str] = None, hang_s: float = 30.0, fingerprint: str = "fp_fixture",
                 content_type: str = "application/json", *, status: int = 500, fault_n: Optional[int] = None,
                 fault_path: str = "/chat/completions", retry_after: Optional[str] = None,
                 bad_logprob: Any = float("nan")) -> None:
        assert fault in self.FAULTS, fault
        self.fault, self.hang_s, self.fingerprint = fault, hang_s, fingerprint
        self.content_type = content_type  # of the page the not_json faults send
        self.status, self.fault_n, self.fault_path, self.retry_after = status, fault_n, fault_path, retry_after
        self.bad_logprob = bad_logprob
        self.faults_sent = 0  # answers of the "status" fault
        self.requests: list[tuple[str, Any]] = []
        self.times: list[tuple[str, float]] = []
        self._429_sent = False
        self._server: Optional[ThreadingHTTPServer] = None

    @property
    def base_url(self) -> str:
        assert self._server is not None
        return f"http://127.0.0.1:{self._server.server_address[1]}/v1"

    def _chat_answer(self, body: dict) -> str:
        rf = body.get("response_format") or {}
        schema = (rf.get("json_schema") or {}).get("schema") or rf.get("schema")
        seed = int(body.get("seed") or 0)
        rng = random.Random(llm_sample_seed(seed, json.dumps(body.get("messages"), sort_keys=True)))
        if self.fault == "bad_json":
            return "I think {banana"
        return json.dumps(schema_instance(schema, rng), sort_keys=True) if schema else "a fixture answer"

    def _handler(self):
        fake = self

        class H(BaseHTTPRequestHandler):
            def log_message(self, *a):
                pass

            def _send(self, code: int, obj: Any, headers: dict | None = None) -> None:
                data = json.dumps(obj).encode()
                self.send_response(code)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(data)))
                for k, v in (headers or {}).items():
                    self.send_header(k, v)
                self.end_headers()
                self.wfile.write(data)

            def _send_page(self) -> None:
                data = b"<html><body><h1>Welcome</h1></body></html>"
                self.send_response(200)
                self.send_header("Content-Type", fake.content_type)
                self.send_header("Content-Length", str(len(data)))
                self.end_headers()
                self.wfile.write(data)

            def _status_fault(self) -> bool:
                """Answer the "status" fault if this request is one of those it hits."""
                hit = fake.fault == "status" and self.path == "/v1" + fake.fault_path and (
                    fake.fault_n is None or fake.faults_sent < fake.fault_n)
                if hit:
                    fake.faults_sent += 1
                    self._send(fake.status, {"error": {"message": f"fixture fault: HTTP {fake.status}",
                                                       "type": "server_error"}},
                               {"Retry-After": fake.retry_after} if fake.retry_after is not None else None)
                return hit

            def do_GET(self):
                fake.requests.append(("GET " + self.path, None))
                fake.times.append(("GET " + self.path, time.monotonic()))
                if self._status_fault():
                    return None
                if self.path.endswith("/models") and fake.fault == "not_json_models":
                    return self._send_page()
                if self.path.endswith("/models"):
                    return self._send(200, {"object": "list", "data": [{"id": MODEL, "object": "model",
                                                                        "owned_by": "fixture", "max_model_len": 4096}]})
                return self._send(404, {"error": {"message": f"no route {self.path}"}})

            def do_POST(self):
                n = int(self.headers.get("Content-Length", 0))
                body = json.loads(self.rfile.read(n) or b"{}")
                fake.requests.append(("POST " + self.path, body))
                fake.times.append(("POST " + self.path, time.monotonic()))
                if self._status_fault():
                    return None
                if body.get("model") != MODEL:
                    return self._send(404, {"error": {"message": f"model {body.get('model')!r} not found",
                                                      "type": "invalid_request_error", "code": "model_not_found"}})
                if self.path.endswith("/chat/completions"):
                    if fake.fault == "429_once" and not fake._429_sent:
                        fake._429_sent = True
                        return self._send(429, {"error": {"message": "rate limited", "type": "rate_limit"}},
                                          {"retry-after-ms": "10"})
                    if fake.fault == "hang":
                        time.sleep(fake.hang_s)
                        return None
                    if fake.fault == "not_json_chat":
                        return self._send_page()
                    if fake.fault == "echo_key_400":
                        return self._send(400, {"error": {"message": "invalid request from client with headers "
                                                          f"Authorization: {self.headers.get('Authorization')}",
                                                          "type": "invalid_request_error"}})
                    text = fake._chat_answer(body)
                    return self._send(200, {
                        "id": "chatcmpl-fixture", "object": "chat.completion", "created": 0, "model": MODEL,
                        "system_fingerprint": fake.fingerprint,
                        "choices": [{"index": 0, "finish_reason": "stop",
                                     "message": {"role": "assistant", "content": text}}],
                        "usage": {"prompt_tokens": 10, "completion_tokens": 5, "total_tokens": 15}})
                if self.path.endswith("/completions"):
                    prompt = str(body.get("prompt", ""))
                    words = prompt.split(" ")
                    toks, offs, pos = [], [], 0
                    for i, w in enumerate(words):
                        t = w if i == 0 else " " + w
                        toks.append(t)
                        offs.append(pos)
                        pos += len(t)
                    lps = [None] + [fake.bad_logprob if fake.fault == "bad_logprobs" else
                                    -1.0 - llm_sample_seed(t) / 2**31 for t in toks[1:]]
                    logprobs = None if fake.fault == "no_logprobs" else {
                        "tokens": toks, "text_offset": offs, "token_logprobs": lps, "top_logprobs": None}
                    return self._send(200, {
                        "id": "cmpl-fixture", "object": "text_completion", "created": 0, "model": MODEL,
                        "choices": [{"index": 0, "text": prompt, "finish_reason": "length", "logprobs": logprobs}],
                        "usage": {"prompt_tokens": len(toks), "completion_tokens": 1, "total_tokens": len(toks) + 1}})
                return self._send(404, {"error": {"message": f"no route {self.path}"}})

        return H

    def __enter__(self) -> FakeOpenAI:
        self._server = ThreadingHTTPServer(("127.0.0.1", 0), self._handler())
        self._server.daemon_threads = True
        threading.Thread(target=self._server.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True).start()
        return self

    def __exit__(self, *exc) -> None:
        assert self._server is not None
        self._server.shutdown()
        self._server.server_close()


@contextlib.contextmanager
def llama_server(model_path: str, alias: str = "gemma3-270m", n_ctx: int = 8192,
                 timeout_s: float = 120.0) -> Iterator[str]:
    """llama-cpp-python's OpenAI-compatible server on 127.0.0.1 (a free port); yields its base URL
    and stops it (and waits for it) on exit. ``pytest.skip``s where the ``server`` extra is absent."""
    import pytest

    pytest.importorskip("llama_cpp.server", reason="llama-cpp-python's server extra is not installed")
    port = free_port()
    log = tempfile.TemporaryFile(mode="w+")  # the server logs a lot; a pipe nobody reads would block it
    # one decoding thread: the server answers one request at a time behind one lock (its /models too),
    # and llama.cpp's threads spin at their barriers; with 2 threads on 2 busy cores both server tests
    # missed a 120 s deadline, with 1 thread (and 600 s) they passed (issue 57; thread count alone not isolated)
    proc = subprocess.Popen([sys.executable, "-m", "llama_cpp.server", "--model", model_path, "--model_alias", alias,
                             "--host", "127.0.0.1", "--port", str(port), "--n_ctx", str(n_ctx), "--n_threads", "1",
                             "--seed", "0"], stdout=log, stderr=subprocess.STDOUT, text=True)
    base = f"http://127.0.0.1:{port}/v1"
    try:
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                with urllib.request.urlopen(base + "/models", timeout=2) as r:
                    if r.status == 200:
                        break
            except OSError:
                pass
            if proc.poll() is not None:
                log.seek(0)
                raise RuntimeError(f"llama_cpp.server exited with {proc.returncode}: {log.read()[-2000:]}")
            if time.monotonic() > deadline:
                raise RuntimeError(f"llama_cpp.server did not answer on {base} within {timeout_s} s")
            time.sleep(0.2)
        yield base
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=20)
        log.close()
