"""Is the model answering? The share of failed or unparseable calls, judged against
``llm.max_failure_share`` mid-stage (by a client) and at the end of a stage (from its call log)."""

from __future__ import annotations

import json
from pathlib import Path

from interllm.config import LLMConfig
from interllm.llm.errors import LLMQualityError

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
