"""Is the model answering? The share of failed or unparseable calls, judged against
``llm.max_failure_share`` mid-stage (by a client) and at the end of a stage (from its call log)."""

from __future__ import annotations

import json
from pathlib import Path

from interllm.config import LLMConfig
from interllm.llm.errors import LLMQualityError

MIN_CALLS_FOR_EARLY_STOP = 20  # judge the failure share mid-stage only after this many calls


def call_log_failures(path: str | Path) -> tuple[int, int, str, str, str, int]:
    """(calls, failed calls, a failed call's answer, backend, model, failed calls the cache answered)
    of a JSONL call log."""
    n = failed = cached = 0
    sample = backend = model = ""
    p = Path(path)
    if not p.is_file():
        return 0, 0, "", "", "", 0
    for line in p.read_text(encoding="utf-8", errors="replace").splitlines():
        try:
            r = json.loads(line)
        except ValueError:
            continue  # a line cut by a crash
        n += 1
        backend, model = str(r.get("backend", backend)), str(r.get("model", model))
        if r.get("error"):
            failed += 1
            cached += bool(r.get("cache_hit"))
            sample = sample or str(r.get("answer") or r["error"])
    return n, failed, sample, backend, model, cached


def check_failure_share(call_log: str | Path, cfg: LLMConfig, where: str) -> None:
    """Raise :class:`LLMQualityError` when more than ``cfg.max_failure_share`` of the calls in
    ``call_log`` failed (the end-of-stage check; clients also stop early, see ``note_failure``)."""
    n, failed, sample, backend, model, cached = call_log_failures(call_log)
    if n and failed > cfg.max_failure_share * n:
        raise LLMQualityError(failure_share_message(
            backend=backend, model=model, n_calls=n, n_failed=failed, bound=cfg.max_failure_share,
            sample=sample, where=f"{where} (call log {call_log})", n_cached=cached, cache_dir=cfg.cache_dir))


def failure_share_message(*, backend: str, model: str, n_calls: int, n_failed: int, bound: float,
                          sample: str, where: str, n_cached: int = 0, cache_dir: str = "") -> str:
    """The failure-share stop: ``n_failed`` of ``n_calls`` calls to ``backend``/``model`` failed,
    over the share ``bound`` (fraction); ``sample``: one failed answer; ``where``: the stage or log.
    When the cache answered ``n_cached`` of the failed calls (failures stored by an earlier run in
    ``cache_dir``, replayed without asking the server), it says so and how to ask again: a run with
    ``llm.cache_mode=retry_failures``, which replaces the stored failures with the new outcomes."""
    share = n_failed / max(1, n_calls)
    check = ("the model and server (a base model in generate mode? the wrong llm.model?), or raise "
             "llm.max_failure_share to go on anyway")
    advice = f"Check {check}"
    if n_cached:
        advice = (f"{n_cached} of the {n_failed} failed answers came from the LLM cache (llm.cache_dir="
                  f"{cache_dir}): they failed when an earlier run asked, and the server was not asked again. "
                  f"If the model or server has been fixed since, rerun once with llm.cache_mode=retry_failures "
                  f"to ask it again: the new answers replace the failed ones in the cache, and later runs "
                  f"(llm.cache_mode=readwrite) get them; else check {check}")
    return (f"{where}: {n_failed} of {n_calls} LLM calls ({100 * share:.0f}%) to backend {backend!r} "
            f"(model {model!r}) failed or gave unparseable answers, above llm.max_failure_share="
            f"{bound:g}; sample answer: {sample[:200]!r}. {advice}")
