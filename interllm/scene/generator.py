"""Procedural house generator: rooms on a grid, walls with doors, furniture, objects.

``generate_scene(cfg, index)`` is deterministic in ``(cfg, index)``: scene ``index`` uses seed
``cfg.seed + index`` (numpy ``Generator`` seeded by ``core.seeding.scene_seed(seed, attempt)``), and every float is rounded
to 1e-4 m so ``scene.to_json()`` is byte-identical across runs and machines.

Floor plan: ``rows x cols`` rectangular cells (column widths and row heights drawn in
[room_size_min, room_size_max] m), one room per cell. Doors: a random spanning tree of the cell
adjacency graph (always normal, fully open doors) plus extra doors that close loops. Only the
extra doors may be narrow or partly closed, so removing all of them leaves the tree: every room
stays reachable on the TRUE map and a blocked door always has a detour. If a scene has extra doors
and ``partly_closed_door_prob > 0`` at least one of them is partly closed (so the collision /
detour case exists in every such scene).

Furniture keeps a free ring of ``placement.free_ring`` m to every other furniture and, on its free
sides, to the walls; no furniture enters the ``door_clear_depth`` m zone in front of a door.
Objects rest on surfaces with a placement label: front / deep / high / clutter (thresholds in
``catalog/furniture.json``). How they are chosen is ``scene.object_design``:

- ``legacy`` (the earlier generator, byte for byte): each catalog command whose target furniture
  exists receives at least ``min_objects_per_command`` valid objects (not on its own targets),
  spread over rooms where possible, each placed hard (deep, high, clutter) with
  ``hard_placement_prob``; then random objects up to ``n_objects``.
- ``graded`` (default): difficulty by design. *Easy* instances first: for every command whose
  targets exist, ``objects_per_command`` (k, ``mission.objects_per_command``) instances of its
  categories placed front, at most EASY_DEPTH in from the edge, on furniture below the high shelf
  that is not one of its targets, on a different furniture (and room) each where one takes it, at a
  spot with at least EASY_MIN_CELLS grid cells within EASY_REACH where the robot can stand (free on
  the presumed and the true grid, the true footprint clear) joined to the furniture's anchor. The
  paper's three commands get k instances each of their own (so the paper's mission can be filled
  with distinct objects). Then EASY_SPARE more per command, while ``hard_placement_prob`` of the
  budget stays free; with that share, *medium* (clutter next to an object) and *hard* (deep, high)
  instances of the commands' categories, command by command, on furniture not holding that category
  yet; then random objects up to ``n_objects``. On every command target a square of DELIVERY_HALF
  around the point nearest its anchor stays free of objects: where delivered objects go. The
  simulator's measurement (``interllm.stages.feasibility``) then says which instances can in fact
  be delivered; the scene layer only arranges for enough of them.

The paper's three commands must always be satisfiable (else the attempt is redrawn).
``scene.meta["commands"]`` lists the commands each scene supports (graded: with k easy instances).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from interllm.config import SceneConfig
from interllm.core.seeding import scene_seed
from interllm.errors import UserError
from interllm.scene.catalog import Catalog, CommandSpec, load_catalog
from interllm.scene.floor_plans import HALLWAY, hallway_rects, plan_walls, shared_edges
from interllm.scene.geometry import footprint_distance, free_edges, r4, rect_gap, rects_overlap
from interllm.scene.graph import Door, Furniture, Room, SceneGraph, SceneObject, Wall
from interllm.scene.grid import OccupancyGrid, clear_of_obstacles, rasterize
from interllm.scene.reachability import unreachable

MAX_ATTEMPTS = 25
MAX_FAILS_IN_A_ROW = 250  # object placements failing in a row before the surfaces count as full
FULL_SUPPORT_ATTEMPTS = 8  # attempts spent looking for a scene supporting every command
EXTRA_DOOR_FRACTION = 0.5  # share of the non-tree adjacencies that get a door (loops)
DOOR_END_MARGIN = 0.3  # [m] door opening keeps this far from the wall ends
DOOR_ZONE_SIDE = 0.3  # [m] furniture-free zone extends this far beside the opening
WALL_GAP = 0.01  # [m] between a wall's inner face and furniture backs
# graded object design (scene.object_design=graded): what makes an instance "easy"
EASY_DEPTH = 0.05  # [m] an easy object's box stands at most this far in from the surface margin
EASY_REACH = 0.5  # [m] easy: floor the robot can stand on within this horizontal distance of the object
EASY_MIN_CELLS = 5  # easy: at least this many such grid cells (sim.n_l base poses by default)
EASY_SPARE = 1  # easy instances each command gets beyond objects_per_command (margin for failures)
POSE_WINDOW = 1.0  # [m] the stand cells join the anchor within this far beyond EASY_REACH (sim.base_poses)
DELIVERY_HALF = 0.35  # [m] half side of the square kept free on a command's target, nearest its anchor
ANCHOR_RINGS = (0.25, 0.5, 1.0)  # [m] beyond robot_radius: where a furniture's anchor may be (sim.belief)


class SceneGenerationError(UserError, RuntimeError):
    """No valid scene after MAX_ATTEMPTS attempts; the message says which requirement failed."""


class _Retry(Exception):
    """This attempt failed; another seed attempt may succeed."""


class _TooFull(SceneGenerationError):
    """Not even half the objects fit: no other attempt will place them all; stop at once."""


@dataclass
class _Build:
    cat: Catalog
    cfg: SceneConfig
    rng: np.random.Generator
    robot_radius: float
    rooms: dict[str, Room] = field(default_factory=dict)
    interiors: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)
    walls: dict[str, Wall] = field(default_factory=dict)
    doors: dict[str, Door] = field(default_factory=dict)
    furniture: dict[str, Furniture] = field(default_factory=dict)
    objects: dict[str, SceneObject] = field(default_factory=dict)
    counters: dict[str, int] = field(default_factory=dict)
    k: int = 3  # graded design: easy instances each command gets (mission.objects_per_command)
    footprint_extra: float = 0.05  # [m] graded design: the robot's true footprint beyond robot_radius
    easy: set[str] = field(default_factory=set)  # graded design: the easy instances placed
    # graded design: furniture id -> the part of its surface kept free of objects (x0, y0, x1, y1) [m]
    keep_clear: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)

    def new_id(self, kind: str) -> str:
        self.counters[kind] = self.counters.get(kind, 0) + 1
        return f"{kind}_{self.counters[kind]}"


def _floor_plan(b: _Build) -> list[tuple[str, str, str]]:
    """Rooms, doors and walls. Returns the door edges as (door id, room a, room b)."""
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

    # Doors: random spanning tree (Kruskal on shuffled edges) + extra loop doors.
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
            raise _Retry(f"wall too short for a {width} m door")
        pos = r4(rng.uniform(*span))
        center = (X[c + 1], pos) if axis == "y" else (pos, Y[r + 1])
        open_fraction, hinge = _leaf(b, kind, width)
        did = b.new_id("door")
        b.doors[did] = Door(did, (room_of[a], room_of[bb]), (r4(center[0]), r4(center[1])), axis,
                            r4(width), open_fraction, hinge)
        openings.setdefault(key, []).append((pos, width))
        out.append((did, room_of[a], room_of[bb]))

    # Walls: every cell side once, split around door openings.
    def add_wall_line(key, lo, hi, fixed, along):
        cuts = sorted(openings.get(key, []))
        s = lo
        for pos, w in cuts:
            if pos - w / 2 > s + 1e-9:
                _add_wall(b, along, fixed, s, pos - w / 2)
            s = pos + w / 2
        if hi > s + 1e-9:
            _add_wall(b, along, fixed, s, hi)

    for r in range(rows):
        for c in range(cols + 1):
            if (r, c - 1) in cellset or (r, c) in cellset:
                add_wall_line(("v", c, r), Y[r], Y[r + 1], X[c], "y")
    for r in range(rows + 1):
        for c in range(cols):
            if (r - 1, c) in cellset or (r, c) in cellset:
                add_wall_line(("h", r, c), X[c], X[c + 1], Y[r], "x")
    return out


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


def _door_kinds(b: _Build, n_tree: int, rest: list) -> tuple[list, list[str]]:
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


def _leaf(b: _Build, kind: str, width: float) -> tuple[float, str]:
    """(open fraction, hinge end) of a door of ``kind``: a partly closed leaf leaves a gap narrower than
    the robot (0.15-0.35 of the width)."""
    open_fraction = 1.0
    if kind == "partly_closed":
        hi_open = min(0.35, (2 * b.robot_radius - 0.1) / width)
        open_fraction = r4(b.rng.uniform(0.15, max(0.15, hi_open)))
    return open_fraction, "low" if b.rng.random() < 0.5 else "high"


def _hallway_plan(b: _Build) -> list[tuple[str, str, str]]:
    """Rooms along hallways (``interllm.scene.floor_plans``), their doors and walls. Doors: a
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
        raise _Retry("rooms are not all joined by shared walls long enough for a door")
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


