"""The one LLM client every planner and stage uses: cache + backend + call log + repair.

``LLMClient.complete(LLMRequest) -> LLMResponse`` and ``LLMClient.score(ScoreRequest) ->
ScoreResponse``. A request is looked up in the content-addressed cache first (see
:mod:`interllm.llm.cache`); on a miss the backend answers, the answer is validated against the
request's JSON schema (bounded repair retries feed the error back to the model) and stored.
Every call is appended to the call log. ``with_context(**labels)`` returns a view whose calls
carry extra call-log labels (planner, scene, mission, command); a client and its views share one
:class:`~interllm.llm.client_state.ClientCore` (counters, failure share, model identity).

Sampling seeds: attempt ``a`` of a request uses ``llm_sample_seed(options.seed, options.sample_index,
a)`` (``interllm.core.seeding``).
"""

from __future__ import annotations

import dataclasses
import json
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Optional

from interllm.config import LLMConfig
from interllm.core import jsonfmt
from interllm.core.seeding import llm_sample_seed
from interllm.llm.backend import Backend, make_backend
from interllm.llm.cache import CacheMissError, ResponseCache, cache_key
from interllm.llm.calllog import CallLog, make_record
from interllm.llm.client_state import ClientCore, ClientStats
from interllm.llm.entry_layout import complete_problem, score_problem
from interllm.llm.errors import LLMOutputError
from interllm.llm.prompts import template_hash
from interllm.llm.schema import check_answer, validate_schema
from interllm.llm.types import (
    LLMOptions,
    LLMRequest,
    LLMResponse,
    Message,
    ScoreRequest,
    ScoreResponse,
)


class LLMClient:
    """Cached, logged, schema-checked access to one backend. Build it with :func:`make_client`."""

    def __init__(self, core: ClientCore, context: tuple[tuple[str, str], ...] = (),
                 observers: tuple[Callable[[Any, Any], None], ...] = ()) -> None:
        self._core = core
        self.context = tuple(context)
        self._observers = tuple(observers)

    # -- views and properties ----------------------------------------------------------------
    def with_context(self, **labels: Any) -> LLMClient:
        """A view sharing backend, cache, counters, log and observers, adding call-log labels."""
        merged = dict(self.context)
        merged.update({k: str(v) for k, v in labels.items() if v is not None})
        return LLMClient(self._core, tuple(sorted(merged.items())), self._observers)

    def with_observer(self, observer: Callable[[Any, Any], None]) -> LLMClient:
        """A view that also calls ``observer(request, response)`` after each answered call (the run
        log's /llm/calls and the per-command tally use it)."""
        return LLMClient(self._core, self.context, self._observers + (observer,))

    def _notify(self, request: Any, response: Any) -> None:
        for observe in self._observers:
            observe(request, response)

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
        scorer = getattr(self.backend, "scorer", "")  # a backend that names its decode layout
        if scorer:
            summary["scorer"] = scorer
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
        response = self._complete(request)
        self._notify(request, response)
        return response

    def _complete(self, request: LLMRequest) -> LLMResponse:
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
                                     f"sample_index={request.options.sample_index}", layout=_complete_layout(request))
            except CacheMissError as e:
                core.stats.failures += 1
                self._log(kind="complete", purpose=request.purpose, context=labels, key=key, tokens_in=0,
                          tokens_out=0, latency=0.0, cached=False, error=str(e),
                          sample_index=request.options.sample_index)
                raise
            if hit is not None and hit.get("failed"):  # the model's answer stayed invalid when it was asked
                core.stats.cache_hits += 1
                self._raise_output_failure(request, key, labels, hit, latency=0.0, reused=0, cached=True)
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
                held = core.cache.put(key, summary, response, layout=_complete_layout(request))
                if held is not response and held.get("failed"):  # another process stored a failure first
                    self._raise_output_failure(request, key, labels, held, latency, reused, cached=False)
                if held is not response:  # another process answered first: go on with the cached answer
                    text, tin, tout = held["text"], held["tokens_in"], held["tokens_out"]
                    errors = list(held.get("errors", []))
                    parsed = json.loads(text) if request.schema is not None else None
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
        # the outcome is cached like an answer (first writer wins), so that a replay and every other
        # process asking the same request meet the same failure, not a luckier sample
        failed = {"failed": True, "text": text, "tokens_in": tin, "tokens_out": tout, "errors": errors,
                  "attempts": core.cfg.repair_retries + 1}
        held = core.cache.put(key, summary, failed, layout=_complete_layout(request))
        if held is not failed and not held.get("failed"):  # another process stored an answer first
            parsed = json.loads(held["text"]) if request.schema is not None else None
            held_errors = tuple(held.get("errors", ()))
            self._log(kind="complete", purpose=request.purpose, context=labels, key=key, tokens_in=held["tokens_in"],
                      tokens_out=held["tokens_out"], latency=latency, cached=False, prompt_tokens_reused=reused,
                      errors=held_errors, sample_index=request.options.sample_index)
            return LLMResponse(text=held["text"], parsed=parsed, tokens_in=held["tokens_in"],
                               tokens_out=held["tokens_out"], latency=latency, cached=False, key=key,
                               prompt_tokens_reused=reused, errors=held_errors)
        self._raise_output_failure(request, key, labels, held, latency, reused, cached=False)

    def _raise_output_failure(self, request: LLMRequest, key: str, labels: tuple, entry: dict, latency: float,
                              reused: int, cached: bool):
        """Log an answer that stayed invalid after the repairs (``entry``: the failed outcome) and raise
        :class:`LLMOutputError`, or :class:`LLMQualityError` when failures are over their share."""
        core = self._core
        core.stats.failures += 1
        errors = list(entry["errors"])
        msg = (f"LLM output for purpose={request.purpose!r} stayed invalid after "
               f"{int(entry['attempts']) - 1} repair retries (llm.repair_retries): {errors[-1]}")
        self._log(kind="complete", purpose=request.purpose, context=labels, key=key, tokens_in=entry["tokens_in"],
                  tokens_out=entry["tokens_out"], latency=latency, cached=cached, prompt_tokens_reused=reused,
                  errors=tuple(errors), error=msg, sample_index=request.options.sample_index,
                  answer=str(entry["text"])[:200])
        stop = core.note_failure(str(entry["text"]), cached)
        if stop is not None:
            raise stop from LLMOutputError(msg, tuple(errors), entry["text"])
        raise LLMOutputError(msg, tuple(errors), entry["text"])

    # -- score --------------------------------------------------------------------------------
    def score(self, request: ScoreRequest) -> ScoreResponse:
        """Mean token log-prob of each continuation (calibrated when a calibration prompt is set)."""
        response = self._score(request)
        self._notify(request, response)
        return response

    def _score(self, request: ScoreRequest) -> ScoreResponse:
        if not request.continuations:
            raise ValueError(f"ScoreRequest(purpose={request.purpose!r}).continuations is empty")
        core = self._core
        labels = self._labels(request.context)
        with core.lock:
            key, summary = self.score_key(request)
            core.stats.calls += 1
            core.stats.score_calls += 1
            layout = _score_layout(request)
            try:
                hit = core.cache.get(key, request.purpose,
                                     describe=f"score of {len(request.continuations)} continuations", layout=layout)
            except CacheMissError as e:
                core.stats.failures += 1
                self._log(kind="score", purpose=request.purpose, context=labels, key=key, tokens_in=0,
                          tokens_out=0, latency=0.0, cached=False, error=str(e))
                raise
            if hit is not None:  # its layout was checked: as many finite scores as continuations
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
            held = core.cache.put(key, summary, response, layout=layout)
            if held is not response:  # another process answered first: go on with the cached answer
                raw, scores = list(held["raw"]), list(held["scores"])
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


