"""Furniture of a generated house (``generate_scene``'s second stage, after the floor plan).

Every room but the hallways gets its type's core furniture first (round-robin over the rooms, one
piece each per round), then every command's target furniture where the budget allows, then
optional furniture in rooms drawn by floor area, up to ``scene.n_furniture``. A piece keeps a free
ring of ``placement.free_ring`` m to every other furniture of its room and, on its free sides, to
the walls; wall-mounted pieces stand ``WALL_GAP`` off a wall. No furniture enters the
``door_clear_depth`` m zone in front of a door (``DOOR_ZONE_SIDE`` m beside the opening).
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
            if k < len(core) and len(b.furniture) < n_target:
                _try_place_furniture(b, r.id, core[k])
    # Every command's target furniture, where the budget allows (e.g. the dresser of the gym command).
    for cmd in cat.commands:
        if len(b.furniture) >= n_target or b.targets(cmd):
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
                raise Retry(f"could place only {len(b.furniture)} of {n_target} furniture; "
                            "rooms are too small (raise scene.room_size_max or lower scene.n_furniture)")


def _try_place_furniture(b: BuildState, rid: str, category: str, tries: int = 30) -> str | None:
    """Place one ``category`` piece in room ``rid`` within ``tries`` draws; its id, or None."""
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