def _add_wall(b: _Build, along: str, fixed: float, s: float, e: float) -> None:
    wid = b.new_id("wall")
    if along == "y":
        start, end = (r4(fixed), r4(s)), (r4(fixed), r4(e))
    else:
        start, end = (r4(s), r4(fixed)), (r4(e), r4(fixed))
    b.walls[wid] = Wall(wid, start, end, r4(b.cfg.wall_thickness), r4(b.cfg.wall_height))


def _door_zones(b: _Build, rid: str) -> list[tuple[float, float, float, float]]:
    depth = b.cat.placement.door_clear_depth
    zones = []
    for d in b.doors.values():
        if rid not in d.rooms:
            continue
        half = d.width / 2 + DOOR_ZONE_SIDE
        cx, cy = d.center
        if d.axis == "x":
            zones.append((cx - half, cy - depth, cx + half, cy + depth))
        else:
            zones.append((cx - depth, cy - half, cx + depth, cy + half))
    return zones


# ---- furniture -----------------------------------------------------------------------------------
def _try_place_furniture(b: _Build, rid: str, category: str, tries: int = 30) -> str | None:
    fc = b.cat.furniture[category]
    ring = b.cat.placement.free_ring
    ix0, iy0, ix1, iy1 = b.interiors[rid]
    zones = _door_zones(b, rid)
    others = [f.footprint for f in b.furniture.values() if f.room == rid]
    a, d, h = fc.size
    for _ in range(tries):
        if fc.mount == "wall":
            side = ("S", "N", "W", "E")[int(b.rng.integers(4))]
            if side in ("S", "N"):
                sx, sy = a, d
                lo, hi = ix0 + sx / 2 + WALL_GAP, ix1 - sx / 2 - WALL_GAP
                if lo > hi:
                    continue
                cx = b.rng.uniform(lo, hi)
                cy = iy0 + WALL_GAP + sy / 2 if side == "S" else iy1 - WALL_GAP - sy / 2
                if iy1 - iy0 - sy - WALL_GAP < ring:
                    continue
            else:
                sx, sy = d, a
                lo, hi = iy0 + sy / 2 + WALL_GAP, iy1 - sy / 2 - WALL_GAP
                if lo > hi:
                    continue
                cy = b.rng.uniform(lo, hi)
                cx = ix0 + WALL_GAP + sx / 2 if side == "W" else ix1 - WALL_GAP - sx / 2
                if ix1 - ix0 - sx - WALL_GAP < ring:
                    continue
        else:
            sx, sy = (a, d) if b.rng.random() < 0.5 else (d, a)
            lox, hix = ix0 + ring + sx / 2, ix1 - ring - sx / 2
            loy, hiy = iy0 + ring + sy / 2, iy1 - ring - sy / 2
            if lox > hix or loy > hiy:
                sx, sy = sy, sx
                lox, hix = ix0 + ring + sx / 2, ix1 - ring - sx / 2
                loy, hiy = iy0 + ring + sy / 2, iy1 - ring - sy / 2
                if lox > hix or loy > hiy:
                    return None
            cx, cy = b.rng.uniform(lox, hix), b.rng.uniform(loy, hiy)
        cx, cy = r4(cx), r4(cy)
        fp = (cx - sx / 2, cy - sy / 2, cx + sx / 2, cy + sy / 2)
        if any(rects_overlap(fp, z) for z in zones):
            continue
        if any(rect_gap(fp, o) < ring for o in others):
            continue
        fid = b.new_id(category)
        b.furniture[fid] = Furniture(fid, category, rid, (cx, cy), (r4(sx), r4(sy), r4(h)), fc.description)
        return fid
    return None


