"""A tiny Ollama-protocol server for tests, bound to 127.0.0.1 on a free port.

Speaks ``GET /api/version``, ``GET /api/tags``, ``POST /api/show`` and ``POST /api/chat``
(non-streaming) like Ollama does. Answers come from an embedded backend when one is given
(``answer_backend``), otherwise deterministic schema-valid JSON drawn from the request's
``format`` schema with a seed from ``options.seed`` and the messages. Every request body is kept
in ``requests`` for assertions. No wall clock enters a response (created_at is fixed).

``fault`` makes /api/chat misbehave the way broken servers do: ``"garbage"`` answers every chat
with the content ``I think {banana``; ``"invalid_json"`` sends a body that is not JSON;
``"http_500"`` an internal server error; ``"trickle"`` sends the headers, then one byte every
0.2 s (for at most ``trickle_s`` seconds), so no single read times out; ``"status"``: the first
``fault_n`` chats (all when None) answer HTTP ``status`` with ``Retry-After: <retry_after>`` when set.
``times`` holds each chat request's time.monotonic().
"""

from __future__ import annotations

import hashlib
import json
import random
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any, Optional

from interllm.core.seeding import llm_sample_seed
from interllm.llm.testing import schema_instance
from interllm.llm.types import LLMOptions, Message

FIXED_TIME = "2024-01-01T00:00:00Z"


