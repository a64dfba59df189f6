"""The one LLM client every planner and stage uses: cache + backend + call log + repair.

``LLMClient.complete(LLMRequest) -> LLMResponse`` and ``LLMClient.score(ScoreRequest) ->
ScoreResponse``. A request is looked up in the content-addressed cache first (see
:mod:`interllm.llm.cache`); on a miss the backend answers, the answer is validated against the
request's JSON schema (bounded repair retries feed the error back to the model) and stored.
Every call is appended to the call log. ``with_context(**labels)`` returns a view whose calls
carry extra call-log labels (planner, scene, mission, command).

Sampling seeds: attempt ``a`` of a request uses ``llm_sample_seed(options.seed, options.sample_index,
a)`` (``interllm.core.seeding``).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import random
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional, Protocol

import jsonschema

from interllm.config import LLMConfig
from interllm.core import jsonfmt
from interllm.core.seeding import llm_sample_seed
from interllm.errors import UserError
from interllm.io import atomic_write_text
from interllm.llm.cache import CacheMissError, ResponseCache, cache_key
from interllm.llm.calllog import CallLog, make_record
from interllm.llm.embedded import Generation, Scores
from interllm.llm.prompts import template_hash
from interllm.llm.types import (
    LLMOptions,
    LLMRequest,
    LLMResponse,
    Message,
    ScoreRequest,
    ScoreResponse,
)

log = logging.getLogger(__name__)

MODELS_PIN_FILE = "models.json"  # in cache_dir: model name -> identity, for offline replay


class LLMError(UserError, RuntimeError):
    """The backend failed, or its output stayed invalid after the repair retries."""


class LLMOutputError(LLMError):
    """The answer did not parse / satisfy the schema after ``llm.repair_retries`` re-asks."""

    def __init__(self, msg: str, errors: tuple[str, ...] = (), text: str = "") -> None:
        super().__init__(msg)
        self.errors = errors
        self.text = text

    def __reduce__(self):  # picklable from a worker process with its extra fields
        return (type(self), (str(self), self.errors, self.text))


class LLMQualityError(LLMError):
    """Too large a share of a backend's answers failed or did not parse (``llm.max_failure_share``):
    the model or server is broken, and an experiment on its answers would measure nothing."""


MIN_CALLS_FOR_EARLY_STOP = 20  # judge the failure share mid-stage only after this many calls


def call_log_failures(path: str | Path) -> tuple[int, int, str, str, str]:
    """(calls, failed calls, a failed call's answer, backend, model) of a JSONL call log."""
    n = failed = 0
    sample = backend = model = ""
    p = Path(path)
    if not p.is_file():
        return 0, 0, "", "", ""
    for line in p.read_text(encoding="utf-8", errors="replace").splitlines():
        try:
            r = json.loads(line)
        except ValueError:
            continue  # a line cut by a crash
        n += 1
        backend, model = str(r.get("backend", backend)), str(r.get("model", model))
        if r.get("error"):
            failed += 1
            sample = sample or str(r.get("answer") or r["error"])
    return n, failed, sample, backend, model


def check_failure_share(call_log: str | Path, cfg: LLMConfig, where: str) -> None:
    """Raise :class:`LLMQualityError` when more than ``cfg.max_failure_share`` of the calls in
    ``call_log`` failed (the end-of-stage check; clients also stop early, see ``note_failure``)."""
    n, failed, sample, backend, model = call_log_failures(call_log)
    if n and failed > cfg.max_failure_share * n:
        raise LLMQualityError(failure_share_message(backend, model, n, failed, cfg.max_failure_share,
                                                    sample, f"{where} (call log {call_log})"))


def failure_share_message(backend: str, model: str, n_calls: int, n_failed: int, bound: float,
                          sample: str, where: str) -> str:
    share = n_failed / max(1, n_calls)
    return (f"{where}: {n_failed} of {n_calls} LLM calls ({100 * share:.0f}%) to backend {backend!r} "
            f"(model {model!r}) failed or gave unparseable answers, above llm.max_failure_share="
            f"{bound:g}; sample answer: {sample[:200]!r}. Check the model and server (a base model in "
            f"generate mode? the wrong llm.model?), or raise llm.max_failure_share to go on anyway")


class Backend(Protocol):
    name: str

    def model_name(self) -> str: ...

    def model_id(self) -> str: ...

    def generate(self, messages: Sequence[Message], schema: Optional[dict], options: LLMOptions,
                 seed: int) -> Generation: ...

    def score(self, prompt: str, continuations: Sequence[str],
              calibration_prompt: Optional[str] = None) -> Scores: ...

    def close(self) -> None: ...


@dataclass
class ClientStats:
    """Counters over a client's lifetime (views share them)."""

    calls: int = 0  # complete + score calls
    complete_calls: int = 0
    score_calls: int = 0
    cache_hits: int = 0
    backend_calls: int = 0  # backend round trips incl. repair attempts
    tokens_in: int = 0  # prompt tokens of backend calls (0 for cache hits)
    tokens_out: int = 0
    prompt_tokens_reused: int = 0  # of tokens_in, served from the backend's KV prefix cache
    repairs: int = 0  # re-asks after invalid output
    failures: int = 0
    backend_seconds: float = 0.0  # wall time in the backend [s] (diagnostics only)



def validate_schema(schema: dict) -> None:
    """Raise ValueError unless ``schema`` is a valid JSON Schema (checked once per schema)."""
    _validator(schema)




_VALIDATORS: dict[str, Any] = {}


def _validator(schema: dict):
    k = json.dumps(schema, sort_keys=True)
    v = _VALIDATORS.get(k)
    if v is None:
        if len(_VALIDATORS) > 512:
            _VALIDATORS.clear()
        try:
            jsonschema.Draft202012Validator.check_schema(schema)
        except jsonschema.SchemaError as e:
            raise ValueError(f"LLMRequest.schema is not a valid JSON Schema: {e.message}") from None
        v = _VALIDATORS[k] = jsonschema.Draft202012Validator(schema)
    return v


def check_answer(text: str, schema: Optional[dict]) -> tuple[Any, Optional[str]]:
    """(parsed, None) when ``text`` is JSON satisfying ``schema``; (None, error text) otherwise."""
    if schema is None:
        return None, None
    try:
        parsed = json.loads(text)
    except json.JSONDecodeError as e:
        return None, f"the answer is not valid JSON ({e.msg} at line {e.lineno} column {e.colno})"
    errs = sorted(_validator(schema).iter_errors(parsed), key=lambda e: list(e.path))
    if errs:
        e = errs[0]
        where = "/".join(str(p) for p in e.path) or "(root)"
        return None, f"the answer violates the JSON schema at {where}: {e.message}"
    return parsed, None


class _Core:
    """State shared by a client and its views."""

    def __init__(self, cfg: LLMConfig, backend: Backend, cache: ResponseCache,
                 call_log: Optional[CallLog]) -> None:
        self.cfg = cfg
        self.backend = backend
        self.cache = cache
        self.call_log = call_log
        self.stats = ClientStats()
        self.lock = threading.RLock()
        self._model_id: Optional[str] = None
        self.failed_calls = 0  # calls that ended in an error (unparseable after repairs, backend error)
        self.last_failed_answer = ""

    def note_failure(self, answer: str) -> Optional[LLMQualityError]:
        """Count a failed call; the error to raise instead when the failure share is over its bound."""
        self.failed_calls += 1
        self.last_failed_answer = answer
        n, bound = self.stats.calls, self.cfg.max_failure_share
        if n >= MIN_CALLS_FOR_EARLY_STOP and self.failed_calls > bound * n:
            return LLMQualityError(failure_share_message(
                self.backend.name, self.backend.model_name(), n, self.failed_calls, bound, answer,
                "stopping early"))
        return None

    def model_id(self) -> str:
        """Backend model identity for cache keys; pinned in ``<cache_dir>/models.json`` so
        replay works offline (e.g. without the Ollama server)."""
        if self._model_id is not None:
            return self._model_id
        name = f"{self.backend.name}:{self.backend.model_name()}"
        pin_path = self.cache.dir / MODELS_PIN_FILE
        pins: dict = {}
        try:
            pins = json.loads(pin_path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            pins = {}
        try:
            mid = self.backend.model_id()
        except Exception as e:  # noqa: BLE001 - backend unreachable
            if self.cache.mode == "replay" and name in pins:
                mid = pins[name]
                log.info("model identity of %s from %s (backend unavailable: %s)", name, pin_path, e)
            else:
                raise
        if self.cache.mode == "readwrite" and self.cache.writable and pins.get(name) != mid:
            pins[name] = mid
            try:
                atomic_write_text(pin_path, json.dumps(pins, indent=1, sort_keys=True) + "\n")
            except OSError as e:
                self.cache.writable = False
                log.warning("LLM cache %s cannot be written (%s: %s); answers of this run are not cached",
                            self.cache.dir, pin_path, e.strerror or e)
        self._model_id = mid
        return mid


class LLMClient:
    """Cached, logged, schema-checked access to one backend. Build it with :func:`make_client`."""

    def __init__(self, core: _Core, context: tuple[tuple[str, str], ...] = ()) -> None:
        self._core = core
        self.context = tuple(context)

    # -- views and properties ----------------------------------------------------------------
    def with_context(self, **labels: Any) -> LLMClient:
        """A view sharing backend, cache, counters and log, adding call-log labels."""
        merged = dict(self.context)
        merged.update({k: str(v) for k, v in labels.items() if v is not None})
        return LLMClient(self._core, tuple(sorted(merged.items())))

    @property
    def cfg(self) -> LLMConfig:
        return self._core.cfg

    @property
    def backend(self) -> Backend:
        return self._core.backend

    @property
    def cache(self) -> ResponseCache:
        return self._core.cache

    @property
    def stats(self) -> ClientStats:
        return self._core.stats

    @property
    def calls(self) -> int:
        return self._core.stats.calls

    @property
    def cache_hits(self) -> int:
        return self._core.stats.cache_hits

    @property
    def tokens(self) -> int:
        return self._core.stats.tokens_in + self._core.stats.tokens_out

    def default_options(self, **overrides: Any) -> LLMOptions:
        """LLMOptions from the config (temperature, top_p, max_tokens, seed) with overrides."""
        c = self._core.cfg
        base = dict(temperature=c.temperature, top_p=c.top_p, max_tokens=c.max_tokens, seed=c.seed)
        base.update(overrides)
        return LLMOptions(**base)

    def model_id(self) -> str:
        return self._core.model_id()

    # -- keys ---------------------------------------------------------------------------------
    def _template(self, name: str) -> dict:
        return {"name": name, "sha256": template_hash(name)} if name else {"name": "", "sha256": ""}

    def complete_key(self, request: LLMRequest) -> tuple[str, dict]:
        """(cache key, request summary) of a generation request."""
        summary = {
            "kind": "complete", "backend": self.backend.name, "model": self.backend.model_name(),
            "model_id": self.model_id(),
            "messages": [[m.role, m.content] for m in request.messages],
            "schema": jsonfmt.normalised(request.schema) if request.schema is not None else None,
            "options": dataclasses.asdict(request.options),
            "template": self._template(request.template),
        }
        return cache_key(summary), summary

    def score_key(self, request: ScoreRequest) -> tuple[str, dict]:
        summary = {
            "kind": "score", "backend": self.backend.name, "model": self.backend.model_name(),
            "model_id": self.model_id(), "prompt": request.prompt,
            "continuations": list(request.continuations),
            "calibration_prompt": request.calibration_prompt,
            "template": self._template(request.template),
        }
        return cache_key(summary), summary

    # -- logging ------------------------------------------------------------------------------
    def _log(self, **kw: Any) -> None:
        cl = self._core.call_log
        if cl is not None:
            cl.write(make_record(backend=self.backend.name, model=self.backend.model_name(), **kw))

    def _labels(self, req_context: tuple[tuple[str, str], ...]) -> tuple[tuple[str, str], ...]:
        merged = dict(self.context)
        merged.update(dict(req_context))
        return tuple(sorted(merged.items()))

    # -- complete -----------------------------------------------------------------------------
    def complete(self, request: LLMRequest) -> LLMResponse:
        """Answer a generation request (cache first; schema-valid or :class:`LLMOutputError`)."""
        if not request.messages:
            raise ValueError(f"LLMRequest(purpose={request.purpose!r}).messages is empty")
        if request.schema is not None:
            validate_schema(request.schema)
        core = self._core
        labels = self._labels(request.context)
        with core.lock:
            key, summary = self.complete_key(request)
            core.stats.calls += 1
            core.stats.complete_calls += 1
            try:
                hit = core.cache.get(key, request.purpose, describe=f"{len(request.messages)} messages, "
                                     f"sample_index={request.options.sample_index}")
            except CacheMissError as e:
                core.stats.failures += 1
                self._log(kind="complete", purpose=request.purpose, context=labels, key=key, tokens_in=0,
                          tokens_out=0, latency=0.0, cached=False, error=str(e),
                          sample_index=request.options.sample_index)
                raise
            if hit is not None:
                # the key covers the schema and the entry's checksum held: it was validated when stored
                parsed = json.loads(hit["text"]) if request.schema is not None else None
                core.stats.cache_hits += 1
                resp = LLMResponse(text=hit["text"], parsed=parsed, tokens_in=hit["tokens_in"],
                                   tokens_out=hit["tokens_out"], latency=0.0, cached=True, key=key,
                                   errors=tuple(hit.get("errors", ())))
                self._log(kind="complete", purpose=request.purpose, context=labels, key=key,
                          tokens_in=resp.tokens_in, tokens_out=resp.tokens_out, latency=0.0,
                          cached=True, errors=resp.errors, sample_index=request.options.sample_index)
                return resp
            return self._complete_backend(request, key, summary, labels)

    def _complete_backend(self, request: LLMRequest, key: str, summary: dict,
                          labels: tuple[tuple[str, str], ...]) -> LLMResponse:
        core = self._core
        messages = list(request.messages)
        errors: list[str] = []
        tin = tout = reused = 0
        latency = 0.0
        text = ""
        for attempt in range(core.cfg.repair_retries + 1):
            seed = llm_sample_seed(request.options.seed, request.options.sample_index, attempt)
            t0 = time.perf_counter()
            try:
                gen = core.backend.generate(tuple(messages), request.schema, request.options, seed)
            except Exception as e:
                latency += time.perf_counter() - t0
                core.stats.failures += 1
                self._log(kind="complete", purpose=request.purpose, context=labels, key=key,
                          tokens_in=tin, tokens_out=tout, latency=latency, cached=False,
                          errors=tuple(errors), error=f"{type(e).__name__}: {e}",
                          sample_index=request.options.sample_index)
                core.note_failure(f"({type(e).__name__}: {e})")
                raise
            dt = time.perf_counter() - t0
            latency += dt
            core.stats.backend_calls += 1
            core.stats.backend_seconds += dt
            tin += gen.tokens_in
            tout += gen.tokens_out
            reused += gen.prompt_tokens_reused
            core.stats.tokens_in += gen.tokens_in
            core.stats.tokens_out += gen.tokens_out
            core.stats.prompt_tokens_reused += gen.prompt_tokens_reused
            text = gen.text
            parsed, err = check_answer(text, request.schema)
            if err is not None and gen.truncated:
                err += (f" (the answer was cut at max_tokens={request.options.max_tokens}; raise "
                        f"llm.max_tokens / LLMOptions.max_tokens)")
            if err is None:
                response = {"text": text, "tokens_in": tin, "tokens_out": tout, "errors": errors,
                            "attempts": attempt + 1}
                core.cache.put(key, summary, response)
                self._log(kind="complete", purpose=request.purpose, context=labels, key=key,
                          tokens_in=tin, tokens_out=tout, latency=latency, cached=False,
                          prompt_tokens_reused=reused, errors=tuple(errors),
                          sample_index=request.options.sample_index)
                return LLMResponse(text=text, parsed=parsed, tokens_in=tin, tokens_out=tout,
                                   latency=latency, cached=False, key=key,
                                   prompt_tokens_reused=reused, errors=tuple(errors))
            errors.append(err)
            if attempt < core.cfg.repair_retries:
                core.stats.repairs += 1
                messages += [Message("assistant", text),
                             Message("user", f"Your answer was invalid: {err}. Answer again with only "
                                             f"a JSON value that satisfies the schema.")]
        core.stats.failures += 1
        msg = (f"LLM output for purpose={request.purpose!r} stayed invalid after "
               f"{core.cfg.repair_retries} repair retries (llm.repair_retries): {errors[-1]}")
        self._log(kind="complete", purpose=request.purpose, context=labels, key=key, tokens_in=tin,
                  tokens_out=tout, latency=latency, cached=False, prompt_tokens_reused=reused,
                  errors=tuple(errors), error=msg, sample_index=request.options.sample_index,
                  answer=text[:200])
        stop = core.note_failure(text)
        if stop is not None:
            raise stop from LLMOutputError(msg, tuple(errors), text)
        raise LLMOutputError(msg, tuple(errors), text)

    # -- score --------------------------------------------------------------------------------
    def score(self, request: ScoreRequest) -> ScoreResponse:
        """Mean token log-prob of each continuation (calibrated when a calibration prompt is set)."""
        if not request.continuations:
            raise ValueError(f"ScoreRequest(purpose={request.purpose!r}).continuations is empty")
        core = self._core
        labels = self._labels(request.context)
        with core.lock:
            key, summary = self.score_key(request)
            core.stats.calls += 1
            core.stats.score_calls += 1
            try:
                hit = core.cache.get(key, request.purpose,
                                     describe=f"score of {len(request.continuations)} continuations")
            except CacheMissError as e:
                core.stats.failures += 1
                self._log(kind="score", purpose=request.purpose, context=labels, key=key, tokens_in=0,
                          tokens_out=0, latency=0.0, cached=False, error=str(e))
                raise
            if hit is not None and len(hit.get("raw", ())) == len(request.continuations):
                core.stats.cache_hits += 1
                self._log(kind="score", purpose=request.purpose, context=labels, key=key,
                          tokens_in=hit["tokens_in"], tokens_out=0, latency=0.0, cached=True)
                return ScoreResponse(scores=list(hit["scores"]), raw=list(hit["raw"]),
                                     tokens_in=hit["tokens_in"], latency=0.0, cached=True, key=key)
            t0 = time.perf_counter()
            try:
                sc = core.backend.score(request.prompt, request.continuations, request.calibration_prompt)
            except Exception as e:
                core.stats.failures += 1
                self._log(kind="score", purpose=request.purpose, context=labels, key=key, tokens_in=0,
                          tokens_out=0, latency=time.perf_counter() - t0, cached=False,
                          error=f"{type(e).__name__}: {e}")
                core.note_failure(f"({type(e).__name__}: {e})")
                raise
            dt = time.perf_counter() - t0
            core.stats.backend_calls += 1
            core.stats.backend_seconds += dt
            core.stats.tokens_in += sc.tokens_in
            core.stats.prompt_tokens_reused += sc.prompt_tokens_reused
            raw = [float(x) for x in sc.raw]
            scores = ([r - c for r, c in zip(raw, sc.calibration, strict=False)] if sc.calibration is not None else raw)
            response = {"raw": raw, "scores": scores, "tokens_in": sc.tokens_in, "method": sc.method,
                        "calibration": list(sc.calibration) if sc.calibration is not None else None}
            core.cache.put(key, summary, response)
            self._log(kind="score", purpose=request.purpose, context=labels, key=key,
                      tokens_in=sc.tokens_in, tokens_out=0, latency=dt, cached=False,
                      prompt_tokens_reused=sc.prompt_tokens_reused)
            return ScoreResponse(scores=scores, raw=raw, tokens_in=sc.tokens_in, latency=dt, cached=False,
                                 key=key, prompt_tokens_reused=sc.prompt_tokens_reused)

    # -- lifecycle ----------------------------------------------------------------------------
    def close(self) -> None:
        """Close the backend and the call log (views share them: close the root client once)."""
        self._core.backend.close()
        if self._core.call_log is not None:
            self._core.call_log.close()

    def __enter__(self) -> LLMClient:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


# -- a deterministic test backend -------------------------------------------------------------

def schema_instance(schema: dict, rng: random.Random, root: Optional[dict] = None, depth: int = 0) -> Any:
    """A value satisfying ``schema`` drawn with ``rng`` (covers the subset our prompts use:
    type object/array/string/integer/number/boolean/null, enum, const, anyOf/oneOf, local $ref,
    required, min/maxItems, uniqueItems, minimum/maximum, minLength)."""
    root = schema if root is None else root
    if depth > 20:
        raise ValueError("schema nesting too deep for schema_instance")
    if "$ref" in schema:
        ref = schema["$ref"]
        if not ref.startswith("#/"):
            raise ValueError(f"only local $ref are supported, got {ref!r}")
        node: Any = root
        for part in ref[2:].split("/"):
            node = node[part]
        return schema_instance(node, rng, root, depth + 1)
    if "const" in schema:
        return schema["const"]
    if "enum" in schema:
        return rng.choice(list(schema["enum"]))
    for k in ("anyOf", "oneOf"):
        if k in schema:
            return schema_instance(schema[k][0], rng, root, depth + 1)
    if "allOf" in schema:
        merged: dict = {}
        for s in schema["allOf"]:
            merged.update(s)
        return schema_instance(merged, rng, root, depth + 1)
    t = schema.get("type", "object" if "properties" in schema else "string")
    if isinstance(t, list):
        t = t[0]
    if t == "object":
        props = schema.get("properties", {})
        keys = list(schema.get("required", list(props)))
        return {k: schema_instance(props.get(k, {"type": "string"}), rng, root, depth + 1) for k in keys}
    if t == "array":
        lo = int(schema.get("minItems", 1))
        hi = int(schema.get("maxItems", max(lo, 3)))
        n = rng.randint(lo, max(lo, hi))
        items = schema.get("items", {"type": "string"})
        out: list = []
        tries = 0
        while len(out) < n and tries < 50 * (n + 1):
            tries += 1
            v = schema_instance(items, rng, root, depth + 1)
            if schema.get("uniqueItems") and v in out:
                continue
            out.append(v)
        return out
    if t == "integer":
        lo = int(schema.get("minimum", 0))
        return rng.randint(lo, int(schema.get("maximum", lo + 20)))
    if t == "number":
        lo = float(schema.get("minimum", 0.0))
        return round(rng.uniform(lo, float(schema.get("maximum", lo + 20.0))), 3)
    if t == "boolean":
        return rng.random() < 0.5
    if t == "null":
        return None
    n = max(int(schema.get("minLength", 1)), 1)
    return "".join(rng.choice("abcdefghijklmnopqrstuvwxyz") for _ in range(max(n, 4)))


class DeterministicBackend:
    """Test backend for code where the LLM is not under test: schema-valid JSON drawn from a
    seeded RNG (seed = the call's seed and the messages), scores from a hash of the text.

    ``generate_fn(messages, schema, options, seed) -> str`` / ``score_fn(prompt, cont) -> float``
    replace the defaults to script answers.
    """

    name = "deterministic"

    def __init__(self, generate_fn: Optional[Callable[..., str]] = None,
                 score_fn: Optional[Callable[[str, str], float]] = None, model: str = "deterministic-v1"):
        self.generate_fn = generate_fn
        self.score_fn = score_fn
        self.model = model
        self.generate_calls = 0
        self.score_calls = 0

    def model_name(self) -> str:
        return self.model

    def model_id(self) -> str:
        return hashlib.sha256(self.model.encode()).hexdigest()

    def generate(self, messages: Sequence[Message], schema: Optional[dict], options: LLMOptions,
                 seed: int) -> Generation:
        self.generate_calls += 1
        if self.generate_fn is not None:
            text = self.generate_fn(messages, schema, options, seed)
        else:
            rng = random.Random(llm_sample_seed(seed, [[m.role, m.content] for m in messages].__repr__()))
            text = jsonfmt.compact(schema_instance(schema, rng)) if schema is not None else "ok"
        tin = sum(len(m.content.split()) + 4 for m in messages)
        return Generation(text=text, tokens_in=tin, tokens_out=max(1, len(text) // 4))

    def score(self, prompt: str, continuations: Sequence[str],
              calibration_prompt: Optional[str] = None) -> Scores:
        self.score_calls += 1

        def f(p: str, c: str) -> float:
            if self.score_fn is not None:
                return float(self.score_fn(p, c))
            return -1.0 - llm_sample_seed(p, c) / 2**31 * 9.0  # in (-10, -1]

        raw = [f(prompt, c) for c in continuations]
        calib = [f(calibration_prompt, c) for c in continuations] if calibration_prompt is not None else None
        return Scores(raw=raw, calibration=calib,
                      tokens_in=len(prompt.split()) + sum(len(c.split()) for c in continuations))

    def close(self) -> None:
        pass


def make_backend(cfg: LLMConfig) -> Backend:
    """The backend named by ``cfg.backend`` (no model load or server contact yet)."""
    if cfg.backend == "embedded":
        from interllm.llm.embedded import EmbeddedBackend

        return EmbeddedBackend(cfg)
    if cfg.backend == "ollama":
        from interllm.llm.ollama_backend import OllamaBackend

        return OllamaBackend(cfg)
    raise ValueError(f"config key 'llm.backend': {cfg.backend!r} is not valid; choose one of "
                     f"['embedded', 'ollama']")


def preflight(cfg: LLMConfig) -> None:
    """Before any stage output is written: is the backend there (server up, model present, model
    file readable)? Raises the backend's error naming the URL or file and the fix. Nothing to
    check in replay mode, where the cache answers everything."""
    if cfg.cache_mode == "replay":
        return
    backend = make_backend(cfg)
    check = getattr(backend, "check", None)
    if check is not None:
        check()


def make_client(cfg: LLMConfig, call_log_path: Optional[str | Path] = None,
                context: Sequence[tuple[str, str]] | dict = (), *, backend: Optional[Backend] = None,
                call_log_callback: Optional[Callable[[dict], Any]] = None,
                cache_dir: Optional[str | Path] = None) -> LLMClient:
    """Build the client for ``cfg``.

    call_log_path: JSONL call log (None: no file); context: default call-log labels, e.g.
    ``{"stage": "candidates"}``; backend: inject a backend (tests: :class:`DeterministicBackend`);
    call_log_callback: receives each call-log record (e.g. the MCAP recorder); cache_dir:
    overrides ``cfg.cache_dir``.
    """
    be = backend if backend is not None else make_backend(cfg)
    cache = ResponseCache(cache_dir if cache_dir is not None else cfg.cache_dir, cfg.cache_mode)
    call_log = (CallLog(call_log_path, call_log_callback)
                if call_log_path is not None or call_log_callback is not None else None)
    ctx = tuple(sorted((str(k), str(v)) for k, v in (context.items() if isinstance(context, dict)
                                                      else context)))
    return LLMClient(_Core(cfg, be, cache, call_log), ctx)