def _place_all_furniture(b: _Build) -> None:
    cat, n_target = b.cat, b.cfg.n_furniture
    rooms = [r for r in b.rooms.values() if r.type != HALLWAY]  # hallways stay clear
    max_core = max(len(cat.rooms[r.type].core) for r in rooms)
    for k in range(max_core):
        for r in rooms:
            core = cat.rooms[r.type].core
            if k < len(core) and len(b.furniture) < n_target:
                _try_place_furniture(b, r.id, core[k])
    # Every command's target furniture, where the budget allows (e.g. the dresser of the gym command).
    for cmd in cat.commands:
        if len(b.furniture) >= n_target or _targets(b, cmd):
            continue
        for r in rooms:
            if cmd.target_room_type in (None, r.type) and len(b.furniture) < n_target:
                if any(_try_place_furniture(b, r.id, c) for c in cmd.target_furniture):
                    break
    failures = 0
    areas = np.array([(r.bounds[2] - r.bounds[0]) * (r.bounds[3] - r.bounds[1]) for r in rooms])
    p_room = areas / areas.sum()
    while len(b.furniture) < n_target:
        r = rooms[int(b.rng.choice(len(rooms), p=p_room))]
        opt = cat.rooms[r.type].optional or tuple((c, 1.0) for c in cat.rooms[r.type].core)
        w = np.array([x[1] for x in opt])
        category = opt[int(b.rng.choice(len(opt), p=w / w.sum()))][0]
        if _try_place_furniture(b, r.id, category, tries=10) is None:
            failures += 1
            if failures > 60 + 10 * n_target:
                raise _Retry(f"could place only {len(b.furniture)} of {n_target} furniture; "
                             "rooms are too small (raise scene.room_size_max or lower scene.n_furniture)")


