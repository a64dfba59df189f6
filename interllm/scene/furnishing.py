"""Furniture of a generated house (``generate_scene``'s second stage, after the floor plan).

Every room but the hallways gets its type's core furniture first (round-robin over the rooms, one
piece each per round), then every command's target furniture where the budget allows, then
optional furniture in rooms drawn by floor area, up to ``scene.n_furniture``. A piece keeps a free
ring of ``placement.free_ring`` m to every other furniture of its room and, on its free sides, to
the walls; wall-mounted pieces stand ``WALL_GAP`` off a wall. No furniture enters the
``door_clear_depth`` m zone in front of a door (``DOOR_ZONE_SIDE`` m beside the opening).

Each piece's size comes from ``b.assets`` (``scene.assets``; ``asset_source``). With ProcTHOR's
assets a dining table or desk is placed with the chairs its asset group puts around it (the chairs
inside the room, out of the door zones, the free ring kept around them too), seated once the
commands' targets stand; chairs are furniture beyond ``scene.n_furniture`` (``_seat_chairs``).
"""

from __future__ import annotations

import numpy as np

from interllm.scene.build_state import BuildState, Retry
from interllm.scene.floor_plans import HALLWAY
from interllm.scene.geometry import r4, rect_gap, rects_overlap
from interllm.scene.graph import Furniture

DOOR_ZONE_SIDE = 0.3  # [m] furniture-free zone extends this far beside the opening
WALL_GAP = 0.01  # [m] between a wall's inner face and furniture backs


def place_all_furniture(b: BuildState) -> None:
    """Furnish the house up to scene.n_furniture (module doc); Retry when the rooms are too small."""
    cat, n_target = b.cat, b.cfg.n_furniture
    rooms = [r for r in b.rooms.values() if r.type != HALLWAY]  # hallways stay clear
    max_core = max(len(cat.rooms[r.type].core) for r in rooms)
    for k in range(max_core):
        for r in rooms:
            core = cat.rooms[r.type].core
            if k < len(core) and _pieces(b) < n_target:
                _try_place_furniture(b, r.id, core[k])
    # Every command's target furniture, where the budget allows (e.g. the dresser of the gym command).
    for cmd in cat.commands:
        if _pieces(b) >= n_target or b.targets(cmd):
            continue
        for r in rooms:
            if cmd.target_room_type in (None, r.type) and _pieces(b) < n_target:
                if any(_try_place_furniture(b, r.id, c) for c in cmd.target_furniture):
                    break
    _seat_chairs(b)
    failures = 0
    areas = np.array([(r.bounds[2] - r.bounds[0]) * (r.bounds[3] - r.bounds[1]) for r in rooms])
    p_room = areas / areas.sum()
    while _pieces(b) < n_target:
        r = rooms[int(b.rng.choice(len(rooms), p=p_room))]
        opt = cat.rooms[r.type].optional or tuple((c, 1.0) for c in cat.rooms[r.type].core)
        w = np.array([x[1] for x in opt])
        category = opt[int(b.rng.choice(len(opt), p=w / w.sum()))][0]
        if _try_place_furniture(b, r.id, category, tries=10) is None:
            failures += 1
            if failures > 60 + 10 * n_target:
                raise Retry(f"could place only {_pieces(b)} of {n_target} furniture; "
                            "rooms are too small (raise scene.room_size_max or lower scene.n_furniture)")
        else:
            _seat_chairs(b)


def _try_place_furniture(b: BuildState, rid: str, category: str, tries: int = 30) -> str | None:
    """Place one ``category`` piece in room ``rid`` within ``tries`` draws; its id, or None. The last
    third of the draws give up the piece's chairs."""
    fc = b.cat.furniture[category]
    ring = b.cat.placement.free_ring
    interior = b.interiors[rid]
    zones = _door_zones(b, rid)
    others = [f.footprint for f in b.furniture.values() if f.room == rid]
    others += [c.footprint for fid, cs in b.pending_chairs.items() if b.furniture[fid].room == rid for c in cs]
    for attempt in range(tries):
        drawn = b.assets.furniture(category, b.rng)
        spots = b.assets.chairs(category, drawn.size[:2], b.rng) if attempt < 2 * tries // 3 else []
        pose = _draw_pose(b, interior, fc.mount, drawn.size, ring)
        if pose is None:
            if fc.mount != "wall":
                return None
            continue
        (cx, cy), (sx, sy), side = pose
        fp = (cx - sx / 2, cy - sy / 2, cx + sx / 2, cy + sy / 2)
        chairs = [_turn(s, side, (cx, cy)) for s in spots]
        boxes = [fp] + [c[0] for c in chairs]
        if any(rects_overlap(box, z) for box in boxes for z in zones):
            continue
        if any(rect_gap(box, o) < ring for box in boxes for o in others):
            continue
        if chairs and not all(_inside(box, interior) for box, _ in chairs):
            continue
        fid = b.new_id(category)
        b.furniture[fid] = Furniture(fid, category, rid, (cx, cy), (r4(sx), r4(sy), r4(drawn.size[2])),
                                     fc.description, asset=drawn.asset)
        if chairs:
            b.pending_chairs[fid] = [_chair(b, rid, box, asset) for box, asset in chairs]
        return fid
    return None


