"""The graded object design (``scene.object_design=graded``, the default): difficulty by design.

*Easy* instances first: for every command whose targets exist, ``objects_per_command`` (k,
``mission.objects_per_command``) instances of its categories placed front, at most
``surface_objects.EASY_DEPTH`` in from the edge, on furniture below the high shelf that is not one
of its targets, on a different furniture (and room) each where one takes it, at a spot with at
least ``EASY_MIN_CELLS`` grid cells within ``EASY_REACH`` where the robot can stand (free on the
presumed and the true grid, the true footprint clear) joined to the furniture's anchor. The paper's
three commands get k instances each of their own (so the paper's mission can be filled with
distinct objects); a paper command short of them redraws the attempt. Then ``EASY_SPARE`` more per
command, while ``hard_placement_prob`` of the budget stays free; with that share, *medium* (clutter
next to an object) and *hard* (deep, high) instances of the commands' categories, command by
command, on furniture not holding that category yet; then random objects up to ``n_objects``.

On every command target a square of ``DELIVERY_HALF`` around the point nearest its anchor stays
free of objects: where delivered objects go. The simulator's measurement
(``interllm.stages.feasibility``) then says which instances can in fact be delivered; the scene
layer only arranges for enough of them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from interllm.scene.build_state import BuildState, Retry
from interllm.scene.catalog import CommandSpec
from interllm.scene.geometry import footprint_distance
from interllm.scene.graph import Furniture, SceneGraph
from interllm.scene.grid import OccupancyGrid, clear_of_obstacles, rasterize
from interllm.scene.surface_objects import fill_budget, modes_for, place_object

EASY_REACH = 0.5  # [m] easy: floor the robot can stand on within this horizontal distance of the object
EASY_MIN_CELLS = 5  # easy: at least this many such grid cells (sim.n_l base poses by default)
EASY_SPARE = 1  # easy instances each command gets beyond objects_per_command (margin for failures)
POSE_WINDOW = 1.0  # [m] the stand cells join the anchor within this far beyond EASY_REACH (sim.base_poses)
DELIVERY_HALF = 0.35  # [m] half side of the square kept free on a command's target, nearest its anchor
ANCHOR_RINGS = (0.25, 0.5, 1.0)  # [m] beyond robot_radius: where a furniture's anchor may be (sim.belief)


@dataclass
class _Approach:
    """The floor a robot can work from (graded design): ``free`` cells (free on the presumed and the
    true grid), ``stand`` cells among them (the true footprint clear of obstacles), and the anchor
    cell (row, col) of each furniture, where a navigation to it ends (as ``sim.belief`` picks it)."""

    grid: OccupancyGrid
    free: np.ndarray
    stand: np.ndarray
    anchors: dict[str, tuple[int, int] | None]


def _approach_map(b: BuildState) -> _Approach:
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


def _delivery_zones(b: BuildState, ap: _Approach, fids: set[str]) -> dict[str, tuple[float, float, float, float]]:
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


def _easy_of(b: BuildState, cmd: CommandSpec, targets: set[str], exclude: set[str]) -> list[str]:
    """The command's easy instances (sorted ids) not on its targets and not in ``exclude``."""
    return [oid for oid in sorted(b.easy - exclude)
            if b.objects[oid].category in cmd.categories and b.objects[oid].furniture not in targets]


def _category_weights(b: BuildState, cats: list[str], open_cmds: list[CommandSpec]) -> np.ndarray:
    """Draw weights of object categories: shared with commands still short of easy instances (fewer
    objects serve them all), fewer when the house already has instances of it (variety)."""
    have = {c: 0 for c in cats}
    for o in b.objects.values():
        if o.category in have:
            have[o.category] += 1
    w = np.array([(1.0 + sum(c in c2.categories for c2 in open_cmds)) / (1.0 + have[c]) for c in cats])
    return w / w.sum()