# ---- objects -------------------------------------------------------------------------------------
def _place_object(b: _Build, category: str, fid: str, mode: str, tries: int = 25,
                  accept: Callable[[float, float], bool] | None = None, easy: bool = False) -> str | None:
    """Put one object of ``category`` on furniture ``fid`` with a placement mode; None if no room.

    easy: a front object whose box stands at most EASY_DEPTH [m] in from the surface margin.
    accept(x, y): a further test of the spot's centre [m] (graded design: robot floor within reach).
    """
    pl = b.cat.placement
    oc = b.cat.objects[category]
    f = b.furniture[fid]
    fx0, fy0, fx1, fy1 = f.footprint
    m = pl.surface_margin
    edges = free_edges(b.rooms[f.room].bounds, f) or ("S", "N", "W", "E")
    existing = [o for o in b.objects.values() if o.furniture == fid]
    if f.surface_height >= pl.high_min:
        mode = "high"
    for _ in range(tries):
        sx, sy = oc.size[0], oc.size[1]
        if b.rng.random() < 0.5:
            sx, sy = sy, sx
        if mode in ("front", "high"):
            e = edges[int(b.rng.integers(len(edges)))]
            perp = sy if e in ("S", "N") else sx
            if perp / 2 + m > pl.front_edge_max:
                sx, sy = sy, sx
                perp = sy if e in ("S", "N") else sx
            dmin, dmax = perp / 2 + m, max(perp / 2 + m, pl.front_edge_max)
            if easy:
                dmax = min(dmax, dmin + EASY_DEPTH)
            dist = b.rng.uniform(dmin, dmax)
            if e in ("S", "N"):
                lo, hi = fx0 + sx / 2 + m, fx1 - sx / 2 - m
                if lo > hi:
                    continue
                x = b.rng.uniform(lo, hi)
                y = fy0 + dist if e == "S" else fy1 - dist
            else:
                lo, hi = fy0 + sy / 2 + m, fy1 - sy / 2 - m
                if lo > hi:
                    continue
                y = b.rng.uniform(lo, hi)
                x = fx0 + dist if e == "W" else fx1 - dist
        elif mode == "deep":
            def need(side, half):
                return max(pl.deep_edge_min, half + m) if side in edges else half + m
            lox, hix = fx0 + need("W", sx / 2), fx1 - need("E", sx / 2)
            loy, hiy = fy0 + need("S", sy / 2), fy1 - need("N", sy / 2)
            if lox > hix or loy > hiy:
                continue
            x, y = b.rng.uniform(lox, hix), b.rng.uniform(loy, hiy)
        else:  # clutter: right next to an object already there
            if not existing:
                return None
            o = existing[int(b.rng.integers(len(existing)))]
            gap = b.rng.uniform(pl.object_gap, pl.clutter_gap_max)
            dirn = int(b.rng.integers(4))
            ox, oy = o.position[0], o.position[1]
            if dirn < 2:
                x = ox + (1 if dirn == 0 else -1) * (o.size[0] / 2 + sx / 2 + gap)
                y = oy + b.rng.uniform(-0.03, 0.03)
            else:
                y = oy + (1 if dirn == 2 else -1) * (o.size[1] / 2 + sy / 2 + gap)
                x = ox + b.rng.uniform(-0.03, 0.03)
        x, y = r4(x), r4(y)
        box = (x - sx / 2, y - sy / 2, x + sx / 2, y + sy / 2)
        if box[0] < fx0 + m - 1e-9 or box[2] > fx1 - m + 1e-9 or box[1] < fy0 + m - 1e-9 \
                or box[3] > fy1 - m + 1e-9:
            continue
        if any(rect_gap(box, _obox(o)) < pl.object_gap - 1e-9 for o in existing):
            continue
        if fid in b.keep_clear and rects_overlap(box, b.keep_clear[fid]):
            continue
        if accept is not None and not accept(x, y):
            continue
        oid = b.new_id(category)
        b.objects[oid] = SceneObject(oid, category, fid, (x, y, r4(f.surface_height + oc.size[2] / 2)),
                                     (r4(sx), r4(sy), r4(oc.size[2])), oc.usage, mode)
        return oid
    return None


def _obox(o: SceneObject) -> tuple[float, float, float, float]:
    return (o.position[0] - o.size[0] / 2, o.position[1] - o.size[1] / 2,
            o.position[0] + o.size[0] / 2, o.position[1] + o.size[1] / 2)


def _modes_for(b: _Build, fid: str, category: str) -> list[str]:
    """Hard placement modes a furniture can offer an object of ``category``."""
    pl = b.cat.placement
    f = b.furniture[fid]
    if f.surface_height >= pl.high_min:
        return ["high"]
    modes = []
    edges = free_edges(b.rooms[f.room].bounds, f)
    half = max(b.cat.objects[category].size[:2]) / 2 + pl.surface_margin
    fx0, fy0, fx1, fy1 = f.footprint
    dx = (fx1 - fx0) - sum(max(pl.deep_edge_min, half) if s in edges else half for s in ("W", "E"))
    dy = (fy1 - fy0) - sum(max(pl.deep_edge_min, half) if s in edges else half for s in ("S", "N"))
    if dx >= 0 and dy >= 0:
        modes.append("deep")
    if any(o.furniture == fid for o in b.objects.values()):
        modes.append("clutter")
    return modes


def _add_object(b: _Build, category: str, hosts: list[str]) -> str | None:
    """Place an object of ``category`` on one of ``hosts`` (hard with hard_placement_prob)."""
    hosts = list(hosts)
    pl = b.cat.placement
    while hosts:
        if b.rng.random() < b.cfg.hard_placement_prob:
            offers = {h: _modes_for(b, h, category) for h in hosts}
            modes = sorted({m for ms in offers.values() for m in ms})
            if modes:
                mode = modes[int(b.rng.integers(len(modes)))]
                cand = [h for h in hosts if mode in offers[h]]
            else:
                mode, cand = "front", hosts
        else:
            low = [h for h in hosts if b.furniture[h].surface_height < pl.high_min]
            mode, cand = "front", (low or hosts)
        fid = cand[int(b.rng.integers(len(cand)))]
        oid = _place_object(b, category, fid, mode)
        if oid is None and mode != "front":
            oid = _place_object(b, category, fid, "front")
        if oid is not None:
            return oid
        hosts.remove(fid)
    return None


def _targets(b: _Build, cmd: CommandSpec) -> set[str]:
    return {f.id for f in b.furniture.values() if f.category in cmd.target_furniture
            and (cmd.target_room_type is None or b.rooms[f.room].type == cmd.target_room_type)}


