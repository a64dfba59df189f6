"""Floor plans of generated houses: rooms, the doors between them and the walls, in two layouts.

``scene.layout=grid`` (``grid_plan``): ``rows x cols`` rectangular cells (column widths and row
heights drawn in [room_size_min, room_size_max] m), one room per cell, the biggest cells to the
room types that need most space.

``scene.layout=hallway`` (``hallway_plan``): rooms of different sizes and aspect ratios on both sides
of hallways, as ProcTHOR's houses have them. A house of n rooms is a stack of blocks of at most
``ROOMS_PER_BLOCK`` rooms; each block is a hallway (type ``hallway``, width in [``HALL_WIDTH_MIN``,
``HALL_WIDTH_MAX``] m) spanning the block's length, a row of rooms below it and a row above it. The
rooms of a row share the row's depth (drawn in [room_size_min, room_size_max]); their widths are
drawn in the same range and scaled so that every row spans the house's length. Rows of neighbouring
blocks touch, so doors can join rooms of different blocks.

Doors, in both layouts: a random spanning tree of the room adjacencies (always normal, fully open
doors; the hallway layout prefers doors onto a hallway) plus extra doors that close loops
(``EXTRA_DOOR_FRACTION`` of the other adjacencies). Only the extra doors may be narrow or partly
closed, so removing all of them leaves the tree: every room stays reachable on the TRUE map and a
blocked door always has a detour. If a house has extra doors and ``partly_closed_door_prob > 0`` at
least one of them is partly closed (so the collision / detour case exists in every such house).

``plan_walls`` turns any set of axis-aligned room rectangles that touch edge to edge, plus their
doors, into walls: per wall line, the union of the rooms' edges on it, cut at the door openings.
``shared_edges`` finds which rooms may get a door between them, and where.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from interllm.scene.build_state import BuildState, Retry
from interllm.scene.geometry import r4
from interllm.scene.graph import Door, Room, Wall

HALLWAY = "hallway"  # room type of the hallways (no furniture is placed in them)
ROOMS_PER_BLOCK = 10
HALL_WIDTH_MIN = 1.1  # [m] between the wall centre lines
HALL_WIDTH_MAX = 1.6  # [m]
EXTRA_DOOR_FRACTION = 0.5  # share of the non-tree adjacencies that get a door (loops)
DOOR_END_MARGIN = 0.3  # [m] door opening keeps this far from the wall ends

# ---- the hallway layout --------------------------------------------------------------------------
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


def hallway_plan(b: BuildState) -> list[tuple[str, str, str]]:
    """Rooms along hallways (``hallway_rects``), their doors and walls. Doors: a
    spanning tree of the rooms' shared edges that prefers doors onto a hallway (always normal,
    fully open, widths in [door_width_min, door_width]), plus extra loop doors between rooms, which
    alone may be narrow or partly closed. Returns the door edges as (door id, room a, room b)."""
    cfg, rng, cat = b.cfg, b.rng, b.cat
    plan = hallway_rects(cfg.n_rooms, rng, cfg.room_size_min, cfg.room_size_max)
    rects = [r for _, r in plan]
    rooms = [i for i, (hall, _) in enumerate(plan) if not hall]
    area = {i: (rects[i][2] - rects[i][0]) * (rects[i][3] - rects[i][1]) for i in rooms}
    types = cat.room_types_for_house(len(rooms))
    order_types = sorted(range(len(rooms)), key=lambda k: (cat.rooms[types[k]].space_rank, k))
    order_rooms = sorted(rooms, key=lambda i: (-area[i], i))
    type_of = {order_rooms[k]: types[t] for k, t in enumerate(order_types)}
    ids = []
    t = cfg.wall_thickness / 2
    for i, (hall, (x0, y0, x1, y1)) in enumerate(plan):
        rtype = HALLWAY if hall else type_of[i]
        rid = b.new_id(rtype)
        b.rooms[rid] = Room(rid, rtype, ((x0, y0), (x1, y0), (x1, y1), (x0, y1)))
        b.interiors[rid] = (r4(x0 + t), r4(y0 + t), r4(x1 - t), r4(y1 - t))
        ids.append(rid)
    edges = shared_edges(rects, cfg.door_width + 2 * DOOR_END_MARGIN)
    hallways = {i for i, (hall, _) in enumerate(plan) if hall}
    keys = rng.random(len(edges))
    order = sorted(range(len(edges)), key=lambda k: (not ({edges[k].a, edges[k].b} & hallways), keys[k]))
    tree, rest, n_parts = _spanning_tree(range(len(rects)), [edges[k] for k in order], lambda e: (e.a, e.b))
    if n_parts > 1:
        raise Retry("rooms are not all joined by shared walls long enough for a door")
    extra, kinds = _door_kinds(b, len(tree), rest)
    openings, out = [], []
    for e, kind in zip(tree + extra, kinds, strict=True):
        width = cfg.narrow_door_width if kind == "narrow" else r4(rng.uniform(cfg.door_width_min, cfg.door_width))
        pos = r4(rng.uniform(e.lo + width / 2 + DOOR_END_MARGIN, e.hi - width / 2 - DOOR_END_MARGIN))
        center = (e.fixed, pos) if e.axis == "y" else (pos, e.fixed)
        open_fraction, hinge = _leaf(b, kind, width)
        did = b.new_id("door")
        b.doors[did] = Door(did, (ids[e.a], ids[e.b]), (r4(center[0]), r4(center[1])), e.axis, r4(width),
                            open_fraction, hinge)
        openings.append((e.axis, e.fixed, pos, width))
        out.append((did, ids[e.a], ids[e.b]))
    for start, end in plan_walls(rects, openings):
        wid = b.new_id("wall")
        b.walls[wid] = Wall(wid, start, end, r4(cfg.wall_thickness), r4(cfg.wall_height))
    return out


# ---- the grid layout -----------------------------------------------------------------------------
@dataclass(frozen=True)
class _GridCells:
    """The grid layout's cells: column edges ``xs`` and row edges ``ys`` [m], the cells (row, col)
    that hold a room (row-major, the first n_rooms), and the room id of each."""

    xs: list[float]
    ys: list[float]
    cells: list[tuple[int, int]]
    cellset: set[tuple[int, int]]
    room_of: dict[tuple[int, int], str]

    @property
    def rows(self) -> int:
        return len(self.ys) - 1

    @property
    def cols(self) -> int:
        return len(self.xs) - 1


def grid_plan(b: BuildState) -> list[tuple[str, str, str]]:
    """Rooms, doors and walls of the grid layout. Returns the door edges as (door id, room a, room b)."""
    g = _grid_rooms(b)
    openings, out = _grid_doors(b, g)
    _grid_walls(b, g, openings)
    return out


def _grid_rooms(b: BuildState) -> _GridCells:
    """Draw the column widths and row heights and put a room in each of the first n_rooms cells."""
    cfg, rng, cat = b.cfg, b.rng, b.cat
    n = cfg.n_rooms
    cols = int(math.ceil(math.sqrt(n)))
    rows = int(math.ceil(n / cols))
    widths = [r4(v) for v in rng.uniform(cfg.room_size_min, cfg.room_size_max, cols)]
    heights = [r4(v) for v in rng.uniform(cfg.room_size_min, cfg.room_size_max, rows)]
    X = [0.0]
    for w in widths:
        X.append(r4(X[-1] + w))
    Y = [0.0]
    for h in heights:
        Y.append(r4(Y[-1] + h))
    cells = [(r, c) for r in range(rows) for c in range(cols)][:n]
    cellset = set(cells)

    # Room types: the biggest cells go to the types that need most space.
    types = cat.room_types_for_house(n)
    order_types = sorted(range(n), key=lambda i: (cat.rooms[types[i]].space_rank, i))
    order_cells = sorted(cells, key=lambda rc: (-widths[rc[1]] * heights[rc[0]], rc))
    type_of = {order_cells[k]: types[i] for k, i in enumerate(order_types)}
    room_of: dict[tuple[int, int], str] = {}
    t = cfg.wall_thickness / 2
    for rc in cells:
        r, c = rc
        rid = b.new_id(type_of[rc])
        x0, x1, y0, y1 = X[c], X[c + 1], Y[r], Y[r + 1]
        b.rooms[rid] = Room(rid, type_of[rc], ((x0, y0), (x1, y0), (x1, y1), (x0, y1)))
        b.interiors[rid] = (r4(x0 + t), r4(y0 + t), r4(x1 - t), r4(y1 - t))
        room_of[rc] = rid
    return _GridCells(X, Y, cells, cellset, room_of)


def _grid_doors(b: BuildState, g: _GridCells
                ) -> tuple[dict[tuple, list[tuple[float, float]]], list[tuple[str, str, str]]]:
    """Doors between neighbouring cells: a random spanning tree (Kruskal on shuffled edges) plus
    extra loop doors. Returns ({wall line key: [(centre, width) [m]]}, [(door id, room a, room b)])."""
    cfg, rng = b.cfg, b.rng
    X, Y, cells, cellset, room_of = g.xs, g.ys, g.cells, g.cellset, g.room_of
    edges = [((r, c), (r, c + 1)) for (r, c) in cells if (r, c + 1) in cellset]
    edges += [((r, c), (r + 1, c)) for (r, c) in cells if (r + 1, c) in cellset]
    perm = rng.permutation(len(edges))
    tree, rest, _ = _spanning_tree(cells, [edges[int(k)] for k in perm], lambda e: e)
    extra, kinds = _door_kinds(b, len(tree), rest)

    openings: dict[tuple, list[tuple[float, float]]] = {}  # wall line key -> [(centre, width)]
    out = []
    for (a, bb), kind in zip(tree + extra, kinds, strict=True):
        (r, c), (r2, _) = a, bb
        width = cfg.narrow_door_width if kind == "narrow" else cfg.door_width
        if r == r2:  # side by side: wall at x = X[c+1], running along y
            lo, hi, axis, key = Y[r], Y[r + 1], "y", ("v", c + 1, r)
        else:  # stacked: wall at y = Y[r+1], running along x
            lo, hi, axis, key = X[c], X[c + 1], "x", ("h", r + 1, c)
        span = (lo + width / 2 + DOOR_END_MARGIN, hi - width / 2 - DOOR_END_MARGIN)
        if span[0] > span[1]:
            raise Retry(f"wall too short for a {width} m door")
        pos = r4(rng.uniform(*span))
        center = (X[c + 1], pos) if axis == "y" else (pos, Y[r + 1])
        open_fraction, hinge = _leaf(b, kind, width)
        did = b.new_id("door")
        b.doors[did] = Door(did, (room_of[a], room_of[bb]), (r4(center[0]), r4(center[1])), axis,
                            r4(width), open_fraction, hinge)
        openings.setdefault(key, []).append((pos, width))
        out.append((did, room_of[a], room_of[bb]))
    return openings, out


def _grid_walls(b: BuildState, g: _GridCells, openings: dict[tuple, list[tuple[float, float]]]) -> None:
    """Walls: every cell side once, split around the door ``openings`` (centre, width) [m]."""
    X, Y, cellset = g.xs, g.ys, g.cellset

    def add_wall_line(key, lo, hi, fixed, along):
        cuts = sorted(openings.get(key, []))
        s = lo
        for pos, w in cuts:
            if pos - w / 2 > s + 1e-9:
                _add_wall(b, along, fixed, s, pos - w / 2)
            s = pos + w / 2
        if hi > s + 1e-9:
            _add_wall(b, along, fixed, s, hi)

    for r in range(g.rows):
        for c in range(g.cols + 1):
            if (r, c - 1) in cellset or (r, c) in cellset:
                add_wall_line(("v", c, r), Y[r], Y[r + 1], X[c], "y")
    for r in range(g.rows + 1):
        for c in range(g.cols):
            if (r - 1, c) in cellset or (r, c) in cellset:
                add_wall_line(("h", r, c), X[c], X[c + 1], Y[r], "x")


def _add_wall(b: BuildState, along: str, fixed: float, s: float, e: float) -> None:
    wid = b.new_id("wall")
    if along == "y":
        start, end = (r4(fixed), r4(s)), (r4(fixed), r4(e))
    else:
        start, end = (r4(s), r4(fixed)), (r4(e), r4(fixed))
    b.walls[wid] = Wall(wid, start, end, r4(b.cfg.wall_thickness), r4(b.cfg.wall_height))


# ---- doors of both layouts -----------------------------------------------------------------------
def _spanning_tree(nodes, edges: list, ends) -> tuple[list, list, int]:
    """Kruskal over ``edges`` in the given order: (tree edges, the other edges, connected parts);
    ``ends(edge)`` gives the two nodes an edge joins."""
    parent = {n: n for n in nodes}

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    tree, rest = [], []
    for e in edges:
        u, v = ends(e)
        ru, rv = find(u), find(v)
        if ru != rv:
            parent[ru] = rv
            tree.append(e)
        else:
            rest.append(e)
    return tree, rest, len({find(n) for n in parent})


def _door_kinds(b: BuildState, n_tree: int, rest: list) -> tuple[list, list[str]]:
    """(the extra loop doors, the kind of every door: tree doors first, always normal). Extra doors
    may be narrow or partly closed; with partly_closed_door_prob > 0 at least one is partly closed."""
    cfg = b.cfg
    n_extra = max(1, int(round(EXTRA_DOOR_FRACTION * len(rest)))) if rest else 0
    extra = rest[:n_extra]
    kinds = ["normal"] * n_tree
    for _ in extra:
        u = b.rng.random()
        kinds.append("partly_closed" if u < cfg.partly_closed_door_prob
                     else "narrow" if u < cfg.partly_closed_door_prob + cfg.narrow_door_prob else "normal")
    if extra and cfg.partly_closed_door_prob > 0 and "partly_closed" not in kinds:
        kinds[n_tree] = "partly_closed"
    return extra, kinds


def _leaf(b: BuildState, kind: str, width: float) -> tuple[float, str]:
    """(open fraction, hinge end) of a door of ``kind``: a partly closed leaf leaves a gap narrower than
    the robot (0.15-0.35 of the width)."""
    open_fraction = 1.0
    if kind == "partly_closed":
        hi_open = min(0.35, (2 * b.robot_radius - 0.1) / width)
        open_fraction = r4(b.rng.uniform(0.15, max(0.15, hi_open)))
    return open_fraction, "low" if b.rng.random() < 0.5 else "high"
