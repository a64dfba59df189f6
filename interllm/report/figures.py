"""The report's figures and run logs: the cumulative overall metric, per-object bars and the
path-similarity illustration (``plots``), the scenes' top-down pictures, each scene's trajectories
from the run logs, and the MCAP links with the replay command."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

from interllm.record.figures import mission_trajectories_figure
from interllm.report import plots
from interllm.report.document import Doc, ordered, rel


def metric_figures(doc: Doc, cumulative: Sequence[Mapping], summary: Sequence[Mapping], fig_dir: Path,
                   eps: float) -> list[Path]:
    """The cumulative m_overall figure, the per-object bars of ``summary`` (per_object_summary.csv)
    and the path-similarity illustration (ε = ``eps`` [m]), drawn into ``fig_dir``; returns their paths."""
    figures: list[Path] = []
    doc.h(2, "Overall metric along the mission")
    f = plots.cumulative_figure(cumulative, fig_dir / "cumulative_m_overall.png")
    figures.append(f)
    doc.img(f, "Cumulative m_overall per object index (mean over missions, CI band)")
    doc.h(2, "Per-object metrics")
    max_idx = 9 if any(int(r["object_index"]) > 9 for r in summary) else None
    for metric, ylab in (("m_overall", "m_overall"), ("t_exe", "t_exe [s]"), ("cc", "collisions"),
                         ("sr_obj", "sr_obj")):
        f = plots.per_object_bars(summary, metric, fig_dir / f"per_object_{metric}.png", ylab, max_idx)
        figures.append(f)
        doc.img(f, f"{ylab} per object (mean, CI)")
    doc.h(2, "Path similarity P°")
    f, note = plots.path_similarity_figure(fig_dir / "path_similarity.png", eps)
    if f is not None:
        figures.append(f)
        doc.img(f, "Three synthetic path pairs and their P°")
    doc.p(note)
    return figures


def scenes_section(doc: Doc, scenes_dir: str | os.PathLike, scenes: Sequence[str]) -> None:
    """The top-down picture (``<scenes_dir>/<id>/topdown.png``) of each scene of ``scenes`` (ids)."""
    pics = [(sid, Path(scenes_dir) / sid / "topdown.png") for sid in scenes]
    pics = [(sid, p) for sid, p in pics if p.is_file()]
    doc.h(2, "Scenes")
    if pics:
        for sid, p in pics:
            doc.img(p, f"scene {sid} (top-down)")
    else:
        doc.p(f"No topdown.png under {scenes_dir} for scenes {scenes}.")


def trajectories_section(doc: Doc, runs_dir: str | os.PathLike, scenes: Sequence[str], fig_dir: Path
                         ) -> list[Path]:
    """Per scene of ``scenes`` (ids), where each planner drove in its first mission with run logs
    (``<runs_dir>/<planner>/<scene>/*.mcap``); returns the figures drawn into ``fig_dir``."""
    figures: list[Path] = []
    doc.h(2, "Trajectories")
    shown = 0
    for sid in scenes:
        by_mission: dict[str, dict[str, Path]] = {}
        for m in sorted(Path(runs_dir).glob(f"*/{sid}/*.mcap")) if Path(runs_dir).is_dir() else []:
            by_mission.setdefault(m.stem, {})[m.parent.parent.name] = m
        if not by_mission:
            continue
        mission, runs = sorted(by_mission.items())[0]
        try:
            f = mission_trajectories_figure({p: runs[p] for p in ordered(runs)},
                                            fig_dir / f"trajectories_{sid}_{mission}.png",
                                            colors={p: plots.color(p) for p in runs if plots.color(p)})
        except (ValueError, OSError) as e:  # an unreadable log must not sink the report
            doc.p(f"Could not draw the trajectories of {sid} {mission}: {e}")
            continue
        figures.append(f)
        doc.img(f, f"{sid} {mission}: where each planner drove (from the run logs)")
        shown += 1
    if not shown:
        doc.p(f"No .mcap run logs under {runs_dir} to draw trajectories from.")
    return figures


def run_logs_section(doc: Doc, runs_dir: str | os.PathLike, out_dir: Path) -> None:
    """Links to every run log (``*.mcap`` under ``runs_dir``, relative to ``out_dir``) and the replay command."""
    doc.h(2, "Run logs (MCAP)")
    mcaps = sorted(Path(runs_dir).glob("**/*.mcap")) if Path(runs_dir).is_dir() else []
    if mcaps:
        doc.p("Replay any run in rerun with `interllm replay <file>`, or open it in Foxglove Studio:")
        doc.links([(Path(m).relative_to(runs_dir).as_posix(), rel(m, out_dir)) for m in mcaps])
        doc.code(f"interllm replay {_from_here(Path(mcaps[0]))}")
    else:
        doc.p(f"No .mcap run logs found under {runs_dir}.")


def _from_here(path: Path) -> str:
    """``path`` relative to the working directory when it lies below it (the report then reads the
    same in every checkout: a DVC stage runs at the project root), else as given."""
    try:
        return path.resolve().relative_to(Path.cwd().resolve()).as_posix()
    except ValueError:
        return path.as_posix()