def _place_all_objects(b: _Build) -> dict[str, bool]:
    cat, budget = b.cat, b.cfg.n_objects
    K = cat.min_objects_per_command
    cmds = list(cat.paper_commands()) + [c for c in cat.commands if not c.paper]
    targets = {c.id: _targets(b, c) for c in cmds}
    fids = list(b.furniture)

    def valid(cmd):
        return [o for o in b.objects.values() if o.category in cmd.categories
                and o.furniture not in targets[cmd.id]]

    supported: dict[str, bool] = {}
    for cmd in cmds:
        if not targets[cmd.id]:
            supported[cmd.id] = False
            if cmd.paper:
                raise _Retry(f"no target furniture for paper command {cmd.id!r}")
            continue
        fails = 0
        while len(valid(cmd)) < K and len(b.objects) < budget and fails < 20:
            hosts_of = {c: [f for f in fids if c in cat.furniture[b.furniture[f].category].holds
                            and f not in targets[cmd.id]] for c in cmd.categories}
            cats = [c for c in cmd.categories if hosts_of[c]]
            if not cats:
                break
            open_cmds = [c2 for c2 in cmds if targets[c2.id] and c2.id not in supported]
            w = np.array([1.0 + sum(c in c2.categories for c2 in open_cmds if c2 is not cmd) for c in cats])
            c = cats[int(b.rng.choice(len(cats), p=w / w.sum()))]
            used_rooms = {b.furniture[o.furniture].room for o in valid(cmd)}
            hosts = [h for h in hosts_of[c] if b.furniture[h].room not in used_rooms] or hosts_of[c]
            if _add_object(b, c, hosts) is None:
                fails += 1
        supported[cmd.id] = len(valid(cmd)) >= K
        if cmd.paper and not supported[cmd.id]:
            raise _Retry(f"paper command {cmd.id!r} has fewer than {K} valid objects")
    _fill_budget(b)
    return {c.id: supported[c.id] for c in cat.commands}


def _fill_budget(b: _Build) -> None:
    """Random objects on random furniture (hard with hard_placement_prob) up to scene.n_objects;
    raises when the surfaces are full."""
    cat, budget = b.cat, b.cfg.n_objects
    fids = list(b.furniture)
    fails = in_a_row = 0
    while len(b.objects) < budget:
        fid = fids[int(b.rng.integers(len(fids)))]
        holds = cat.furniture[b.furniture[fid].category].holds
        if _add_object(b, holds[int(b.rng.integers(len(holds)))], [fid]) is None:
            fails += 1
            in_a_row += 1
            # surfaces are full: too many failures in all, or in a row (bounds the work for big budgets)
            if fails > 50 + 5 * budget or in_a_row > MAX_FAILS_IN_A_ROW:
                if 2 * len(b.objects) < budget:
                    raise _TooFull(
                        f"scene.n_objects={budget} does not fit: the surfaces of the {len(fids)} furniture "
                        f"(scene.n_furniture) were full after {len(b.objects)} objects; lower scene.n_objects "
                        f"to about {len(b.objects)}, or raise scene.n_furniture to about "
                        f"{-(-budget * len(fids) // max(1, len(b.objects)))}")
                raise _Retry(f"could place only {len(b.objects)} of {budget} objects; surfaces are full "
                             "(raise scene.n_furniture or lower scene.n_objects)")
        else:
            in_a_row = 0


# ---- graded object design ------------------------------------------------------------------------
@dataclass
class _Approach:
    """The floor a robot can work from (graded design): ``free`` cells (free on the presumed and the
    true grid), ``stand`` cells among them (the true footprint clear of obstacles), and the anchor
    cell (row, col) of each furniture, where a navigation to it ends (as ``sim.belief`` picks it)."""

    grid: OccupancyGrid
    free: np.ndarray
    stand: np.ndarray
    anchors: dict[str, tuple[int, int] | None]


def _approach_map(b: _Build) -> _Approach:
    """The grids of the house as furnished (objects do not change them) and the furniture anchors."""
    scene = SceneGraph(id="draft", seed=0, rooms=b.rooms, walls=b.walls, doors=b.doors, furniture=b.furniture)
    res = b.cfg.grid_resolution
    presumed = rasterize(scene, res, b.robot_radius, doors="presumed")
    true = rasterize(scene, res, b.robot_radius, doors="true")
    labels, n = ndimage.label(presumed.free, structure=np.ones((3, 3), dtype=bool))
    main = labels == (int(np.argmax(np.bincount(labels.ravel())[1:])) + 1) if n else np.zeros_like(presumed.free)
    anchor_ok = presumed.free & main & clear_of_obstacles(presumed.free, b.footprint_extra, res)
    free = presumed.free & true.free
    ap = _Approach(presumed, free, clear_of_obstacles(free, b.footprint_extra, res), {})
    cells = np.argwhere(anchor_ok)
    pts = presumed.cell_to_world(cells)
    for fid, f in b.furniture.items():
        ap.anchors[fid] = _anchor_cell(cells, pts, f, b.robot_radius)
    return ap