def _grow_easy(b: BuildState, ap: _Approach, cmd: CommandSpec, targets: set[str], have: list[str],
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
            oid = place_object(b, c, fid, "front", easy=True, accept=lambda x, y, f=fid: _easy_spot(ap, f, x, y))
            if oid is not None:
                b.easy.add(oid)
                return True
        cats.remove(c)
    return False


def _fill_easy(b: BuildState, ap: _Approach, cmd: CommandSpec, targets: dict[str, set[str]], *, want: int,
               exclude: set[str], limit: int, open_cmds: list[CommandSpec]) -> list[str]:
    """Easy instances of ``cmd`` (not in ``exclude``) up to ``want`` while the house has fewer than
    ``limit`` objects; returns their ids."""
    have = _easy_of(b, cmd, targets[cmd.id], exclude)
    while len(have) < want and len(b.objects) < limit:
        if not _grow_easy(b, ap, cmd, targets[cmd.id], have, open_cmds):
            break
        have = _easy_of(b, cmd, targets[cmd.id], exclude)
    return have


def place_graded_objects(b: BuildState) -> dict[str, bool]:
    """The graded design (module doc): easy instances per command first (the paper's commands on
    instances of their own, so the paper's mission can be filled), a spare each, then medium and
    hard instances of the commands' categories, then random ones up to scene.n_objects."""
    cat, budget, k = b.cat, b.cfg.n_objects, b.k
    cmds = list(cat.paper_commands()) + [c for c in cat.commands if not c.paper]
    targets = {c.id: b.targets(c) for c in cmds}
    ap = _approach_map(b)
    b.keep_clear = _delivery_zones(b, ap, set().union(*targets.values()))
    supported: dict[str, bool] = {c.id: False for c in cmds}
    reserved: dict[str, set[str]] = {}  # paper command -> its own easy instances

    def others(cmd: CommandSpec) -> set[str]:
        return set().union(*(v for c, v in reserved.items() if c != cmd.id)) if cmd.paper else set()

    for cmd in cmds:
        if not targets[cmd.id]:
            if cmd.paper:
                raise Retry(f"no target furniture for paper command {cmd.id!r}")
            continue
        open_cmds = [c for c in cmds if targets[c.id] and c is not cmd and not supported[c.id]]
        have = _fill_easy(b, ap, cmd, targets, want=k, exclude=others(cmd), limit=budget, open_cmds=open_cmds)
        supported[cmd.id] = len(have) >= k
        if cmd.paper:
            if not supported[cmd.id]:
                raise Retry(f"paper command {cmd.id!r} has fewer than {k} easy instances (raise scene.n_objects "
                            f"or lower mission.objects_per_command)")
            reserved[cmd.id] = set(have[:k])
    keep = int(round(b.cfg.hard_placement_prob * budget))  # left for medium and hard instances
    for cmd in cmds:
        if supported[cmd.id]:
            _fill_easy(b, ap, cmd, targets, want=k + EASY_SPARE, exclude=others(cmd), limit=budget - keep,
                       open_cmds=[])
    _place_graded_extras(b, [c for c in cmds if supported[c.id]], targets, min(budget, len(b.objects) + keep))
    fill_budget(b)
    return {c.id: supported[c.id] for c in cat.commands}


def _place_graded_extras(b: BuildState, cmds: list[CommandSpec], targets: dict[str, set[str]], limit: int) -> None:
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


def _add_graded(b: BuildState, cmd: CommandSpec, targets: set[str], level: str) -> bool:
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
        offers = {f: [m for m in modes_for(b, f, c) if m in modes_of] for f, fu in b.furniture.items()
                  if c in b.cat.furniture[fu.category].holds and f not in targets and f not in here}
        hosts = sorted(f for f, ms in offers.items() if ms)
        for j in b.rng.permutation(len(hosts)):
            fid = hosts[int(j)]
            mode = offers[fid][int(b.rng.integers(len(offers[fid])))]
            if place_object(b, c, fid, mode) is not None:
                return True
    return False