def _complete_layout(request: LLMRequest) -> Callable[[dict], Optional[str]]:
    """The cache's layout check of a generation request's stored outcome."""
    return lambda resp: complete_problem(resp, request.schema is not None)


def _score_layout(request: ScoreRequest) -> Callable[[dict], Optional[str]]:
    """The cache's layout check of a score request's stored scores."""
    return lambda resp: score_problem(resp, len(request.continuations))


def make_client(cfg: LLMConfig, call_log_path: Optional[str | Path] = None,
                context: Sequence[tuple[str, str]] | dict = (), *, backend: Optional[Backend] = None,
                call_log_callback: Optional[Callable[[dict], Any]] = None,
                cache_dir: Optional[str | Path] = None, probe: Optional[dict] = None) -> LLMClient:
    """Build the client for ``cfg``.

    call_log_path: JSONL call log (None: no file); context: default call-log labels, e.g.
    ``{"stage": "candidates"}``; backend: inject a backend (tests: :class:`DeterministicBackend`);
    call_log_callback: receives each call-log record (e.g. the MCAP recorder); cache_dir:
    overrides ``cfg.cache_dir``; probe: what the stage's conformance probe recorded (``preflight``'s
    result, ``llm_probe.json``): a backend that probes its server takes it (``adopt_probe``) instead
    of probing on its own, so every process of a stage uses one structured-output mode.
    """
    be = backend if backend is not None else make_backend(cfg)
    adopt = getattr(be, "adopt_probe", None)
    if probe is not None and adopt is not None:
        adopt(probe)
    cache = ResponseCache(cache_dir if cache_dir is not None else cfg.cache_dir, cfg.cache_mode)
    call_log = (CallLog(call_log_path, call_log_callback)
                if call_log_path is not None or call_log_callback is not None else None)
    ctx = tuple(sorted((str(k), str(v)) for k, v in (context.items() if isinstance(context, dict)
                                                      else context)))
    return LLMClient(ClientCore(cfg, be, cache, call_log), ctx)


def complete_or_none(client: Any, request: LLMRequest) -> Optional[LLMResponse]:
    """``client.complete(request)``, with an answer that stays malformed after the client's repair
    retries turned into ``None`` (the caller falls back: an empty plan, an "unknown" label)."""
    try:
        return client.complete(request)
    except LLMOutputError:
        return None
