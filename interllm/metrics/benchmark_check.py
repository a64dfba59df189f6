"""metrics.json's ``benchmark``: which versioned benchmark the runs' houses and missions come from
(``interllm.scene.benchmark``) and what the simulator of these runs measured differently from the
one it was frozen with, summed over the scenes' ``feasibility.json`` (their ``benchmark`` sections,
written by the scenes stage)."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from interllm.io import InputFileError, read_json
from interllm.metrics.compute import MetricsInputError

DRAWN = {"name": ""}  # no benchmark: the missions were drawn from the runs' own measurement


def benchmark_summary(scenes_dir: Path, scene_ids: Iterable[str]) -> dict:
    """{name, frozen_commit, frozen_robot, slots (the frozen missions' slots), slots_changed (Σ |then −
    now| of the slots their matching fills), commands_changed, pickups_changed (objects whose pickup
    became possible or impossible), starts_moved (missions)} over ``scene_ids``; ``DRAWN`` when the
    scenes came from no benchmark; ``unknown`` lists the scenes whose feasibility.json is missing or
    unreadable (left out of the totals). MetricsInputError when some do and some do not, or two differ."""
    sections, unknown = {}, []
    for sid in sorted(scene_ids):
        p = Path(scenes_dir) / sid / "feasibility.json"
        try:
            sections[sid] = read_json(p).get("benchmark") if p.is_file() else unknown.append(sid)
        except InputFileError:  # the report names the unreadable file; the runs' metrics stand
            unknown.append(sid)
    sections = {sid: s for sid, s in sections.items() if sid not in unknown}
    names = {(s or DRAWN)["name"] for s in sections.values()}
    if len(names) > 1:
        raise MetricsInputError(f"the scenes under {scenes_dir} come from different benchmarks ({sorted(names)}; '' "
                                f"= drawn): re-run the scenes stage with one benchmark for all")
    extra = {"unknown": unknown} if unknown else {}  # scenes whose feasibility.json is missing or unreadable
    if not sections or names == {""}:
        return {**DRAWN, **extra}
    first = next(iter(sections.values()))
    rows = list(sections.values())
    return {"name": first["name"], "frozen_commit": first["frozen_commit"], "frozen_robot": first["frozen_robot"],
            "slots": sum(int(s["slots"]) for s in rows),
            "slots_changed": sum(int(s["slots_changed"]) for s in rows),
            "commands_changed": sum(len(s["changes"]) for s in rows),
            "pickups_changed": sum(len(s["pickups_changed"]) for s in rows),
            "starts_moved": sum(len(s["starts_moved"]) for s in rows), **extra}
