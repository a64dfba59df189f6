"""Pictures of run logs: one mission's trajectories, every planner on one top-down map."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from interllm.record.reader import RunLog, read_run
from interllm.scene.render import render_topdown

_FALLBACK = ("#8338ec", "#fb8500", "#3a86ff", "#6a994e")


def mission_trajectories_figure(runs: Mapping[str, str | os.PathLike | RunLog], out_png: str | os.PathLike,
                                title: str | None = None, colors: Mapping[str, str] | None = None) -> Path:
    """Draw the base trajectory of each run (the same mission under different planners) on the
    scene, with a triangle where an object was grasped and a circle where it was put down.

    runs: {planner: run .mcap path or RunLog}; all must be of the same scene. colors: {planner:
    matplotlib colour} (others get a fallback colour).
    """
    logs = {k: v if isinstance(v, RunLog) else read_run(v) for k, v in runs.items()}
    if not logs:
        raise ValueError("no runs to draw; pass {planner: run.mcap}")
    scenes = {k: r.scene.id for k, r in logs.items() if r.scene is not None}
    if not scenes:
        raise ValueError(f"none of the run logs {sorted(logs)} has a scene attachment")
    if len(set(scenes.values())) > 1:
        raise ValueError(f"the runs are of different scenes: {scenes}")
    scene = next(r.scene for r in logs.values() if r.scene is not None)
    given = dict(colors or {})
    colors = {k: given.get(k) or _FALLBACK[i % len(_FALLBACK)] for i, k in enumerate(sorted(logs))}
    paths, markers = {}, []
    for k, r in logs.items():
        if len(r.base):
            paths[k] = r.base[:, 1:3]
        where = {o.id: o.position[:2] for o in scene.objects.values()}
        for mv in r.object_moves:
            if mv.frame == "world":
                where[mv.object] = mv.position[:2]
                markers.append((mv.position[0], mv.position[1], "o", colors[k]))
            elif mv.object in where:
                x, y = where[mv.object]
                markers.append((x, y, "^", colors[k]))
    mission = next((str(r.run.get("mission")) for r in logs.values() if r.run.get("mission")), "")
    render_topdown(scene, out_png, paths=paths, markers=markers, colors=colors, labels=False,
                   title=title or f"{scene.id} {mission}: base trajectories (triangle: grasp, circle: release)")
    return Path(out_png)


__all__ = ["mission_trajectories_figure"]
