"""Top-down PNG of a scene (matplotlib, Agg backend): rooms, walls, doors, furniture, objects.

Partly closed doors are drawn red with their leaf; narrow doors orange; furniture marked unreachable
is hatched red. The PNG carries no date or software metadata, so re-rendering the same scene gives
the same bytes on one machine.
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Optional

import numpy as np

from interllm.io import atomic_write_bytes
from interllm.scene.graph import SceneGraph
from interllm.scene.grid import OccupancyGrid

LINE_MARKERS = {"x", "+", "1", "2", "3", "4", "|", "_"}  # matplotlib markers drawn as lines: no edge colour
PLACEMENT_COLORS = {"front": "#2a9d8f", "deep": "#e9c46a", "high": "#9b5de5", "clutter": "#f4a261", "inside": "#6c757d"}


def render_topdown(scene: SceneGraph, path_png: str | Path, *, grid: Optional[OccupancyGrid] = None,
                   paths: Optional[Sequence[Sequence[Sequence[float]]] | Mapping[str, Sequence]] = None,
                   dpi: int = 100, labels: bool = True, narrow_width: float = 0.9,
                   markers: Sequence[tuple[float, float, str, str]] = (), title: Optional[str] = None,
                   colors: Optional[Mapping[str, str]] = None) -> None:
    """Draw ``scene`` from above into ``path_png``.

    grid: optional occupancy grid drawn underneath (occupied cells grey).
    paths: optional robot paths, each a sequence of (x, y) [m]; a mapping {label: path} draws a
        legend (``colors``: {label: matplotlib colour}).
    markers: (x [m], y [m], matplotlib marker, colour) drawn on top (e.g. grasps and releases).
    dpi: pixels per inch; the figure is sized at most 0.6 inch per metre (30 x 30 inches at most).
    labels: write the room and furniture ids.
    narrow_width: doors narrower than this [m] are drawn as narrow.
    title: default: the scene id and its numbers of rooms, furniture and objects.
    """
    import matplotlib  # lazy: heavy, only when a picture is drawn

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure  # lazy: heavy, only when a picture is drawn

    x0, y0, x1, y1 = scene.bounds
    w, h = x1 - x0, y1 - y0
    scale = min(0.6, 30.0 / max(w, h))  # [inch per metre]; figures stay under 30 x 30 inches
    fig = Figure(figsize=(max(4.0, w * scale), max(4.0, h * scale)), dpi=dpi)
    ax = fig.add_subplot(1, 1, 1)
    ax.set_aspect("equal")
    ax.set_xlim(x0 - 0.3, x1 + 0.3)
    ax.set_ylim(y0 - 0.3, y1 + 0.3)
    font = 6 if len(scene.rooms) <= 12 else 3
    if grid is not None:
        _draw_grid(ax, grid)
    _draw_house(ax, scene, labels=labels, font=font, narrow_width=narrow_width)
    _draw_paths(ax, paths, markers, colors)
    ax.set_title(title or f"{scene.id}: {len(scene.rooms)} rooms, {len(scene.furniture)} furniture, "
                 f"{len(scene.objects)} objects", fontsize=8)
    ax.tick_params(labelsize=6)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    atomic_write_bytes(path_png, buf.getvalue())


def _draw_grid(ax, grid: OccupancyGrid) -> None:
    """The occupied cells of ``grid`` in grey, underneath everything."""
    gx0, gy0 = grid.origin
    ext = (gx0, gx0 + grid.shape[1] * grid.resolution, gy0, gy0 + grid.shape[0] * grid.resolution)
    ax.imshow(np.where(grid.occupied, 0.8, 1.0), origin="lower", extent=ext, cmap="gray", vmin=0, vmax=1,
              interpolation="nearest", zorder=0)


def _draw_house(ax, scene: SceneGraph, *, labels: bool, font: int, narrow_width: float) -> None:
    """Rooms (outlines, ids), walls, doors (red: partly closed, with the leaf; orange: narrower than
    ``narrow_width`` [m]), furniture (hatched red: unreachable) and objects (by placement label)."""
    from matplotlib.patches import Rectangle  # lazy: heavy, only when a picture is drawn

    for r in sorted(scene.rooms.values(), key=lambda r: r.id):
        poly = np.array(r.polygon + (r.polygon[0],))
        ax.plot(poly[:, 0], poly[:, 1], color="#cccccc", lw=0.5, zorder=1)
        if labels:
            bx0, by0, bx1, by1 = r.bounds
            ax.text(bx0 + 0.15, by1 - 0.15, r.id, fontsize=font + 1, va="top", color="#555555", zorder=5)
    for wl in sorted(scene.walls.values(), key=lambda w: w.id):
        ax.plot([wl.start[0], wl.end[0]], [wl.start[1], wl.end[1]], color="black", lw=1.5,
                solid_capstyle="butt", zorder=3)
    for d in sorted(scene.doors.values(), key=lambda d: d.id):
        cx, cy = d.center
        half = d.width / 2
        seg = ([cx - half, cx + half], [cy, cy]) if d.axis == "x" else ([cx, cx], [cy - half, cy + half])
        color = "#d62828" if d.open_fraction < 1 else ("#f77f00" if d.width < narrow_width else "#52b788")
        ax.plot(*seg, color=color, lw=2.5, alpha=0.5, zorder=3)
        leaf = d.leaf_segment()
        if leaf is not None:
            ax.plot([leaf[0][0], leaf[1][0]], [leaf[0][1], leaf[1][1]], color="#d62828", lw=3, zorder=4)
    for f in sorted(scene.furniture.values(), key=lambda f: f.id):
        unreachable = {"hatch": "xx", "facecolor": "#f1c0c0"} if f.unreachable else {"facecolor": "#a8dadc"}
        for fx0, fy0, fx1, fy1 in f.boxes:
            ax.add_patch(Rectangle((fx0, fy0), fx1 - fx0, fy1 - fy0, edgecolor="#1d3557", lw=0.6, zorder=2,
                                   **unreachable))
        if labels:
            ax.text(f.center[0], f.center[1], f.id, fontsize=font - 1, ha="center", va="center",
                    color="#1d3557", zorder=6)
    if scene.objects:
        objs = sorted(scene.objects.values(), key=lambda o: o.id)
        xy = np.array([o.position[:2] for o in objs])
        ax.scatter(xy[:, 0], xy[:, 1], s=6, c=[PLACEMENT_COLORS.get(o.placement, "k") for o in objs],
                   zorder=7, linewidths=0)


def _draw_paths(ax, paths, markers: Sequence[tuple[float, float, str, str]],
                colors: Optional[Mapping[str, str]]) -> None:
    """Robot paths (a legend when ``paths`` is a mapping {label: path}) and the markers, on top."""
    named = paths.items() if isinstance(paths, Mapping) else [(None, p) for p in paths or []]
    lines = []
    for label, p in named:
        p = np.asarray(p, dtype=float).reshape(-1, 2)
        if len(p):
            lines += ax.plot(p[:, 0], p[:, 1], lw=1.0, zorder=8, label=label, alpha=0.85,
                             color=(colors or {}).get(label) if label is not None else None)
    for x, y, marker, color in markers:
        edge = {} if marker in LINE_MARKERS else {"edgecolors": "black", "linewidths": 0.4}
        ax.scatter([x], [y], marker=marker, s=28, c=color, zorder=9, **edge)
    if isinstance(paths, Mapping) and lines:
        ax.legend(handles=lines, fontsize=6, loc="upper right", framealpha=0.9).set_zorder(20)