class FakeOllama:
    """Context manager: ``with FakeOllama(models=("tiny:latest",)) as srv: srv.host``."""

    def __init__(self, models: tuple[str, ...] = ("fixture-model:latest",),
                 answer_backend: Optional[Any] = None, fault: Optional[str] = None,
                 trickle_s: float = 20.0, *, status: int = 503, fault_n: Optional[int] = None,
                 retry_after: Optional[str] = None) -> None:
        assert fault in (None, "garbage", "invalid_json", "http_500", "trickle", "status"), fault
        self.models = {m: hashlib.sha256(m.encode()).hexdigest() for m in models}
        self.answer_backend = answer_backend
        self.fault = fault
        self.trickle_s = trickle_s
        self.status, self.fault_n, self.retry_after = status, fault_n, retry_after
        self.faults_sent = 0
        self.times: list[float] = []
        self.requests: list[tuple[str, str, Any]] = []
        self._server: Optional[ThreadingHTTPServer] = None
        self._thread: Optional[threading.Thread] = None

    @property
    def host(self) -> str:
        assert self._server is not None
        return f"http://127.0.0.1:{self._server.server_address[1]}"

    def _find(self, name: str) -> Optional[str]:
        for cand in (name, f"{name}:latest"):
            if cand in self.models:
                return cand
        return None

    def _answer(self, body: dict) -> tuple[str, int, int]:
        msgs = [Message(m["role"], m["content"]) for m in body.get("messages", [])]
        opts = body.get("options") or {}
        schema = body.get("format")
        if isinstance(schema, str):  # format="json": any JSON object
            schema = {"type": "object", "properties": {"answer": {"type": "string"}}, "required": ["answer"]}
        seed = int(opts.get("seed", 0))
        if self.answer_backend is not None:
            o = LLMOptions(temperature=float(opts.get("temperature", 0.8)), seed=seed,
                           top_p=float(opts.get("top_p", 0.95)), max_tokens=int(opts.get("num_predict", 64)))
            g = self.answer_backend.generate(tuple(msgs), schema, o, seed)
            return g.text, g.tokens_in, g.tokens_out
        rng = random.Random(llm_sample_seed(seed, [[m.role, m.content] for m in msgs].__repr__()))
        text = json.dumps(schema_instance(schema, rng), sort_keys=True) if schema else "fixture answer"
        return text, sum(len(m.content.split()) for m in msgs), max(1, len(text) // 4)

    def _handler(self):
        fake = self

        class H(BaseHTTPRequestHandler):
            def log_message(self, *a):  # keep test output quiet
                pass

            def _send(self, code: int, obj: Any, headers: Optional[dict] = None) -> None:
                data = json.dumps(obj).encode()
                self.send_response(code)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(data)))
                for k, v in (headers or {}).items():
                    self.send_header(k, v)
                self.end_headers()
                self.wfile.write(data)

            def _fault(self, fault: str) -> None:
                if fault == "garbage":
                    return self._send(200, {"model": "fixture-model:latest", "created_at": FIXED_TIME,
                                            "message": {"role": "assistant", "content": "I think {banana"},
                                            "done": True, "done_reason": "stop", "prompt_eval_count": 5,
                                            "eval_count": 4})
                if fault == "http_500":
                    return self._send(500, {"error": "llama runner process has terminated"})
                if fault == "status":
                    return self._send(fake.status, {"error": f"fixture fault: HTTP {fake.status}"},
                                      {"Retry-After": fake.retry_after} if fake.retry_after is not None else None)
                if fault == "invalid_json":
                    data = b"<html>502 Bad Gateway</html>"
                    self.send_response(200)
                    self.send_header("Content-Type", "application/json")
                    self.send_header("Content-Length", str(len(data)))
                    self.end_headers()
                    self.wfile.write(data)
                    return None
                self.send_response(200)  # trickle
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", "1000000")
                self.end_headers()
                t_end = time.monotonic() + fake.trickle_s
                try:
                    while time.monotonic() < t_end:
                        self.wfile.write(b" ")
                        self.wfile.flush()
                        time.sleep(0.2)
                except OSError:  # the client hung up
                    pass
                return None

            def do_GET(self):
                fake.requests.append(("GET", self.path, None))
                if self.path == "/api/version":
                    return self._send(200, {"version": "0.0.0-fixture"})
                if self.path == "/api/tags":
                    return self._send(200, {"models": [
                        {"name": m, "model": m, "modified_at": FIXED_TIME, "size": 1000, "digest": d,
                         "details": {"format": "gguf", "family": "fixture", "parameter_size": "1M",
                                     "quantization_level": "Q4_K_M"}}
                        for m, d in fake.models.items()]})
                return self._send(404, {"error": f"unknown path {self.path}"})

            def do_POST(self):
                n = int(self.headers.get("Content-Length", 0))
                body = json.loads(self.rfile.read(n) or b"{}")
                fake.requests.append(("POST", self.path, body))
                name = fake._find(body.get("model", ""))
                if self.path in ("/api/show", "/api/chat") and name is None:
                    return self._send(404, {"error": f"model '{body.get('model')}' not found"})
                if self.path == "/api/show":
                    return self._send(200, {"modelfile": "", "parameters": "", "template": "{{ .Prompt }}",
                                            "details": {"format": "gguf", "family": "fixture"},
                                            "model_info": {}, "modified_at": FIXED_TIME})
                if self.path == "/api/chat":
                    fake.times.append(time.monotonic())
                if self.path == "/api/chat" and fake.fault == "status" and (
                        fake.fault_n is None or fake.faults_sent < fake.fault_n):
                    fake.faults_sent += 1
                    return self._fault("status")
                if self.path == "/api/chat" and fake.fault not in (None, "status"):
                    return self._fault(fake.fault)
                if self.path == "/api/chat":
                    text, tin, tout = fake._answer(body)
                    return self._send(200, {
                        "model": name, "created_at": FIXED_TIME,
                        "message": {"role": "assistant", "content": text}, "done": True,
                        "done_reason": "stop", "total_duration": 0, "load_duration": 0,
                        "prompt_eval_count": tin, "prompt_eval_duration": 0, "eval_count": tout,
                        "eval_duration": 0})
                return self._send(404, {"error": f"unknown path {self.path}"})

        return H

    def __enter__(self) -> FakeOllama:
        self._server = ThreadingHTTPServer(("127.0.0.1", 0), self._handler())
        self._server.daemon_threads = True
        self._thread = threading.Thread(target=self._server.serve_forever, kwargs={"poll_interval": 0.05},
                                        daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        assert self._server is not None
        self._server.shutdown()
        self._server.server_close()
        if self._thread is not None:
            self._thread.join(timeout=5)


def free_port() -> int:
    """A port on 127.0.0.1 with nothing listening (for the server-down test)."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]
