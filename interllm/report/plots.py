"""Figures of the report (matplotlib, Agg backend, PNG).

PNGs are saved with ``metadata={"Software": None}`` and a fixed DPI so identical inputs give
identical bytes with the same matplotlib/freetype versions.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Optional

import numpy as np

from interllm.errors import UserError
from interllm.io import check_inside, ensure_dir
from interllm.metrics import planner_info
from interllm.planning.similarity import path_overlap

DPI = 100


def _plt():
    import matplotlib  # lazy: heavy, only when a figure is drawn

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt  # lazy: heavy, only when a figure is drawn

    return plt


def _save(fig, path: str | os.PathLike) -> Path:
    path = Path(path)
    ensure_dir(check_inside(path).parent)
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=DPI, metadata={"Software": None})
    os.replace(tmp, path)
    _plt().close(fig)
    return path


def label(planner: str) -> str:
    """A planner's display label (``planner_info``: as the runs recorded it)."""
    return planner_info.current().label(planner)


def color(planner: str) -> str | None:
    """A planner's colour in figures (``planner_info``; None: matplotlib's next). A colour matplotlib
    does not know (a hand-edited planners.json) raises a UserError naming it and the fix."""
    c = planner_info.current().color(planner)
    _plt()
    from matplotlib.colors import is_color_like  # lazy: heavy, only when a figure is drawn

    if c is not None and not is_color_like(c):
        raise UserError(f"planner {planner!r}: colour {c!r} (metrics.json planners.{planner}.color, copied from "
                        f"runs/planners.json) is not a matplotlib colour; rerun the missions stage "
                        f"(dvc repro missions) to rewrite it from the planner's registration")
    return c


def cumulative_figure(rows: Iterable[Mapping], path: str | os.PathLike) -> Path:
    """The overall-metric figure: cumulative m_overall mean vs object index, one line per planner
    with its CI band. rows: cumulative.csv (planner, object_index, m_overall_cum, ci_lo,
    ci_hi)."""
    plt = _plt()
    by: dict[str, list[Mapping]] = {}
    for r in rows:
        by.setdefault(str(r["planner"]), []).append(r)
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for p in sorted(by):
        rs = sorted(by[p], key=lambda r: int(r["object_index"]))
        x = np.array([int(r["object_index"]) for r in rs])
        y = np.array([float(r["m_overall_cum"]) for r in rs])
        lo = np.array([float(r["ci_lo"]) for r in rs])
        hi = np.array([float(r["ci_hi"]) for r in rs])
        c = color(p)
        ax.plot(x, y, marker="o", color=c, label=label(p))
        ax.fill_between(x, lo, hi, color=c, alpha=0.2, linewidth=0)
    ax.set_xlabel("object index along the mission")
    ax.set_ylabel("cumulative $m_{overall}$")
    ax.set_title("Overall metric along the mission (mean, CI)")
    ax.grid(alpha=0.3)
    if by:
        ax.legend()
    fig.tight_layout()
    return _save(fig, path)


def per_object_bars(rows: Iterable[Mapping], metric: str, path: str | os.PathLike,
                    ylabel: Optional[str] = None, max_index: Optional[int] = None) -> Path:
    """Grouped bars of ``metric`` per object index and planner with CI error bars.
    rows: per_object_summary.csv (planner, object_index, metric, mean, ci_lo, ci_hi)."""
    plt = _plt()
    rs = [r for r in rows if r["metric"] == metric
          and (max_index is None or int(r["object_index"]) <= max_index)]
    planners = sorted({str(r["planner"]) for r in rs})
    idx = sorted({int(r["object_index"]) for r in rs})
    fig, ax = plt.subplots(figsize=(min(11.0, max(6.4, 0.35 * len(idx) * max(1, len(planners)))), 3.6))
    w = 0.8 / max(1, len(planners))
    for j, p in enumerate(planners):
        d = {int(r["object_index"]): r for r in rs if r["planner"] == p}
        xs = np.array([i for i in idx if i in d], dtype=float)
        m = np.array([float(d[int(i)]["mean"]) for i in xs])
        lo = np.array([float(d[int(i)]["ci_lo"]) for i in xs])
        hi = np.array([float(d[int(i)]["ci_hi"]) for i in xs])
        err = np.vstack([np.clip(m - lo, 0, None), np.clip(hi - m, 0, None)])
        ax.bar(xs + (j - (len(planners) - 1) / 2) * w, m, w, yerr=err, capsize=2,
               color=color(p), label=label(p))
    ax.set_xticks(idx)
    ax.set_xticklabels([f"obj_{i}" for i in idx], rotation=0)
    ax.set_ylabel(ylabel or metric)
    ax.set_title(f"{ylabel or metric} per object (mean, CI)")
    ax.grid(axis="y", alpha=0.3)
    if planners:
        ax.legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


def synthetic_path_pairs() -> list[tuple[str, np.ndarray, np.ndarray]]:
    """Three pairs of 2-D paths [m]: almost identical, partly overlapping, disjoint."""
    x = np.linspace(0.0, 6.0, 61)
    base = np.stack([x, np.zeros_like(x)], axis=1)
    near = np.stack([x, 0.1 * np.sin(x)], axis=1)
    # shares the first half, then turns away
    part = np.stack([x, np.where(x < 3.0, 0.05, (x - 3.0) * 1.2)], axis=1)
    far = np.stack([x, np.full_like(x, 2.5)], axis=1)
    return [("nearly identical", base, near), ("partly overlapping", base, part), ("disjoint", base, far)]


