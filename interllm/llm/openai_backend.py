"""OpenAI-compatible backend: the official ``openai`` client against ``llm.base_url`` — OpenAI
itself (the paper's GPT-4o), vLLM, llama.cpp's servers, Ollama's ``/v1``, LM Studio.

Generation: ``chat.completions`` with the request's JSON schema as ``response_format``, in the
strongest form the server accepts (found by :func:`probe` or on the first call): ``json_schema``
(OpenAI, vLLM, Ollama, LM Studio), ``json_object`` with a ``schema`` (llama-cpp-python's server),
or none — then the schema is written into the prompt and the client's validation and bounded
repair (``llm.repair_retries``) handle what comes back.

Scoring: ``completions`` with ``echo`` and ``logprobs`` gives the log-probabilities of the prompt's
own tokens (vLLM and llama-cpp-python's server do; OpenAI's chat models do not): the score of a
continuation is the mean log-probability of the tokens after the prompt text. A server without
them is refused before the experiment with the mode to use instead.

Faults: every call has a whole-call deadline (``llm.timeout_s``), which the client library's own
timeout (set well past it) never beats, so a hang always reads as one; 429, 5xx and connection
errors are retried ``llm.max_retries`` times with exponential backoff; an unreachable server, a
missing model or a body that is not the API's JSON is an error naming the URL and the fix. The API
key is read from the environment variable named by ``llm.api_key_env`` and never written anywhere.

Cache identity (``model_id``): the model name and the fingerprint the server reports
(``system_fingerprint``), not the URL, so a model moved to another host keeps its cache.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, Optional, TypeVar

from interllm.config import ConfigError, LLMConfig
from interllm.errors import UserError
from interllm.llm.backend import BACKENDS, Generation, Scores
from interllm.llm.deadline import LIBRARY_TIMEOUT, DeadlineExceeded, call_with_deadline, deadline_exceeded
from interllm.llm.schema import check_answer
from interllm.llm.types import LLMOptions, Message

T = TypeVar("T")
SCHEMA_MODES = ("json_schema", "json_object", "prompt")  # strongest first
NO_KEY = "not-needed"  # local servers take any key; the client insists on one
BACKOFF_S = 0.5  # [s] first retry delay, doubled per retry


class OpenAIUnavailable(UserError, RuntimeError):
    """The server is unreachable, lacks the model, refuses the key, or cannot do what the mode needs."""


class OpenAIProtocolError(UserError, RuntimeError):
    """The server answered, but with a body that is not the OpenAI API's JSON (an HTML page, a proxy's
    text)."""


@dataclass
class ProbeResult:
    """What an OpenAI-compatible server does, measured by :func:`probe`."""

    base_url: str
    model: str
    models_listed: list[str] = field(default_factory=list)
    json_schema: str = "untested"  # which SCHEMA_MODES the server enforces ("prompt": none)
    logprobs: bool = False  # completions with echo return prompt-token log-probabilities
    seed_honoured: Optional[bool] = None  # the same seeded request twice gave the same answer
    context_length: Optional[int] = None  # as the server reports it (None: not reported)
    fingerprint: str = ""  # system_fingerprint of the answers ("" when none is reported)
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return asdict(self)


def _retryable(e: BaseException, server_errors: bool) -> bool:
    """429 and connection errors are always worth a retry; 5xx only where ``server_errors`` (the
    probe's format checks must not retry a server that answers an unknown format with a 500)."""
    import openai  # lazy: the optional dependency of this backend

    if isinstance(e, openai.APITimeoutError):
        return False
    return isinstance(e, (openai.RateLimitError, openai.APIConnectionError)) or \
        (server_errors and isinstance(e, openai.InternalServerError))


@BACKENDS.register("openai", label="OpenAI-compatible")
class OpenAIBackend:
    name = "openai"

    def __init__(self, cfg: LLMConfig) -> None:
        if not cfg.model:
            raise ConfigError("config key 'llm.model': the openai backend needs a model name, e.g. "
                              "llm.model=gpt-4o (the name the server lists under /v1/models)")
        self.cfg = cfg
        self._client = None
        self._schema_mode: Optional[str] = None
        self._probe: Optional[ProbeResult] = None
        self.requests = 0  # HTTP requests sent (retries included)

    # -- connection --------------------------------------------------------------------------
    @property
    def client(self):
        if self._client is None:
            from openai import OpenAI  # lazy: the optional dependency of this backend

            key = os.environ.get(self.cfg.api_key_env) or NO_KEY
            self._client = OpenAI(base_url=self.cfg.base_url, api_key=key, max_retries=0,
                                  timeout=LIBRARY_TIMEOUT * self.cfg.timeout_s)
        return self._client

    def _call(self, what: str, fn: Callable[[Any], T], retry: bool = True) -> T:
        """``fn(client)`` with the whole-call deadline, bounded retries (of 5xx too with ``retry``) and
        named errors."""
        url = f"{self.cfg.base_url}{what}"
        describe = f"the OpenAI-compatible call to {url} (llm.base_url)"
        retries = self.cfg.max_retries
        for attempt in range(retries + 1):
            client = self.client
            self.requests += 1
            try:
                result = call_with_deadline(lambda c=client: fn(c), self.cfg.timeout_s, describe)
            except DeadlineExceeded:
                self._client = None  # drop the stuck connection
                raise
            except Exception as e:  # noqa: BLE001 - classified below
                if _retryable(e, server_errors=retry) and attempt < retries:
                    time.sleep(BACKOFF_S * 2 ** attempt)
                    continue
                raise self._named(e, url, describe) from None
            if isinstance(result, str):  # the library's answer to a body it could not read as JSON
                raise self._not_json(url, f"got text: {result[:80]!r}")
            return result
        raise AssertionError("unreachable")  # the loop returns or raises

    def _named(self, e: Exception, url: str, describe: str) -> Exception:
        """What a failed call raises: an error naming the URL and the fix, or ``e`` itself (a bug)."""
        import openai  # lazy: the optional dependency of this backend

        if isinstance(e, openai.APITimeoutError):  # the library's own timeout, set past the deadline
            self._client = None
            return deadline_exceeded(describe, self.cfg.timeout_s)
        if isinstance(e, openai.APIConnectionError):
            return OpenAIUnavailable(
                f"the OpenAI-compatible server at {self.cfg.base_url} (llm.base_url) is not reachable "
                f"({type(e).__name__}: {e}); start it (e.g. `python -m llama_cpp.server --model "
                f"<file.gguf>`, `vllm serve <model>`, `ollama serve`) or fix llm.base_url")
        if isinstance(e, openai.AuthenticationError):
            return OpenAIUnavailable(f"{url} refused the API key: set the environment variable "
                                     f"{self.cfg.api_key_env} (llm.api_key_env) to a valid key")
        if isinstance(e, openai.NotFoundError):
            return OpenAIUnavailable(f"{url}: not found ({e}); is llm.model={self.cfg.model!r} served there "
                                     f"(see {self.cfg.base_url}/models)?")
        if isinstance(e, openai.APIStatusError):
            return OpenAIUnavailable(f"{url} answered HTTP {e.status_code}: {str(e)[:300]}")
        if isinstance(e, (ValueError, KeyError, TypeError, AttributeError)):  # a 200 whose body is not JSON
            return self._not_json(url, f"{type(e).__name__}: {str(e)[:200]}")
        return e

    def _not_json(self, url: str, detail: str) -> OpenAIProtocolError:
        return OpenAIProtocolError(f"the server answered {url} (llm.base_url) with a body that is not the "
                                   f"OpenAI API's JSON ({detail}); is llm.base_url an OpenAI-compatible "
                                   f"endpoint (usually ending in /v1)?")

    # -- identity -------------------------------------------------------------------------------
    def model_name(self) -> str:
        return self.cfg.model

    def model_id(self) -> str:
        """Model name + server fingerprint (cache-key identity; probes the server once)."""
        fp = self.probe().fingerprint
        return hashlib.sha256(f"{self.cfg.model}\x1f{fp}".encode()).hexdigest()

    def check(self) -> None:
        """Before any stage writes: server up, model served, the modes' needs met (raises)."""
        p = self.probe()
        needs_scores = [k for k in ("proposal_mode", "cost_inference_mode") if getattr(self.cfg, k) == "score"]
        if needs_scores and not p.logprobs:
            raise OpenAIUnavailable(
                f"the server at {self.cfg.base_url} returns no prompt log-probabilities (completions with echo "
                f"and logprobs), which llm.{needs_scores[0]}=score needs (OpenAI's chat models have none); use "
                f"llm.proposal_mode=generate llm.cost_inference_mode=generate")

    # -- the probe ------------------------------------------------------------------------------
    def probe(self) -> ProbeResult:
        """Measure what the server does (once per backend); see :class:`ProbeResult`."""
        if self._probe is not None:
            return self._probe
        p = ProbeResult(self.cfg.base_url, self.cfg.model)
        models = self._call("/models", lambda c: c.models.list())
        p.models_listed = sorted(str(m.id) for m in models.data)
        for m in models.data:
            extra = getattr(m, "model_extra", None) or {}
            n = extra.get("max_model_len") or extra.get("context_length") or extra.get("n_ctx")
            if m.id == self.cfg.model and n:
                p.context_length = int(n)
        if p.models_listed and self.cfg.model not in p.models_listed:
            raise OpenAIUnavailable(f"model {self.cfg.model!r} (llm.model) is not served at {self.cfg.base_url}; "
                                    f"it serves {p.models_listed} (llama-cpp-python: --model_alias; vLLM: "
                                    f"--served-model-name; Ollama: `ollama pull`)")
        schema = {"type": "object", "properties": {"color": {"type": "string", "enum": ["red", "blue"]}},
                  "required": ["color"], "additionalProperties": False}
        msgs = [{"role": "user", "content": "Pick a color. Answer in JSON."}]
        for mode in SCHEMA_MODES:  # the strongest form the server accepts and keeps to
            try:
                r = self._chat(msgs, None if mode == "prompt" else schema, mode, retry=False, max_tokens=24,
                               temperature=0.0, seed=1, top_p=1.0)
            except OpenAIUnavailable as e:
                p.notes.append(f"response_format {mode}: refused ({str(e)[:120]})")
                continue
            text = r.choices[0].message.content or ""
            p.fingerprint = p.fingerprint or str(r.system_fingerprint or "")
            if mode == "prompt" or _valid(text, schema):
                p.json_schema = mode
                break
            p.notes.append(f"response_format {mode}: accepted but the answer broke the schema ({text[:60]!r})")
        if p.json_schema == "prompt":
            p.notes.append("the server enforces no JSON schema: answers are validated and repaired")
        self._schema_mode = p.json_schema
        seeded = [self._chat([{"role": "user", "content": "Name a fruit."}], None, "prompt", max_tokens=8,
                             temperature=1.0, seed=7, top_p=1.0).choices[0].message.content for _ in range(2)]
        p.seed_honoured = seeded[0] == seeded[1]
        try:
            self._prompt_logprobs("The cat sat on the", " mat", retry=False)
            p.logprobs = True
        except OpenAIUnavailable as e:
            p.notes.append(f"no prompt log-probabilities ({str(e)[:120]})")
        self._probe = p
        return p

    # -- generation -----------------------------------------------------------------------------
    def _chat(self, messages: list[dict], schema: Optional[dict], mode: str, retry: bool = True, **options: Any):
        kwargs: dict[str, Any] = dict(model=self.cfg.model, messages=messages, **options)
        if schema is not None and mode == "json_schema":
            kwargs["response_format"] = {"type": "json_schema",
                                         "json_schema": {"name": "answer", "schema": schema, "strict": False}}
        elif schema is not None and mode == "json_object":
            kwargs["response_format"] = {"type": "json_object", "schema": schema}
        return self._call("/chat/completions", lambda c: c.chat.completions.create(**kwargs), retry)

    def generate(self, messages: Sequence[Message], schema: Optional[dict], options: LLMOptions,
                 seed: int) -> Generation:
        mode = self._schema_mode or self.probe().json_schema
        msgs = [{"role": m.role, "content": m.content} for m in messages]
        if schema is not None and mode == "prompt":
            msgs.append({"role": "user", "content": "Answer with only a JSON value that satisfies this JSON Schema: "
                                                    + json.dumps(schema, sort_keys=True)})
        r = self._chat(msgs, schema, mode, max_tokens=options.max_tokens, temperature=options.temperature,
                       top_p=options.top_p, seed=int(seed))
        choice = r.choices[0]
        usage = r.usage
        return Generation(text=choice.message.content or "", tokens_in=int(getattr(usage, "prompt_tokens", 0) or 0),
                          tokens_out=int(getattr(usage, "completion_tokens", 0) or 0),
                          truncated=choice.finish_reason == "length")

    # -- scoring --------------------------------------------------------------------------------
    def _prompt_logprobs(self, prompt: str, continuation: str, retry: bool = True) -> tuple[float, int]:
        """(mean log-probability of the continuation's tokens, prompt tokens) from an echoed completion."""
        text = prompt + continuation
        r = self._call("/completions", lambda c: c.completions.create(
            model=self.cfg.model, prompt=text, max_tokens=1, temperature=0.0, echo=True, logprobs=1), retry)
        lp = r.choices[0].logprobs
        if lp is None or not lp.token_logprobs or lp.text_offset is None:
            raise OpenAIUnavailable(f"{self.cfg.base_url}/completions returned no prompt log-probabilities "
                                    f"(echo=true, logprobs=1)")
        n_prompt = int(getattr(r.usage, "prompt_tokens", 0) or 0) or len(lp.tokens)
        vals = []
        for tok, off, v in zip(lp.tokens[:n_prompt], lp.text_offset[:n_prompt], lp.token_logprobs[:n_prompt],
                               strict=False):
            if off + len(tok) > len(prompt) and off < len(text) and v is not None:
                vals.append(float(v))
        if not vals:
            raise OpenAIUnavailable(f"{self.cfg.base_url}/completions: no token of {continuation!r} in the echoed "
                                    f"prompt")
        return sum(vals) / len(vals), n_prompt

    def score(self, prompt: str, continuations: Sequence[str], calibration_prompt: Optional[str] = None) -> Scores:
        if not continuations:
            raise ValueError("ScoreRequest.continuations is empty; give at least one continuation")
        raw, tokens = [], 0
        for c in continuations:
            v, n = self._prompt_logprobs(prompt, c)
            raw.append(v)
            tokens += n
        calib = None
        if calibration_prompt is not None:
            calib = []
            for c in continuations:
                v, n = self._prompt_logprobs(calibration_prompt, c)
                calib.append(v)
                tokens += n
        return Scores(raw=raw, calibration=calib, tokens_in=tokens)

    def close(self) -> None:
        self._client = None


def _valid(text: str, schema: dict) -> bool:
    return check_answer(text, schema)[1] is None