def _anchor_cell(cells: np.ndarray, pts: np.ndarray, f: Furniture, robot_radius: float) -> tuple[int, int] | None:
    """The cell of ``cells`` (world centres ``pts`` [m]) within robot_radius + ANCHOR_RINGS of the
    footprint closest to the furniture's centre; None if there is none."""
    if not len(cells):
        return None
    d_fp = footprint_distance(pts, f.footprint)
    for ring in ANCHOR_RINGS:
        ok = d_fp <= robot_radius + ring
        if ok.any():
            dc = np.round(np.hypot(pts[ok, 0] - f.center[0], pts[ok, 1] - f.center[1]), 9)
            r, c = cells[ok][int(np.argmin(dc))]
            return int(r), int(c)
    return None


def _delivery_zones(b: _Build, ap: _Approach, fids: set[str]) -> dict[str, tuple[float, float, float, float]]:
    """Where the objects a command delivers will go on each of ``fids`` (the commands' targets): the
    surface within DELIVERY_HALF [m] (a square) of the point nearest the furniture's anchor, where a
    place puts them first; kept free of objects so a target takes objects_per_command of them."""
    zones = {}
    for fid in sorted(fids):
        anchor = ap.anchors.get(fid)
        if anchor is None:
            continue
        x0, y0, x1, y1 = b.furniture[fid].footprint
        ax, ay = (float(v) for v in ap.grid.cell_to_world(np.array(anchor)))
        px, py = min(max(ax, x0), x1), min(max(ay, y0), y1)
        zones[fid] = (px - DELIVERY_HALF, py - DELIVERY_HALF, px + DELIVERY_HALF, py + DELIVERY_HALF)
    return zones


def _easy_spot(ap: _Approach, fid: str, x: float, y: float) -> bool:
    """True when at least EASY_MIN_CELLS stand cells lie within EASY_REACH [m] of (x, y) [m] and join
    the furniture's anchor over free cells near the spot (where the robot's base poses come from)."""
    anchor = ap.anchors.get(fid)
    if anchor is None:
        return False
    g, m = ap.grid, EASY_REACH + POSE_WINDOW
    ax, ay = (float(v) for v in g.cell_to_world(np.array(anchor)))
    lo = g.world_to_cell((min(x - m, ax - 0.5), min(y - m, ay - 0.5)))
    hi = g.world_to_cell((max(x + m, ax + 0.5), max(y + m, ay + 0.5)))
    r0, c0 = max(int(lo[0]), 0), max(int(lo[1]), 0)
    r1, c1 = min(int(hi[0]) + 1, g.shape[0]), min(int(hi[1]) + 1, g.shape[1])
    labels, _ = ndimage.label(ap.free[r0:r1, c0:c1], structure=np.ones((3, 3), dtype=bool))
    home = labels[anchor[0] - r0, anchor[1] - c0]
    if home == 0:
        return False
    rr, cc = np.mgrid[r0:r1, c0:c1]
    xy = g.cell_to_world(np.stack([rr, cc], -1))
    near = np.hypot(xy[..., 0] - x, xy[..., 1] - y) <= EASY_REACH
    return int((near & ap.stand[r0:r1, c0:c1] & (labels == home)).sum()) >= EASY_MIN_CELLS


def _easy_of(b: _Build, cmd: CommandSpec, targets: set[str], exclude: set[str]) -> list[str]:
    """The command's easy instances (sorted ids) not on its targets and not in ``exclude``."""
    return [oid for oid in sorted(b.easy - exclude)
            if b.objects[oid].category in cmd.categories and b.objects[oid].furniture not in targets]


def _category_weights(b: _Build, cats: list[str], open_cmds: list[CommandSpec]) -> np.ndarray:
    """Draw weights of object categories: shared with commands still short of easy instances (fewer
    objects serve them all), fewer when the house already has instances of it (variety)."""
    have = {c: 0 for c in cats}
    for o in b.objects.values():
        if o.category in have:
            have[o.category] += 1
    w = np.array([(1.0 + sum(c in c2.categories for c2 in open_cmds)) / (1.0 + have[c]) for c in cats])
    return w / w.sum()


def _grow_easy(b: _Build, ap: _Approach, cmd: CommandSpec, targets: set[str], have: list[str],
               open_cmds: list[CommandSpec]) -> bool:
    """Place one more easy instance of ``cmd``, on a furniture not holding one of ``have`` yet where
    one takes it (in another room where possible); False if no category fits anywhere."""
    pl = b.cat.placement
    used = {b.objects[o].furniture for o in have}
    rooms = {b.furniture[f].room for f in used}
    hosts_of = {c: [f for f, fu in b.furniture.items() if c in b.cat.furniture[fu.category].holds
                    and f not in targets and fu.surface_height < pl.high_min
                    and ap.anchors.get(f) is not None] for c in cmd.categories}
    fresh = {c: [f for f in hs if f not in used] for c, hs in hosts_of.items()}
    if any(fresh.values()):
        hosts_of = fresh
    cats = [c for c in cmd.categories if hosts_of[c]]
    while cats:
        c = cats[int(b.rng.choice(len(cats), p=_category_weights(b, cats, open_cmds)))]
        hosts = [h for h in hosts_of[c] if b.furniture[h].room not in rooms] or hosts_of[c]
        for j in b.rng.permutation(len(hosts)):
            fid = hosts[int(j)]
            oid = _place_object(b, c, fid, "front", easy=True, accept=lambda x, y, f=fid: _easy_spot(ap, f, x, y))
            if oid is not None:
                b.easy.add(oid)
                return True
        cats.remove(c)
    return False