def path_similarity_figure(path: str | os.PathLike, eps: float = 1.0) -> tuple[Optional[Path], str]:
    """The paper's path-similarity illustration with P° from
    ``interllm.planning.similarity.path_overlap``. Returns (png or None, note)."""
    plt = _plt()
    pairs = synthetic_path_pairs()
    fig, axes = plt.subplots(1, len(pairs), figsize=(10.5, 3.0), sharey=True)
    vals = []
    for ax, (name, a, b) in zip(axes, pairs, strict=True):
        v = float(path_overlap(a, b, eps))
        vals.append(v)
        ax.plot(a[:, 0], a[:, 1], color="tab:blue", label="path i")
        ax.plot(b[:, 0], b[:, 1], color="tab:orange", linestyle="--", label="path j")
        ax.set_title(f"{name}: P° = {v:.1f} ({v / 2:.0f}%)")
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("y [m]")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    note = (f"P° (of 200) with ε = {eps} m: " + ", ".join(f"{n} {v:.1f}" for (n, _, _), v in zip(pairs, vals, strict=True)))
    return _save(fig, path), note


def _curve_and_star(ax, xs, vals, star, x_star, name: str, col) -> None:
    """One sweep curve with its CI band (vals: [n, 3] mean, lo, hi) and, at ``x_star``, the model's
    value with its CI as a star (``star``: (mean, lo, hi) or None)."""
    line = ax.plot(xs, vals[:, 0], marker="o", label=name, color=col)[0]
    ax.fill_between(xs, vals[:, 1], vals[:, 2], alpha=0.15, color=line.get_color())
    if x_star is not None and star is not None:
        m, lo, hi = star
        ax.errorbar([x_star], [m], yerr=[[m - lo], [hi - m]], marker="*", markersize=12, capsize=3,
                    color=line.get_color(), linestyle="none")


def capability_figure(sweep: list, model: Mapping, where: Mapping, planners: list[str], judge: str,
                      path: str | os.PathLike) -> Path:
    """The LLM-capability axis. Left: m_overall per mission [CI] of each planner against the oracle's
    error, with the model's m_overall marked at its equivalent error (by relevance accuracy).
    Right: the judged planner's paired improvement [%, CI] over each baseline, the model's marked
    the same way. sweep: [(error, row)], model: a row (``report._source_row``); where: {"relevance":
    equivalent error or None, ...}."""
    plt = _plt()
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    xs = np.array([e for e, _ in sweep])
    x_model = where.get("relevance")
    nan3 = (np.nan,) * 3
    for p in planners:
        vals = np.array([r["planners"].get(p, nan3) for _, r in sweep], dtype=float)
        _curve_and_star(ax1, xs, vals, model["planners"].get(p), x_model, f"{label(p)} (oracle)", color(p))
    ax1.set_xlabel("oracle error (share of random answers)")
    ax1.set_ylabel("m_overall per mission (lower is better)")
    ax1.set_title(f"stars: {model['source']} at its relevance-equivalent error", fontsize=9)
    ax1.legend(fontsize=8)
    for b in [p for p in planners if p != judge]:
        vals = np.array([r["improvement"].get(b, nan3) for _, r in sweep], dtype=float)
        if np.isnan(vals[:, 0]).all() and model["improvement"].get(b) is None:
            continue  # no improvement is computed over it (an anchor): no empty line in the legend
        _curve_and_star(ax2, xs, vals, model["improvement"].get(b), x_model, f"vs {label(b)}", color(b))
    ax2.axhline(0.0, color="black", linewidth=0.8)
    ax2.set_xlabel("oracle error (share of random answers)")
    ax2.set_ylabel(f"{label(judge)} improvement in m_overall [%]")
    ax2.legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


def learning_curve(mechanism: Mapping[str, Mapping], path: str | os.PathLike) -> Path:
    """Per command index, full − variant of objects delivered and of the cost per delivered object
    [s / object] for every ablation variant (metrics.json's "mechanism"), with house-clustered
    paired CIs as error bars."""
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(10.0, 3.6))
    panels = (("n_fulfilled_diff", "Δ objects delivered (full − variant)"),
              ("cost_per_delivered_diff", "Δ cost per delivered object [s] (full − variant)"))
    for ax, (key, ylab) in zip(axes, panels, strict=True):
        for j, (variant, d) in enumerate(sorted(mechanism.items())):
            rows = d.get("by_command", [])
            xs = np.array([int(r["command_index"]) for r in rows], dtype=float) + 0.08 * (j - 1)
            m = np.array([_num(r.get(key)) for r in rows])
            lo = np.array([_num(r.get(f"{key}_ci_lo")) for r in rows])
            hi = np.array([_num(r.get(f"{key}_ci_hi")) for r in rows])
            err = np.vstack([np.clip(np.nan_to_num(m - lo), 0, None), np.clip(np.nan_to_num(hi - m), 0, None)])
            ax.errorbar(xs, m, yerr=err, marker="o", capsize=2, color=color(variant), label=label(variant))
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.set_xlabel("command index in the mission")
        ax.set_ylabel(ylab, fontsize=8)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle("What each removed part costs along the mission (mean, house-clustered paired CI)", fontsize=9)
    fig.tight_layout()
    return _save(fig, path)


def _num(v) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")
