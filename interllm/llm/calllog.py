"""Call log: one JSON line per LLM call, flushed per line so a crash leaves it readable.

Records carry the labels of the call (stage, planner, scene, mission, command), its purpose and
kind, token counts, wall latency [s], whether the cache answered, the backend's KV prefix reuse
and any repaired errors. An optional ``callback(record)`` receives the same dict (the MCAP
recorder uses it). The log is diagnostic output: latency is wall time and never enters a result.
"""

from __future__ import annotations

import json
import os
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any, Optional

from interllm.core import jsonfmt
from interllm.io import check_inside, ensure_dir

LABEL_KEYS = ("stage", "planner", "scene", "mission", "command")
# A room-selection request (generate mode, planning/expansion.py) is named after the plan request it
# serves: "rooms_for_candidates", "rooms_for_regeneration", "rooms_for_replan"
SELECTION_PREFIX = "rooms_for_"
# the phase of a command's planning a request belongs to, by its purpose (score mode's proposal
# requests are the "score_*" purposes other than score_cost)
PHASE_OF_PURPOSE = {"candidates": "proposal", "regeneration": "repair", "replan": "replan",
                    "cost_inference": "cost_inference", "score_cost": "cost_inference"}
PHASES = ("proposal", "repair", "replan", "cost_inference", "other")


def phase_of(purpose: str) -> str:
    """The phase (one of ``PHASES``) a request of ``purpose`` belongs to; a room selection belongs to
    the phase of the plan request it serves."""
    if purpose.startswith(SELECTION_PREFIX):
        return phase_of(purpose[len(SELECTION_PREFIX):])
    if purpose in PHASE_OF_PURPOSE:
        return PHASE_OF_PURPOSE[purpose]
    return "proposal" if purpose.startswith("score_") else "other"


def is_selection(purpose: str) -> bool:
    """Whether a request of ``purpose`` chose rooms (generate mode's expansion) rather than a plan."""
    return purpose.startswith(SELECTION_PREFIX)


class CallLog:
    """Append-only JSONL call log.

    path: JSONL file (parent folders are created); ``None`` keeps no file (callback only).
    callback: called with each record dict after it is written.
    """

    def __init__(self, path: Optional[str | os.PathLike] = None,
                 callback: Optional[Callable[[dict], Any]] = None) -> None:
        self.path = Path(path) if path is not None else None
        self.callback = callback
        self._lock = threading.Lock()
        self._fh = None
        self.n_records = 0
        if self.path is not None:
            ensure_dir(check_inside(self.path).parent)
            # line-buffered append: each record reaches the OS as one write of one line
            self._fh = open(self.path, "a", encoding="utf-8", buffering=1)

    def write(self, record: dict) -> None:
        """Append one record (a JSON-serialisable dict) as one line and flush it."""
        line = jsonfmt.message(record, default=str) + "\n"
        with self._lock:
            if self._fh is not None:
                self._fh.write(line)
                self._fh.flush()
            self.n_records += 1
        if self.callback is not None:
            self.callback(record)

    def close(self) -> None:
        with self._lock:
            if self._fh is not None:
                self._fh.close()
                self._fh = None

    def __enter__(self) -> CallLog:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def read_records(path: str | os.PathLike) -> list[dict]:
    """The records of a JSONL call log, in order; a line cut by a crash is skipped and a missing log
    has none."""
    p = Path(path)
    if not p.is_file():
        return []
    out = []
    for line in p.read_text(encoding="utf-8", errors="replace").splitlines():
        try:
            out.append(json.loads(line))
        except ValueError:
            continue
    return out


def make_record(*, kind: str, purpose: str, context: tuple[tuple[str, str], ...], backend: str,
                model: str, key: str, tokens_in: int, tokens_out: int, latency: float,
                cached: bool, prompt_tokens_reused: int = 0, errors: tuple[str, ...] = (),
                error: Optional[str] = None, sample_index: Optional[int] = None,
                answer: Optional[str] = None) -> dict:
    """Build one call-log record; labels from ``context`` become top-level fields.

    latency: wall time of the backend call [s] (0 on a cache hit); answer: the model's last
    answer when the call failed on it (first 200 characters; for the failure report).
    """
    rec: dict[str, Any] = {k: None for k in LABEL_KEYS}
    extra = {}
    for k, v in context:
        if k in LABEL_KEYS:
            rec[k] = v
        else:
            extra[k] = v
    rec.update({
        "kind": kind, "purpose": purpose, "backend": backend, "model": model, "key": key,
        "tokens_in": int(tokens_in), "tokens_out": int(tokens_out), "latency": float(latency),
        "cache_hit": bool(cached), "prompt_tokens_reused": int(prompt_tokens_reused),
        "errors": list(errors), "error": error,
    })
    if sample_index is not None:
        rec["sample_index"] = int(sample_index)
    if answer is not None:
        rec["answer"] = answer
    if extra:
        rec["labels"] = extra
    return rec