def _fill_easy(b: _Build, ap: _Approach, cmd: CommandSpec, targets: dict[str, set[str]], want: int,
               exclude: set[str], limit: int, open_cmds: list[CommandSpec]) -> list[str]:
    """Easy instances of ``cmd`` (not in ``exclude``) up to ``want`` while the house has fewer than
    ``limit`` objects; returns their ids."""
    have = _easy_of(b, cmd, targets[cmd.id], exclude)
    while len(have) < want and len(b.objects) < limit:
        if not _grow_easy(b, ap, cmd, targets[cmd.id], have, open_cmds):
            break
        have = _easy_of(b, cmd, targets[cmd.id], exclude)
    return have


def _place_graded_objects(b: _Build) -> dict[str, bool]:
    """The graded design (module doc): easy instances per command first (the paper's commands on
    instances of their own, so the paper's mission can be filled), a spare each, then medium and
    hard instances of the commands' categories, then random ones up to scene.n_objects."""
    cat, budget, k = b.cat, b.cfg.n_objects, b.k
    cmds = list(cat.paper_commands()) + [c for c in cat.commands if not c.paper]
    targets = {c.id: _targets(b, c) for c in cmds}
    ap = _approach_map(b)
    b.keep_clear = _delivery_zones(b, ap, set().union(*targets.values()))
    supported: dict[str, bool] = {c.id: False for c in cmds}
    reserved: dict[str, set[str]] = {}  # paper command -> its own easy instances

    def others(cmd: CommandSpec) -> set[str]:
        return set().union(*(v for c, v in reserved.items() if c != cmd.id)) if cmd.paper else set()

    for cmd in cmds:
        if not targets[cmd.id]:
            if cmd.paper:
                raise _Retry(f"no target furniture for paper command {cmd.id!r}")
            continue
        open_cmds = [c for c in cmds if targets[c.id] and c is not cmd and not supported[c.id]]
        have = _fill_easy(b, ap, cmd, targets, k, others(cmd), budget, open_cmds)
        supported[cmd.id] = len(have) >= k
        if cmd.paper:
            if not supported[cmd.id]:
                raise _Retry(f"paper command {cmd.id!r} has fewer than {k} easy instances (raise scene.n_objects "
                             f"or lower mission.objects_per_command)")
            reserved[cmd.id] = set(have[:k])
    keep = int(round(b.cfg.hard_placement_prob * budget))  # left for medium and hard instances
    for cmd in cmds:
        if supported[cmd.id]:
            _fill_easy(b, ap, cmd, targets, k + EASY_SPARE, others(cmd), budget - keep, [])
    _place_graded_extras(b, [c for c in cmds if supported[c.id]], targets, min(budget, len(b.objects) + keep))
    _fill_budget(b)
    return {c.id: supported[c.id] for c in cat.commands}


def _place_graded_extras(b: _Build, cmds: list[CommandSpec], targets: dict[str, set[str]], limit: int) -> None:
    """Medium (clutter) and hard (deep, high) instances of the commands' categories, command by
    command in a random order, until the house has ``limit`` objects or no furniture takes one."""
    while len(b.objects) < limit:
        placed = False
        for j in b.rng.permutation(len(cmds)):
            for level in ("medium", "hard"):
                if len(b.objects) < limit and _add_graded(b, cmds[int(j)], targets[cmds[int(j)].id], level):
                    placed = True
        if not placed:
            return


def _add_graded(b: _Build, cmd: CommandSpec, targets: set[str], level: str) -> bool:
    """One ``level`` ("medium": clutter next to an object already there; "hard": deep or high)
    instance of a category of ``cmd``, on a furniture (not a target) holding no instance of that
    category yet, preferring the categories with fewest instances of this level."""
    modes_of = {"medium": ("clutter",), "hard": ("deep", "high")}[level]
    count = {c: 0 for c in cmd.categories}
    for o in b.objects.values():
        if o.category in count and o.placement in modes_of:
            count[o.category] += 1
    for c in sorted(cmd.categories, key=lambda c: (count[c], b.rng.random())):
        here = {o.furniture for o in b.objects.values() if o.category == c}
        offers = {f: [m for m in _modes_for(b, f, c) if m in modes_of] for f, fu in b.furniture.items()
                  if c in b.cat.furniture[fu.category].holds and f not in targets and f not in here}
        hosts = sorted(f for f, ms in offers.items() if ms)
        for j in b.rng.permutation(len(hosts)):
            fid = hosts[int(j)]
            mode = offers[fid][int(b.rng.integers(len(offers[fid])))]
            if _place_object(b, c, fid, mode) is not None:
                return True
    return False


