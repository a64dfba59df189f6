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
them is refused before the experiment with the mode to use instead; log-probabilities that are not
finite numbers are an :class:`OpenAIProtocolError` naming the URL and the field (never cached).

Faults: every call has a whole-call deadline (``llm.timeout_s``, its retries included), which the
client library's own timeout (set well past it) never beats, so a hang always reads as one; 429,
5xx and connection errors are retried ``llm.max_retries`` times, after the server's Retry-After or
an exponential backoff (:mod:`interllm.llm.retry`), by the probe as by every request; a 5xx or 429
that persists is an :class:`OpenAIServerError` naming the URL and the status (a server's fault, not
a missing capability); an unreachable server, a missing model or a body that is not the API's JSON
is an error naming the URL and the fix. The API key is read from the environment variable named by
``llm.api_key_env``, never written anywhere, and redacted from every server text quoted in a message
(:mod:`interllm.llm.redact`).

One probe per stage: :meth:`OpenAIBackend.adopt_probe` takes what the stage's probe recorded
(``llm_probe.json``), so every worker process of a stage uses the structured-output mode that
provenance.json records, instead of probing on its own.

Cache identity (``model_id``): the model name and the fingerprint the server reports
(``system_fingerprint``), not the URL, so a model moved to another host keeps its cache.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, Optional, TypeVar

from interllm.config import ConfigError, LLMConfig
from interllm.errors import UserError
from interllm.llm.backend import BACKENDS, Generation, Scores
from interllm.llm.deadline import LIBRARY_TIMEOUT, DeadlineExceeded, call_with_deadline, deadline_exceeded
from interllm.llm.redact import env_secrets, redact
from interllm.llm.retry import RETRY_AFTER_STATUSES, CallBudget, retry_after_s
from interllm.llm.schema import check_answer
from interllm.llm.types import LLMOptions, Message

T = TypeVar("T")
SCHEMA_MODES = ("json_schema", "json_object", "prompt")  # strongest first
NO_KEY = "not-needed"  # local servers take any key; the client insists on one
SCORE_MODES = ("proposal_mode", "cost_inference_mode")  # the llm keys whose "score" needs log-probabilities


class OpenAIUnavailable(UserError, RuntimeError):
    """The server is unreachable, lacks the model, refuses the key, or cannot do what the mode needs."""


class OpenAIProtocolError(UserError, RuntimeError):
    """The server answered, but with a body that is not the OpenAI API's JSON (an HTML page, a proxy's
    text), or with values the API does not allow (log-probabilities that are not finite numbers)."""


class OpenAIServerError(UserError, RuntimeError):
    """The server failed (HTTP 5xx) or kept rate-limiting (HTTP 429) through the retries: a fault of the
    server, not a capability it lacks."""


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


def _retryable(e: BaseException) -> bool:
    """429, 5xx and connection errors are worth a retry (a timeout is not: the deadline is spent)."""
    import openai  # lazy: the optional dependency of this backend

    if isinstance(e, openai.APITimeoutError):
        return False
    return isinstance(e, (openai.RateLimitError, openai.InternalServerError, openai.APIConnectionError))


