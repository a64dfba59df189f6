"""Hallway floor plans (``scene.layout=hallway``): rooms of different sizes and aspect ratios on
both sides of hallways, as ProcTHOR's houses have them, instead of a grid of cells.

A house of n rooms is a stack of blocks of at most ``ROOMS_PER_BLOCK`` rooms; each block is a
hallway (type ``hallway``, width in [``HALL_WIDTH_MIN``, ``HALL_WIDTH_MAX``] m) spanning the
block's length, a row of rooms below it and a row above it. The rooms of a row share the row's
depth (drawn in [room_size_min, room_size_max]); their widths are drawn in the same range and
scaled so that every row spans the house's length. Rows of neighbouring blocks touch, so doors can
join rooms of different blocks.

``plan_walls`` turns any set of axis-aligned room rectangles that touch edge to edge, plus their
doors, into walls: per wall line, the union of the rooms' edges on it, cut at the door openings.
``shared_edges`` finds which rooms may get a door between them, and where.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from interllm.scene.geometry import r4

HALLWAY = "hallway"  # room type of the hallways (no furniture is placed in them)
ROOMS_PER_BLOCK = 10
HALL_WIDTH_MIN = 1.1  # [m] between the wall centre lines
HALL_WIDTH_MAX = 1.6  # [m]

Rect = tuple[float, float, float, float]  # (x0, y0, x1, y1) [m]


@dataclass(frozen=True)
class SharedEdge:
    """The wall segment two rooms share: ``axis`` "x" (a horizontal wall at y = ``fixed``) or "y"
    (a vertical wall at x = ``fixed``), from ``lo`` to ``hi`` [m] along it."""

    a: int
    b: int
    axis: str
    fixed: float
    lo: float
    hi: float

    @property
    def length(self) -> float:
        return self.hi - self.lo


def _row_widths(rng: np.random.Generator, k: int, length: float, lo: float, hi: float) -> list[float]:
    w = rng.uniform(lo, hi, k)
    w = w * (length / w.sum())
    return [float(v) for v in w]


def hallway_rects(n_rooms: int, rng: np.random.Generator, size_min: float, size_max: float
                  ) -> list[tuple[bool, Rect]]:
    """Rectangles of a hallway house: [(is_hallway, (x0, y0, x1, y1) [m]), ...], the hallways and
    the n_rooms rooms, all with corners rounded to 1e-4 m and the house's corner at (0, 0)."""
    n_blocks = max(1, math.ceil(n_rooms / ROOMS_PER_BLOCK))
    per_block = [n_rooms // n_blocks + (1 if i < n_rooms % n_blocks else 0) for i in range(n_blocks)]
    per_side = max(math.ceil(k / 2) for k in per_block)
    length = r4(per_side * 0.5 * (size_min + size_max))
    out: list[tuple[bool, Rect]] = []
    y = 0.0
    for k in per_block:
        below, above = k // 2, k - k // 2
        rows = []
        for count in (below, above):
            depth = float(rng.uniform(size_min, size_max))
            rows.append((count, depth))
        hall = float(rng.uniform(HALL_WIDTH_MIN, HALL_WIDTH_MAX))
        for side, (count, depth) in enumerate(rows):
            if side == 1:  # the hallway between the two rows
                out.append((True, (0.0, r4(y), length, r4(y + hall))))
                y += hall
            if count == 0:
                continue
            x = 0.0
            widths = _row_widths(rng, count, length, size_min, size_max)
            for i, w in enumerate(widths):
                x1 = length if i == count - 1 else r4(x + w)
                out.append((False, (r4(x), r4(y), x1, r4(y + depth))))
                x = x1
            y += depth
    return out


def shared_edges(rects: list[Rect], min_length: float) -> list[SharedEdge]:
    """Every pair of rectangles that share a wall segment at least ``min_length`` [m] long."""
    out = []
    for i, a in enumerate(rects):
        for j in range(i + 1, len(rects)):
            b = rects[j]
            for fixed_a, fixed_b, axis, lo, hi in (
                    (a[3], b[1], "x", max(a[0], b[0]), min(a[2], b[2])),
                    (a[1], b[3], "x", max(a[0], b[0]), min(a[2], b[2])),
                    (a[2], b[0], "y", max(a[1], b[1]), min(a[3], b[3])),
                    (a[0], b[2], "y", max(a[1], b[1]), min(a[3], b[3]))):
                if abs(fixed_a - fixed_b) < 1e-6 and hi - lo >= min_length - 1e-9:
                    out.append(SharedEdge(i, j, axis, fixed_a, lo, hi))
    return out


def plan_walls(rects: list[Rect], openings: list[tuple[str, float, float, float]]
               ) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """Wall segments [(start, end), ...] of touching room rectangles: per line, the union of the
    rooms' edges on it, minus the openings (axis, fixed, centre, width) [m] on that line."""
    lines: dict[tuple[str, float], list[tuple[float, float]]] = {}
    for x0, y0, x1, y1 in rects:
        for key, span in ((("x", y0), (x0, x1)), (("x", y1), (x0, x1)),
                          (("y", x0), (y0, y1)), (("y", x1), (y0, y1))):
            lines.setdefault((key[0], r4(key[1])), []).append(span)
    walls = []
    for (axis, fixed) in sorted(lines):
        for lo, hi in _union(lines[(axis, fixed)]):
            cuts = sorted((c - w / 2, c + w / 2) for ax, f, c, w in openings
                          if ax == axis and abs(f - fixed) < 1e-6 and lo < c < hi)
            s = lo
            for c0, c1 in cuts:
                if c0 > s + 1e-9:
                    walls.append(_segment(axis, fixed, s, c0))
                s = c1
            if hi > s + 1e-9:
                walls.append(_segment(axis, fixed, s, hi))
    return walls


def _union(spans: list[tuple[float, float]]) -> list[tuple[float, float]]:
    out: list[list[float]] = []
    for lo, hi in sorted(spans):
        if out and lo <= out[-1][1] + 1e-9:
            out[-1][1] = max(out[-1][1], hi)
        else:
            out.append([lo, hi])
    return [(a, b) for a, b in out]


def _segment(axis: str, fixed: float, s: float, e: float) -> tuple[tuple[float, float], tuple[float, float]]:
    if axis == "x":  # a horizontal wall at y = fixed
        return (r4(s), r4(fixed)), (r4(e), r4(fixed))
    return (r4(fixed), r4(s)), (r4(fixed), r4(e))
