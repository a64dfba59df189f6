"""Ollama backend: the official ``ollama`` Python client against ``cfg.host``.

Generation: ``chat(model, messages, format=<JSON schema>, options={temperature, seed, top_p,
num_predict, num_ctx})``. ``llm.timeout_s`` bounds the whole call, its retries included
(:func:`interllm.llm.deadline.call_with_deadline`; the HTTP client's own timeout is set past it, so
a hang always reads as one); HTTP 429 and 503 are retried ``llm.max_retries`` times after the
server's Retry-After or an exponential backoff (:mod:`interllm.llm.retry`); a server error (HTTP
5xx) or a body that is not Ollama's JSON is an :class:`OllamaProtocolError` naming the URL. A
server's text quoted in a message has any key redacted (:mod:`interllm.llm.redact`).

Scoring: Ollama returns log-probs only for tokens it generates (no prompt/echo log-probs), so
continuation likelihoods cannot be read off. ``score()`` therefore asks the model for a JSON
object ``{"ratings": [r_1, ..., r_N]}`` with integer ratings 0..10 (temperature 0, seed 0) and
reports ``ln((r + 1) / 11)`` as the "raw" score (in [-2.4, 0], higher is better; ``method =
"rating"``). The calibration prompt does not apply to ratings and is ignored (calibration None).

``check()`` runs before an experiment: server down -> :class:`OllamaUnavailable` telling to run
``ollama serve``; model missing -> telling to run ``ollama pull <model>``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import Any, Optional

from interllm.config import ConfigError, LLMConfig
from interllm.errors import UserError
from interllm.llm.backend import BACKENDS, Generation, Scores
from interllm.llm.deadline import LIBRARY_TIMEOUT, DeadlineExceeded, call_with_deadline, deadline_exceeded
from interllm.llm.redact import env_secrets, redact
from interllm.llm.retry import RETRY_AFTER_STATUSES, CallBudget, retry_after_s
from interllm.llm.types import LLMOptions, Message

KEY_ENV = "OLLAMA_API_KEY"  # the ollama client sends its value as a bearer token


class OllamaUnavailable(UserError, RuntimeError):
    """The Ollama server is unreachable or lacks the model; the message says how to fix it."""


class OllamaProtocolError(UserError, RuntimeError):
    """The server answered, but not as Ollama does (HTTP error status, a body that is not JSON)."""


def _names(model: str) -> set[str]:
    return {model, f"{model}:latest"} if ":" not in model else {model}


@BACKENDS.register("ollama", label="Ollama")
class OllamaBackend:
    name = "ollama"

    def __init__(self, cfg: LLMConfig) -> None:
        if not cfg.model:
            raise ConfigError("config key 'llm.model': the ollama backend needs a model name, "
                              "e.g. llm.model=llama3.2:3b (see `ollama list`)")
        self.cfg = cfg
        self._client = None
        self._digest: Optional[str] = None
        self._last_headers: dict = {}  # the headers of the last HTTP answer (for its Retry-After)

    @property
    def client(self):
        if self._client is None:
            import ollama  # lazy: optional dependency, only for this backend

            # the ollama client drops an error's headers; a response hook keeps the Retry-After
            self._client = ollama.Client(host=self.cfg.host, timeout=LIBRARY_TIMEOUT * self.cfg.timeout_s,
                                         event_hooks={"response": [self._note_response]})
        return self._client

    def _note_response(self, response) -> None:
        self._last_headers = dict(response.headers)

    def _quote(self, text: object, limit: int) -> str:
        """A server's ``text`` fit to quote in a message: any key redacted, then cut to ``limit`` characters."""
        return redact(text, env_secrets([KEY_ENV, self.cfg.api_key_env]))[:limit]

    def model_name(self) -> str:
        return self.cfg.model

    def _down(self, e: Exception) -> OllamaUnavailable:
        return OllamaUnavailable(f"the Ollama server at {self.cfg.host} (llm.host) is not reachable "
                                 f"({type(e).__name__}: {self._quote(e, 300)}); start it with `ollama serve`, or "
                                 f"use llm.backend=embedded")

    def _list(self) -> list[Any]:
        return list(self._call("/api/tags", lambda c: c.list()).models)

    def check(self) -> str:
        """Verify server and model; return the model digest."""
        models = self._list()
        want = _names(self.cfg.model)
        for m in models:
            if m.model in want:
                self._digest = m.digest or ""
                return self._digest
        have = sorted(m.model for m in models)
        raise OllamaUnavailable(f"model {self.cfg.model!r} (llm.model) is not on the Ollama server at "
                                f"{self.cfg.host}; run `ollama pull {self.cfg.model}` (available: {have})")

    def model_id(self) -> str:
        """Ollama model digest (cache-key identity)."""
        if self._digest is None:
            self.check()
        return self._digest or ""

    def _chat(self, messages: list[dict], schema: Optional[dict], options: dict):
        return self._call("/api/chat", lambda c: c.chat(model=self.cfg.model, messages=messages, format=schema,
                                                        options=options, stream=False))

    def _call(self, endpoint: str, fn):
        """``fn(client)`` within the whole-call deadline (retries included), HTTP 429 and 503 retried after
        the server's Retry-After, every failure named by URL and fix."""
        import ollama  # lazy: optional dependency, only for this backend

        url = f"{self.cfg.host}{endpoint}"
        budget = CallBudget(self.cfg.timeout_s, self.cfg.max_retries)
        while True:
            self._last_headers = {}
            try:
                return self._attempt(url, fn, budget.start_attempt())
            except ollama.ResponseError as e:
                retry = e.status_code in RETRY_AFTER_STATUSES and budget.wait_to_retry(
                    retry_after_s(self._last_headers), f"the Ollama server at {url} (llm.host) answered HTTP "
                                                       f"{e.status_code}")
                if not retry:
                    raise self._status_error(e, url, budget.attempts) from None

    def _status_error(self, e, url: str, attempts: int) -> Exception:
        """The error of an HTTP error status that is not retried (any more)."""
        if e.status_code == 404:
            return OllamaUnavailable(f"model {self.cfg.model!r} is not on the Ollama server at "
                                     f"{self.cfg.host}; run `ollama pull {self.cfg.model}`")
        body = repr(self._quote(e.error, 200))
        if e.status_code in RETRY_AFTER_STATUSES:  # busy or rate-limiting: the server's state, not the model's
            return OllamaProtocolError(
                f"the Ollama server at {url} (llm.host) kept answering HTTP {e.status_code} (busy or "
                f"rate-limiting) through {attempts} attempts (llm.max_retries={self.cfg.max_retries}, within "
                f"llm.timeout_s={self.cfg.timeout_s:g} s): {body}. Wait and rerun (answers already received are "
                f"in the LLM cache), send fewer requests at once (jobs=1, OLLAMA_NUM_PARALLEL), or raise "
                f"llm.max_retries or llm.timeout_s")
        return OllamaProtocolError(f"the Ollama server answered {url} (llm.host) with HTTP {e.status_code}: "
                                   f"{body}; check its log (`ollama serve` output) and the model {self.cfg.model!r}")

    def _attempt(self, url: str, fn, wait_s: float):
        """One attempt of ``fn(client)``, given ``wait_s`` [s] of the deadline; an HTTP error status is
        raised as the client's ``ResponseError`` (for :meth:`_call`), any other failure by its name."""
        import httpx  # lazy: optional dependency, only for this backend
        import ollama  # lazy: optional dependency, only for this backend

        client = self.client
        describe = f"the Ollama call to {url} (llm.host)"
        try:
            return call_with_deadline(lambda: fn(client), wait_s, describe, configured_s=self.cfg.timeout_s)
        except (DeadlineExceeded, ollama.ResponseError) as e:
            if isinstance(e, DeadlineExceeded):
                self._client = None  # drop the stuck connection; the next call opens a new one
            raise
        except httpx.TimeoutException:  # the library's own timeout, set past the deadline
            self._client = None
            raise deadline_exceeded(describe, self.cfg.timeout_s) from None
        except (ConnectionError, httpx.HTTPError, OSError) as e:
            raise self._down(e) from None
        except (ValueError, KeyError, TypeError, AttributeError) as e:  # a 200 whose body is not Ollama's JSON
            raise OllamaProtocolError(f"the server answered {url} (llm.host) with a body that is not Ollama's "
                                      f"JSON ({type(e).__name__}: {self._quote(e, 200)}); is llm.host an Ollama "
                                      f"server?") from None

    def generate(self, messages: Sequence[Message], schema: Optional[dict], options: LLMOptions,
                 seed: int) -> Generation:
        opts = {"temperature": options.temperature, "seed": int(seed), "top_p": options.top_p,
                "num_predict": options.max_tokens, "num_ctx": self.cfg.n_ctx}
        r = self._chat([{"role": m.role, "content": m.content} for m in messages], schema, opts)
        return Generation(text=r.message.content or "", tokens_in=int(r.prompt_eval_count or 0),
                          tokens_out=int(r.eval_count or 0), truncated=r.done_reason == "length")

    def score(self, prompt: str, continuations: Sequence[str],
              calibration_prompt: Optional[str] = None) -> Scores:
        n = len(continuations)
        if n == 0:
            raise ValueError("ScoreRequest.continuations is empty; give at least one continuation")
        schema = {"type": "object", "properties": {"ratings": {
            "type": "array", "items": {"type": "integer", "minimum": 0, "maximum": 10},
            "minItems": n, "maxItems": n}}, "required": ["ratings"]}
        options_text = "\n".join(f"{i + 1}. {c.strip()}" for i, c in enumerate(continuations))
        content = (f"Text:\n{prompt}\n\nRate how well each option continues the text, from 0 (not at "
                   f"all) to 10 (perfectly). Options:\n{options_text}\n\nAnswer with JSON "
                   f'{{"ratings": [...]}} holding exactly {n} integers, in the order of the options.')
        opts = {"temperature": 0.0, "seed": 0, "top_p": 1.0, "num_predict": 16 + 4 * n,
                "num_ctx": self.cfg.n_ctx}
        r = self._chat([{"role": "user", "content": content}], schema, opts)
        try:
            ratings = json.loads(r.message.content)["ratings"]
            if len(ratings) != n:
                raise ValueError(f"expected {n} ratings, got {len(ratings)}")
            raw = [math.log((min(10, max(0, int(x))) + 1) / 11.0) for x in ratings]
        except (ValueError, KeyError, TypeError) as e:
            raise ValueError(f"Ollama rating answer is malformed ({e}): {r.message.content[:200]!r}") from None
        return Scores(raw=raw, calibration=None, tokens_in=int(r.prompt_eval_count or 0), method="rating")

    def close(self) -> None:
        self._client = None