def _retry_after(e: BaseException) -> Optional[float]:
    """Seconds [s] a 429 or 503 answer asks to wait (its Retry-After), else None."""
    response = getattr(e, "response", None)
    if getattr(e, "status_code", None) not in RETRY_AFTER_STATUSES or response is None:
        return None
    return retry_after_s(response.headers)


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

    def _quote(self, text: object, limit: int) -> str:
        """A server's ``text`` fit to quote in a message: the key redacted, then cut to ``limit`` characters."""
        return redact(text, env_secrets([self.cfg.api_key_env]))[:limit]

    def _call(self, what: str, fn: Callable[[Any], T]) -> T:
        """``fn(client)`` within the whole-call deadline (retries included), with bounded retries of 429,
        5xx and connection errors (after the server's Retry-After) and named errors."""
        url = f"{self.cfg.base_url}{what}"
        describe = f"the OpenAI-compatible call to {url} (llm.base_url)"
        budget = CallBudget(self.cfg.timeout_s, self.cfg.max_retries)
        while True:
            client = self.client
            self.requests += 1
            try:
                result = call_with_deadline(lambda c=client: fn(c), budget.start_attempt(), describe,
                                            configured_s=self.cfg.timeout_s)
            except DeadlineExceeded:
                self._client = None  # drop the stuck connection
                raise
            except Exception as e:  # noqa: BLE001 - classified below
                if not (_retryable(e) and budget.wait_to_retry(
                        _retry_after(e), f"the server at {url} (llm.base_url) answered HTTP "
                                         f"{getattr(e, 'status_code', '')}".rstrip())):
                    raise self._named(e, url, describe, budget.attempts) from None
                continue
            if isinstance(result, str):  # the library's answer to a body it could not read as JSON
                raise self._not_json(url, f"got text: {self._quote(result, 80)!r}")
            return result

    def _named(self, e: Exception, url: str, describe: str, attempts: int = 1) -> Exception:
        """What a failed call raises after ``attempts`` attempts: an error naming the URL and the fix, or
        ``e`` itself (a bug)."""
        import openai  # lazy: the optional dependency of this backend

        if isinstance(e, openai.APITimeoutError):  # the library's own timeout, set past the deadline
            self._client = None
            return deadline_exceeded(describe, self.cfg.timeout_s)
        if isinstance(e, openai.APIConnectionError):
            return OpenAIUnavailable(
                f"the OpenAI-compatible server at {self.cfg.base_url} (llm.base_url) is not reachable "
                f"({type(e).__name__}: {self._quote(e, 300)}); start it (e.g. `python -m llama_cpp.server "
                f"--model <file.gguf>`, `vllm serve <model>`, `ollama serve`) or fix llm.base_url")
        if isinstance(e, openai.AuthenticationError):
            return OpenAIUnavailable(f"{url} refused the API key: set the environment variable "
                                     f"{self.cfg.api_key_env} (llm.api_key_env) to a valid key")
        if isinstance(e, openai.NotFoundError):
            return OpenAIUnavailable(f"{url}: not found ({self._quote(e, 300)}); is llm.model={self.cfg.model!r} "
                                     f"served there (see {self.cfg.base_url}/models)?")
        tries = (f"{attempts} attempt{'s' if attempts != 1 else ''} (llm.max_retries={self.cfg.max_retries}, "
                 f"within llm.timeout_s={self.cfg.timeout_s:g} s)")
        if isinstance(e, openai.RateLimitError):
            return OpenAIServerError(
                f"the server at {url} (llm.base_url) kept rate-limiting: HTTP 429 after {tries}: "
                f"{self._quote(e, 300)}. Wait and rerun (answers already received are in the LLM cache), send "
                f"fewer requests at once (jobs=1), or raise llm.max_retries or llm.timeout_s")
        if isinstance(e, openai.InternalServerError):
            return OpenAIServerError(
                f"the server at {url} (llm.base_url) failed: HTTP {e.status_code} after {tries}: "
                f"{self._quote(e, 300)}. A server error, not a capability the server lacks: check the server "
                f"(its log, its load) and rerun when it answers")
        if isinstance(e, openai.APIStatusError):
            return OpenAIUnavailable(f"{url} answered HTTP {e.status_code}: {self._quote(e, 300)}")
        if isinstance(e, (ValueError, KeyError, TypeError, AttributeError)):  # a 200 whose body is not JSON
            return self._not_json(url, f"{type(e).__name__}: {self._quote(e, 200)}")
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

    def _needs_scores(self) -> list[str]:
        """The llm keys whose mode (score) needs prompt log-probabilities."""
        return [k for k in SCORE_MODES if getattr(self.cfg, k) == "score"]

    def check(self) -> None:
        """Before any stage writes: server up, model served, the modes' needs met (raises)."""
        p = self.probe()
        needs_scores = self._needs_scores()
        if needs_scores and not p.logprobs:
            raise OpenAIUnavailable(
                f"the server at {self.cfg.base_url} returns no prompt log-probabilities (completions with echo "
                f"and logprobs), which llm.{needs_scores[0]}=score needs (OpenAI's chat models have none); use "
                f"llm.proposal_mode=generate llm.cost_inference_mode=generate")

    # -- the probe ------------------------------------------------------------------------------
    def adopt_probe(self, recorded: Any) -> bool:
        """Take what a probe of this server recorded (``ProbeResult.to_dict()``: the stage's
        ``llm_probe.json``) instead of probing again, so every process of a stage uses the one
        structured-output mode that provenance.json records. Nothing is taken (False) when the record
        is of another server or model, or unreadable: this backend then probes on its own."""
        if not isinstance(recorded, dict):
            return False
        try:
            p = ProbeResult(**{k: recorded[k] for k in ProbeResult.__dataclass_fields__ if k in recorded})
        except TypeError:
            return False
        if (p.base_url, p.model) != (self.cfg.base_url, self.cfg.model) or p.json_schema not in SCHEMA_MODES:
            return False
        self._probe, self._schema_mode = p, p.json_schema
        return True

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
        self._schema_mode = p.json_schema = self._probe_schema_mode(p)
        seeded = [self._chat([{"role": "user", "content": "Name a fruit."}], None, "prompt", max_tokens=8,
                             temperature=1.0, seed=7, top_p=1.0).choices[0].message.content for _ in range(2)]
        p.seed_honoured = seeded[0] == seeded[1]
        p.logprobs = self._probe_logprobs(p.notes)
        self._probe = p
        return p

    def _probe_schema_mode(self, p: ProbeResult) -> str:
        """The strongest of SCHEMA_MODES the server accepts and keeps to (``p.notes`` get why a stronger
        one was not taken, ``p.fingerprint`` the first answer's). Each check is retried like any request
        (a transient 429 or 5xx changes nothing); a form the server refuses (HTTP 4xx, or a 5xx that
        persists while a weaker form works: llama-cpp-python's server answers an unknown form with a
        500) is passed over; a 5xx that persists even without a form is a server error (raised)."""
        schema = {"type": "object", "properties": {"color": {"type": "string", "enum": ["red", "blue"]}},
                  "required": ["color"], "additionalProperties": False}
        msgs = [{"role": "user", "content": "Pick a color. Answer in JSON."}]
        notes = p.notes
        for mode in SCHEMA_MODES:
            try:
                r = self._chat(msgs, None if mode == "prompt" else schema, mode, max_tokens=24,
                               temperature=0.0, seed=1, top_p=1.0)
            except (OpenAIUnavailable, OpenAIServerError) as e:
                if mode == "prompt" and isinstance(e, OpenAIServerError):
                    raise
                notes.append(f"response_format {mode}: refused ({str(e)[:120]})")
                continue
            text = r.choices[0].message.content or ""
            p.fingerprint = p.fingerprint or str(r.system_fingerprint or "")
            if mode == "prompt" or _valid(text, schema):
                if mode == "prompt":
                    notes.append("the server enforces no JSON schema: answers are validated and repaired")
                return mode
            notes.append(f"response_format {mode}: accepted but the answer broke the schema "
                         f"({self._quote(text, 60)!r})")
        return "untested"  # every form refused (a 4xx to a plain chat too)

    def _probe_logprobs(self, notes: list[str]) -> bool:
        """Whether echoed completions carry the prompt's log-probabilities. A server that fails or answers
        values the API does not allow (a persistent 5xx, NaN) is not one that lacks them: its error is
        raised where a mode needs scores, else noted."""
        try:
            self._prompt_logprobs("The cat sat on the", " mat")
            return True
        except OpenAIUnavailable as e:  # refused, or answered without them: the server lacks them
            notes.append(f"no prompt log-probabilities ({str(e)[:120]})")
        except OpenAIServerError as e:
            if self._needs_scores():
                raise OpenAIServerError(f"{e} (if its answer says that it cannot echo prompt log-probabilities, "
                                        f"use llm.proposal_mode=generate llm.cost_inference_mode=generate)") from None
            notes.append(f"prompt log-probabilities untested: /completions failed ({str(e)[:200]})")
        except OpenAIProtocolError as e:
            if self._needs_scores():
                raise
            notes.append(f"prompt log-probabilities unusable ({str(e)[:200]})")
        return False

    # -- generation -----------------------------------------------------------------------------
    def _chat(self, messages: list[dict], schema: Optional[dict], mode: str, **options: Any):
        kwargs: dict[str, Any] = dict(model=self.cfg.model, messages=messages, **options)
        if schema is not None and mode == "json_schema":
            kwargs["response_format"] = {"type": "json_schema",
                                         "json_schema": {"name": "answer", "schema": schema, "strict": False}}
        elif schema is not None and mode == "json_object":
            kwargs["response_format"] = {"type": "json_object", "schema": schema}
        return self._call("/chat/completions", lambda c: c.chat.completions.create(**kwargs))

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
    def _prompt_logprobs(self, prompt: str, continuation: str) -> tuple[float, int]:
        """(mean log-probability of the continuation's tokens, prompt tokens) from an echoed completion."""
        text = prompt + continuation
        r = self._call("/completions", lambda c: c.completions.create(
            model=self.cfg.model, prompt=text, max_tokens=1, temperature=0.0, echo=True, logprobs=1))
        tokens, offsets, values, n_prompt = self._read_logprobs(r)
        vals = [v for tok, off, v in zip(tokens, offsets, values, strict=False)
                if off + len(tok) > len(prompt) and off < len(text) and v is not None]
        if not vals:
            raise OpenAIUnavailable(f"{self.cfg.base_url}/completions: no token of {continuation!r} in the echoed "
                                    f"prompt")
        return sum(vals) / len(vals), n_prompt

    def _read_logprobs(self, r: Any) -> tuple[list[str], list[int], list[Optional[float]], int]:
        """(tokens, text offsets, log-probabilities, prompt tokens) of an echoed completion, the prompt's
        tokens only; raises :class:`OpenAIUnavailable` when it has none (the server lacks them) and
        :class:`OpenAIProtocolError` naming the field when they are not what the API allows (a
        log-probability that is not a finite number, a token that is not a string)."""
        url = f"{self.cfg.base_url}/completions"
        field = "choices[0].logprobs"
        try:
            lp = r.choices[0].logprobs
            if lp is None or not lp.token_logprobs or lp.text_offset is None:
                raise OpenAIUnavailable(f"{url} returned no prompt log-probabilities (echo=true, logprobs=1)")
            field = "usage.prompt_tokens"
            n_prompt = int(getattr(r.usage, "prompt_tokens", 0) or 0) or len(lp.tokens)
            field = "choices[0].logprobs.tokens"
            tokens, offsets, values = (list(lp.tokens[:n_prompt]), list(lp.text_offset[:n_prompt]),
                                       list(lp.token_logprobs[:n_prompt]))
        except (AttributeError, IndexError, TypeError, ValueError) as e:
            raise self._bad_logprobs(url, f"{field} cannot be read ({type(e).__name__}: "
                                          f"{self._quote(e, 120)})") from None
        for name, items, ok, want in (
                ("tokens", tokens, lambda x: isinstance(x, str), "a string"),
                ("text_offset", offsets, lambda x: isinstance(x, int) and not isinstance(x, bool), "an integer"),
                ("token_logprobs", values, lambda x: x is None or _finite(x), "a finite number")):
            for i, x in enumerate(items):
                if not ok(x):
                    raise self._bad_logprobs(url, f"choices[0].logprobs.{name}[{i}] is {self._quote(repr(x), 40)} "
                                                  f"({type(x).__name__}), not {want}")
        return tokens, offsets, [None if v is None else float(v) for v in values], n_prompt

    def _bad_logprobs(self, url: str, problem: str) -> OpenAIProtocolError:
        return OpenAIProtocolError(
            f"the server answered {url} (llm.base_url) with log-probabilities the OpenAI API does not allow: "
            f"{problem} (nothing was cached). The server or its model is broken: "
            f"check it (its log, its version), or use llm.proposal_mode=generate llm.cost_inference_mode="
            f"generate, which need no log-probabilities")

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


def _finite(x: Any) -> bool:
    """A real number (not a bool, not a string) that is finite."""
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