def capacity(cfg: SceneConfig, cat: Catalog) -> tuple[int, int]:
    """Upper bounds (furniture, objects) a house of ``cfg`` can hold, from the catalog's sizes:
    every room at ``scene.room_size_max``, furniture packed at its smallest footprint plus the free
    ring, objects packed on the largest surface at their smallest side plus the object gap. Sizes
    above these can never be generated; sizes below may still fail (rooms are smaller in fact)."""
    pl = cat.placement
    floor_area = cfg.n_rooms * cfg.room_size_max ** 2
    smallest = min((f.size[0] + pl.free_ring) * (f.size[1] + pl.free_ring) for f in cat.furniture.values())
    max_furniture = int(floor_area // smallest)
    per_piece = 0
    for f in cat.furniture.values():
        if not f.holds:
            continue
        area = max(0.0, f.size[0] - 2 * pl.surface_margin + pl.object_gap) * \
            max(0.0, f.size[1] - 2 * pl.surface_margin + pl.object_gap)
        need = min((cat.objects[c].size[0] + pl.object_gap) * (cat.objects[c].size[1] + pl.object_gap)
                   for c in f.holds)
        per_piece = max(per_piece, int(area // need))
    return max_furniture, per_piece * min(cfg.n_furniture, max_furniture)


def check_capacity(cfg: SceneConfig, cat: Catalog) -> None:
    """Refuse sizes that cannot fit, up front, naming the numbers that would."""
    max_f, max_o = capacity(cfg, cat)
    if cfg.n_furniture > max_f:
        raise SceneGenerationError(
            f"scene.n_furniture={cfg.n_furniture} cannot fit in {cfg.n_rooms} rooms of at most "
            f"{cfg.room_size_max:g} m (scene.room_size_max): at most {max_f} pieces would; lower "
            f"scene.n_furniture to <= {max_f}, or raise scene.n_rooms or scene.room_size_max")
    if cfg.n_objects > max_o:
        per = max(1, max_o // max(1, cfg.n_furniture))
        raise SceneGenerationError(
            f"scene.n_objects={cfg.n_objects} cannot fit on scene.n_furniture={cfg.n_furniture} pieces: at "
            f"most {max_o} objects would (about {per} per piece at best); lower scene.n_objects to "
            f"<= {max_o}, or raise scene.n_furniture to >= {-(-cfg.n_objects // per)}")


def generate_scene(cfg: SceneConfig, index: int = 0, robot_radius: float = 0.25,
                   catalog: Catalog | None = None, objects_per_command: int | None = None,
                   footprint_radius: float | None = None) -> SceneGraph:
    """Generate scene ``index`` of an experiment, deterministic in (cfg, index).

    cfg: scene config (counts, room sizes [m], door widths [m], probabilities, seed).
    robot_radius: base radius [m] used to size partly closed doors (gap < 2 * radius) and to check
        that every furniture is reachable on the presumed and the true grid.
    objects_per_command: graded design: the easy instances each command gets
        (``mission.objects_per_command``; None: the catalog's ``min_objects_per_command``).
    footprint_radius: [m] graded design: the base's true contact radius (``sim.footprint_radius``);
        easy spots need floor clear of obstacles by it (None: robot_radius + 0.05 m).
    """
    cfg.validate()
    cat = catalog or load_catalog()
    check_capacity(cfg, cat)
    k = cat.min_objects_per_command if objects_per_command is None else int(objects_per_command)
    extra = 0.05 if footprint_radius is None else max(0.0, float(footprint_radius) - robot_radius)
    graded = cfg.object_design == "graded"
    seed = int(cfg.seed) + int(index)
    if seed < 0:
        raise ValueError(f"scene.seed + index must be >= 0, got {seed}; use a non-negative scene.seed")
    reasons = []
    house_types = set(cat.room_types_for_house(cfg.n_rooms))
    want_all = all(c.target_room_type in house_types or c.target_room_type is None for c in cat.commands)
    fallback = None
    for attempt in range(MAX_ATTEMPTS):
        rng = np.random.default_rng(scene_seed(seed, attempt))
        b = _Build(cat, cfg, rng, robot_radius, k=k, footprint_extra=extra)
        try:
            (_hallway_plan if cfg.layout == "hallway" else _floor_plan)(b)
            _place_all_furniture(b)
            supported = (_place_graded_objects if graded else _place_all_objects)(b)
        except _Retry as e:
            reasons.append(str(e))
            continue
        scene = SceneGraph(
            id=f"{cfg.name}_s{seed:04d}", seed=seed, rooms=b.rooms, walls=b.walls, doors=b.doors,
            furniture=b.furniture, objects=b.objects,
            meta={"generator": "interllm.scene.generator", "preset": cfg.name, "attempt": attempt,
                  "commands": supported, "robot_radius": robot_radius,
                  "grid_resolution": cfg.grid_resolution,
                  **({"object_design": "graded", "objects_per_command": k} if graded else {})})
        bad = []
        for doors in ("presumed", "true"):
            grid = rasterize(scene, cfg.grid_resolution, robot_radius, doors=doors)
            bad += [f"{x} ({doors})" for x in unreachable(scene, grid, robot_radius)]
        if bad:
            reasons.append(f"unreachable: {bad[:5]}")
            continue
        if not want_all or all(supported.values()):
            return scene
        # Some command lacks targets or objects: keep this scene, try a few more attempts for one
        # that supports every command of the catalog.
        fallback = fallback or scene
        if attempt >= FULL_SUPPORT_ATTEMPTS:
            return fallback
    if fallback is not None:
        return fallback
    raise SceneGenerationError(f"no valid scene for seed {seed} after {MAX_ATTEMPTS} attempts; "
                               f"last reasons: {reasons[-3:]}")