def _draw_pose(b: BuildState, interior: tuple[float, float, float, float], mount: str,
               size: tuple[float, float, float], ring: float
               ) -> tuple[tuple[float, float], tuple[float, float], str] | None:
    """((cx, cy), (sx, sy), side) [m] of one drawn pose of a piece of ``size`` (x along its back,
    depth) in the room ``interior``: against a wall (side "S", "N", "W", "E": the wall its back is
    to) or free-standing (side "" unturned, "T" turned by 90°); None when it cannot fit this way."""
    ix0, iy0, ix1, iy1 = interior
    a, d = size[0], size[1]
    if mount == "wall":
        side = ("S", "N", "W", "E")[int(b.rng.integers(4))]
        along_x = side in ("S", "N")  # the wall runs along x (its back to the south or north wall)
        (l0, l1), (c0, c1) = ((ix0, ix1), (iy0, iy1)) if along_x else ((iy0, iy1), (ix0, ix1))
        lo, hi = l0 + a / 2 + WALL_GAP, l1 - a / 2 - WALL_GAP
        if lo > hi:
            return None
        u = b.rng.uniform(lo, hi)  # along the wall
        v = c0 + WALL_GAP + d / 2 if side in ("S", "W") else c1 - WALL_GAP - d / 2  # off it
        if c1 - c0 - d - WALL_GAP < ring:
            return None
        (cx, cy), (sx, sy) = ((u, v), (a, d)) if along_x else ((v, u), (d, a))
        return (r4(cx), r4(cy)), (sx, sy), side
    side = "" if b.rng.random() < 0.5 else "T"
    sx, sy = (a, d) if side == "" else (d, a)
    lox, hix = ix0 + ring + sx / 2, ix1 - ring - sx / 2
    loy, hiy = iy0 + ring + sy / 2, iy1 - ring - sy / 2
    if lox > hix or loy > hiy:
        side = "T" if side == "" else ""
        sx, sy = sy, sx
        lox, hix = ix0 + ring + sx / 2, ix1 - ring - sx / 2
        loy, hiy = iy0 + ring + sy / 2, iy1 - ring - sy / 2
        if lox > hix or loy > hiy:
            return None
    return (r4(b.rng.uniform(lox, hix)), r4(b.rng.uniform(loy, hiy))), (sx, sy), side


# how a piece's own frame (x along its back, y towards its front) lies in the room for each side
# (module doc of asset_source): (x, y) -> the room's (x, y), and whether x and y swap
_TURNS = {"": (lambda x, y: (x, y), False), "S": (lambda x, y: (x, y), False),
          "T": (lambda x, y: (-y, x), True), "N": (lambda x, y: (-x, -y), False),
          "W": (lambda x, y: (y, -x), True), "E": (lambda x, y: (-y, x), True)}


def _turn(spot, side: str, centre: tuple[float, float]) -> tuple[tuple[float, float, float, float], str]:
    """(footprint (x0, y0, x1, y1) [m], asset id) of a chair ``spot`` of a piece posed at ``centre``
    [m] with ``side`` (``_draw_pose``)."""
    turn, swap = _TURNS[side]
    ox, oy = turn(*spot.offset)
    w, h = (spot.size[1], spot.size[0]) if swap else spot.size
    x, y = r4(centre[0] + ox), r4(centre[1] + oy)
    return (x - w / 2, y - h / 2, x + w / 2, y + h / 2), spot.asset


def _inside(box: tuple[float, float, float, float], interior: tuple[float, float, float, float]) -> bool:
    """True when ``box`` lies in ``interior`` at least WALL_GAP [m] off its walls."""
    return (box[0] >= interior[0] + WALL_GAP and box[1] >= interior[1] + WALL_GAP
            and box[2] <= interior[2] - WALL_GAP and box[3] <= interior[3] - WALL_GAP)


def _chair(b: BuildState, rid: str, box: tuple[float, float, float, float], asset: str) -> Furniture:
    """A reserved chair on footprint ``box`` [m] (its id is given when it is seated)."""
    fc = b.cat.furniture["chair"]
    cx, cy = r4((box[0] + box[2]) / 2), r4((box[1] + box[3]) / 2)
    size = (r4(box[2] - box[0]), r4(box[3] - box[1]), r4(fc.size[2]))
    return Furniture("", "chair", rid, (cx, cy), size, fc.description, asset=asset)


def _pieces(b: BuildState) -> int:
    """The furniture placed so far that counts against scene.n_furniture: all but the seated chairs."""
    return len(b.furniture) - b.seated_chairs


def _seat_chairs(b: BuildState) -> None:
    """Seat the reserved chairs, table by table in placing order. They are furniture (obstacles, in
    the scene graph) but no part of scene.n_furniture: a table's chairs do not take the place of a
    piece that hosts objects, so a house with chairs hosts the commands a house without them does."""
    for fid in list(b.pending_chairs):
        b.seated_chairs += len(b.pending_chairs[fid])
        for c in b.pending_chairs.pop(fid):
            cid = b.new_id("chair")
            b.furniture[cid] = Furniture(cid, c.category, c.room, c.center, c.size, c.description, asset=c.asset)


def _door_zones(b: BuildState, rid: str) -> list[tuple[float, float, float, float]]:
    """The furniture-free rectangles (x0, y0, x1, y1) [m] in front of the doors of room ``rid``."""
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

