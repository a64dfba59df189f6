"""What the planners asked the LLM, from the call logs: requests and prompt / answer tokens per
command, split by phase (proposal, repair, replan, cost inference; ``llm.calllog.phase_of``), and in
generate mode the room selections and how often a command's selection had to be widened
(``planning.expansion``).

Every logged call counts, answered from the cache or not (a cache hit logs the tokens the answer
took when it was made), so the figures are the same on a cold and a warm run. Written by the
aggregate stage as ``metrics/llm_usage.json`` beside metrics.json.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from typing import Any, Optional

from interllm.llm.calllog import PHASES, is_selection, phase_of, read_records

SHARED = "(candidates stage)"  # the planner label of the shared initial candidates' calls


def _empty() -> dict[str, int]:
    return {"requests": 0, "tokens_in": 0, "tokens_out": 0, "selection_requests": 0}


def _per(total: Mapping[str, int], n: int) -> dict[str, float]:
    return {k: v / n for k, v in total.items()} if n else {k: 0.0 for k in total}


def planner_usage(calls: Iterable[Mapping[str, Any]], commands: Optional[Mapping[str, int]] = None) -> dict[str, dict]:
    """Per planner: commands, totals and per-command means by phase, and the room selections.

    commands: the commands each planner ran (the per-command means divide by it; a command may make
    no request, e.g. a first command run on the shared candidates); default: the commands that
    made a request."""
    acc: dict[str, dict] = {}
    for c in calls:
        planner = str(c.get("planner") or SHARED)
        d = acc.setdefault(planner, {"commands": set(), "phases": {p: _empty() for p in PHASES},
                                     "selected": set(), "widened": set()})
        command = (c.get("scene"), c.get("mission"), c.get("command"))
        d["commands"].add(command)
        ph = d["phases"][phase_of(str(c.get("purpose", "")))]
        ph["requests"] += 1
        ph["tokens_in"] += int(c.get("tokens_in") or 0)
        ph["tokens_out"] += int(c.get("tokens_out") or 0)
        if is_selection(str(c.get("purpose", ""))):
            ph["selection_requests"] += 1
            d["selected"].add(command)
            if int(c.get("sample_index") or 0) >= 1:  # a widening (planning.expansion.ask_rooms' attempt)
                d["widened"].add(command)
    commands = commands or {}
    return {p: _summary(d, int(commands.get(p, len(d["commands"])))) for p, d in sorted(acc.items())}


def _summary(d: dict, n: int) -> dict:
    total = {k: sum(ph[k] for ph in d["phases"].values()) for k in ("requests", "tokens_in", "tokens_out",
                                                                     "selection_requests")}
    phases = {p: {**ph, "per_command": _per(ph, n)} for p, ph in d["phases"].items() if ph["requests"]}
    selected, widened = len(d["selected"]), len(d["widened"])
    return {"commands": n, **total, "per_command": _per(total, n), "phases": phases,
            "room_selection": {"commands": selected, "widened": widened,
                               "widened_share": widened / selected if selected else None}}


def llm_usage(call_logs: Mapping[str, str | os.PathLike], commands: Optional[Mapping[str, int]] = None) -> dict:
    """{stage: planner_usage} over the call logs ``{stage: llm_calls.jsonl}``; ``commands``: the
    commands each planner ran (the missions stage's per-command means divide by it)."""
    return {stage: planner_usage(read_records(path), commands if stage == "missions" else None)
            for stage, path in sorted(call_logs.items())}
