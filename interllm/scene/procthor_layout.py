"""The floor map of a ProcTHOR house: rooms, walls and doors (module doc of ``importer``).

ProcTHOR's floor is the x-z plane; ours is x-y. A wall shared by two rooms is listed once per room
and imported once; ``wall|exterior|...`` copies are skipped; an ``empty`` wall is an opening as wide
as the shared edge. A house without walls gets them from its room polygons. Door holes cut the
walls; every open stretch between two rooms becomes a fully open door of its width.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Optional

from interllm.scene.geometry import point_in_polygon, r4
from interllm.scene.graph import Door, Room, Wall
from interllm.scene.procthor_format import (
    ROOM_TYPES,
    Conversion,
    IdCounter,
    ImportReport,
    required,
    seg_key,
    snake_case,
    xz_point,
)
from interllm.scene.validate import SceneValidationError


def convert_floor_map(d: dict, cv: Conversion, wall_thickness: float
                      ) -> tuple[dict[str, Room], dict[str, str], dict[str, Wall], dict[str, Door]]:
    """(rooms, {the file's room id: ours}, walls, doors) of house ``d``; walls ``wall_thickness`` [m]
    thick. The file's doors come first, then one door per open stretch between two rooms."""
    ids, rep = cv.ids, cv.rep
    rooms, room_map = _rooms(d, cv)
    walls_in = _walls(d, cv)
    doors, holes, door_pairs = _doors(d, cv, room_map, walls_in)
    for i, _ in enumerate(d.get("windows", []) or []):
        rep.add("window: ignored (not part of the floor map)", f"$.windows[{i}]")
    if walls_in:
        segments = _file_walls(walls_in, rep)
    else:
        segments = _walls_from_polygons(rooms, door_pairs, rep, bool(d.get("doors")))
    walls, openings = _cut_walls(segments, holes, rooms, ids, wall_thickness)
    for (ra, rb), (center, axis, width) in sorted(openings.items()):
        did = ids.new("door")
        doors[did] = Door(did, (ra, rb), center, axis, r4(width), 1.0, "low")
    return rooms, room_map, walls, doors


def _rooms(d: dict, cv: Conversion) -> tuple[dict[str, Room], dict[str, str]]:
    """(our rooms, {the file's room id: ours}) of ``rooms[i]``; polygons counter-clockwise."""
    source, ids, rep = cv.source, cv.ids, cv.rep
    rooms: dict[str, Room] = {}
    room_map: dict[str, str] = {}
    for i, r in enumerate(required(d, "rooms", source, "$")):
        p = f"$.rooms[{i}]"
        cv.at = p
        rid_raw = str(required(r, "id", source, p))
        poly = required(r, "floorPolygon", source, p)
        if not isinstance(poly, list) or len(poly) < 3:
            raise SceneValidationError(source, f"{p}.floorPolygon", "needs at least 3 points")
        pts = tuple(tuple(r4(v) for v in xz_point(q, source, f"{p}.floorPolygon[{j}]")) for j, q in enumerate(poly))
        if "roomType" not in r:
            rep.add("room without roomType: typed 'room'", rid_raw)
        rt_raw = str(r.get("roomType", "room"))
        rtype = ROOM_TYPES.get(rt_raw.replace("_", "").lower(), snake_case(rt_raw))
        if rid_raw in room_map:
            raise SceneValidationError(source, f"{p}.id", f"duplicate room id {rid_raw!r}")
        rid = ids.new(rtype)
        room_map[rid_raw] = rid
        area2 = sum(a[0] * b[1] - b[0] * a[1] for a, b in zip(pts, pts[1:] + pts[:1], strict=True))
        rooms[rid] = Room(rid, rtype, pts if area2 > 0 else tuple(reversed(pts)))
    return rooms, room_map


def _walls(d: dict, cv: Conversion) -> dict[str, dict]:
    """{wall id: {"a", "b", "height", "empty", "room"}} of the room walls of the file."""
    source, rep = cv.source, cv.rep
    out: dict[str, dict] = {}
    for i, w in enumerate(d.get("walls", []) or []):
        p = f"$.walls[{i}]"
        cv.at = p
        wid = str(required(w, "id", source, p))
        if wid.startswith("wall|exterior") or str(w.get("roomId", "")) == "exterior":
            rep.add("exterior wall copy: skipped (the room's own wall is imported)", wid)
            continue
        height = 2.5
        if "polygon" in w and isinstance(w["polygon"], list) and len(w["polygon"]) >= 2:
            pts = [(xz_point(q, source, f"{p}.polygon[{j}]"), float(q.get("y", 0.0)))
                   for j, q in enumerate(w["polygon"])]
            base = [xz for xz, y in pts if abs(y - min(y for _, y in pts)) < 1e-6]
            height = max(y for _, y in pts) - min(y for _, y in pts) or height
            a, b = base[0], base[-1]
        else:
            parts = wid.split("|")
            try:
                a, b = (float(parts[2]), float(parts[3])), (float(parts[4]), float(parts[5]))
            except (IndexError, ValueError):
                raise SceneValidationError(source, f"{p}.polygon", "missing, and the id is not "
                                           "'wall|<room>|x0|z0|x1|z1'") from None
        if abs(a[0] - b[0]) > 1e-6 and abs(a[1] - b[1]) > 1e-6:
            raise SceneValidationError(source, p, "only axis-aligned walls are supported")
        out[wid] = {"a": a, "b": b, "height": height, "empty": bool(w.get("empty", False)),
                    "room": str(w.get("roomId", ""))}
    return out


def _doors(d: dict, cv: Conversion, room_map: dict[str, str], walls_in: dict[str, dict]):
    """(doors, openings per wall segment key [(lo, hi) along the line], the room pairs with a door)."""
    source, ids, rep = cv.source, cv.ids, cv.rep
    doors: dict[str, Door] = {}
    holes: dict[tuple, list[tuple[float, float]]] = {}
    pairs: set[tuple[str, str]] = set()
    for i, dr in enumerate(d.get("doors", []) or []):
        p = f"$.doors[{i}]"
        cv.at = p
        r0, r1 = str(required(dr, "room0", source, p)), str(required(dr, "room1", source, p))
        for key, r in (("room0", r0), ("room1", r1)):
            if r not in room_map:
                raise SceneValidationError(source, f"{p}.{key}", f"unknown room {r!r}; valid: {sorted(room_map)}")
        if r0 == r1:
            rep.add("exterior door: dropped (the outside is not on the map; its wall stays closed)",
                    str(dr.get("id", p)))
            continue
        w0 = str(required(dr, "wall0", source, p))
        geo = walls_in.get(w0) or (None if walls_in else _wall_from_id(w0))  # no walls: the id says where
        if geo is None:
            raise SceneValidationError(source, f"{p}.wall0", f"unknown wall {w0!r}")
        (ax, az), (bx, bz) = geo["a"], geo["b"]
        length = math.hypot(bx - ax, bz - az)
        lo, hi = _hole(dr, source, p, rep)
        if lo < -1e-6 or hi > length + 1e-6 or hi <= lo:
            raise SceneValidationError(source, f"{p}.holePolygon",
                                       f"opening [{lo}, {hi}] m is not inside wall {w0!r} of length {length:.3f} m")
        ux, uz = (bx - ax) / length, (bz - az) / length
        mid = (lo + hi) / 2
        center = (r4(ax + ux * mid), r4(az + uz * mid))
        axis = "x" if abs(az - bz) < 1e-6 else "y"
        openable = bool(dr.get("openable", False))
        if openable and "openness" not in dr:
            rep.add("openable door without openness: fully open", str(dr.get("id", p)))
        open_fraction = r4(min(max(float(dr.get("openness", 1.0)), 0.0), 1.0)) if openable else 1.0
        if open_fraction == 0.0:
            rep.add("door closed in the file (openness 0): kept closed (the robot does not open doors)",
                    str(dr.get("id", p)))
        did = ids.new("door")
        ra, rb = room_map[r0], room_map[r1]
        doors[did] = Door(did, (ra, rb), center, axis, r4(hi - lo), open_fraction, "low")
        pairs.add(tuple(sorted((ra, rb))))  # type: ignore[arg-type]
        c_along = center[0 if axis == "x" else 1]
        holes.setdefault(seg_key((ax, az), (bx, bz)), []).append((c_along - (hi - lo) / 2, c_along + (hi - lo) / 2))
    return doors, holes, pairs


def _wall_from_id(wid: str) -> Optional[dict]:
    parts = wid.split("|")
    try:
        a, b = (float(parts[2]), float(parts[3])), (float(parts[4]), float(parts[5]))
    except (IndexError, ValueError):
        return None
    return {"a": a, "b": b, "height": 2.5, "empty": False, "room": ""}


def _hole(dr, source, p, rep) -> tuple[float, float]:
    if "holePolygon" in dr:
        hp = dr["holePolygon"]
        return tuple(sorted((float(hp[0]["x"]), float(hp[1]["x"]))))  # type: ignore[return-value]
    if "assetPosition" in dr:
        width = 1.0
        rep.add(f"door without holePolygon: {width} m wide at its assetPosition", str(dr.get("id", p)))
        mid = float(dr["assetPosition"]["x"])
        return mid - width / 2, mid + width / 2
    raise SceneValidationError(source, f"{p}.holePolygon", "required field is missing (or give assetPosition)")


def _file_walls(walls_in: dict[str, dict], rep: ImportReport) -> list[dict]:
    """One segment per distinct wall of the file: {"a", "b", "height", "open"} ("open": ``empty``)."""
    seen: dict[tuple, dict] = {}
    for w in walls_in.values():
        key = seg_key(w["a"], w["b"])
        if key in seen:
            seen[key]["open"] |= w["empty"]
            continue
        seen[key] = {"a": key[0], "b": key[1], "height": w["height"], "open": w["empty"]}
    for key, s in seen.items():
        if s["open"]:
            rep.add("empty wall (ProcTHOR's open connection): no wall, an opening as wide as the shared edge",
                    f"{key[0]}-{key[1]}")
    return list(seen.values())


def _walls_from_polygons(rooms: dict[str, Room], door_pairs: set, rep: ImportReport, had_doors: bool) -> list[dict]:
    """Walls of a house whose file has none: every room-polygon edge, split where rooms meet; a
    shared stretch is a wall when the file has a door between the two rooms, else open."""
    lines: dict[tuple[str, float], list[tuple[float, float, str]]] = defaultdict(list)
    for rid, r in rooms.items():
        pts = list(r.polygon)
        for (ax, ay), (bx, by) in zip(pts, pts[1:] + pts[:1], strict=True):
            if abs(ay - by) < 1e-6:
                lines[("x", round(ay, 4))].append((min(ax, bx), max(ax, bx), rid))
            elif abs(ax - bx) < 1e-6:
                lines[("y", round(ax, 4))].append((min(ay, by), max(ay, by), rid))
    out = []
    n_open = 0
    for (axis, fixed), spans in sorted(lines.items()):
        cuts = sorted({v for lo, hi, _ in spans for v in (lo, hi)})
        for lo, hi in zip(cuts, cuts[1:], strict=False):
            if hi - lo < 1e-6:
                continue
            owners = sorted({rid for a, b, rid in spans if a <= lo + 1e-6 and b >= hi - 1e-6})
            if not owners:
                continue
            a, b = ((lo, fixed), (hi, fixed)) if axis == "x" else ((fixed, lo), (fixed, hi))
            shared_open = len(owners) >= 2 and tuple(owners[:2]) not in door_pairs
            n_open += shared_open
            out.append({"a": a, "b": b, "height": 2.5, "open": shared_open})
    rep.add("no walls in the file: walls derived from the room polygons", f"{len(out)} segments")
    if n_open:
        why = "no doors in the file either: the rooms are open to each other" if not had_doors else \
            "no door of the file between the two rooms: open"
        rep.add(f"shared edge without a wall ({why})", f"{n_open} segments")
    if n_open and not had_doors:
        rep.warn(f"the file has no walls and no doors: the house is open inside ({n_open} shared edges between "
                 "rooms have no wall), so the robot drives straight between rooms and navigation is easier than "
                 "in the walled house the file came from; look at topdown.png")
    return _merge_collinear(out)


def _merge_collinear(segs: list[dict]) -> list[dict]:
    """Join touching segments on one line that are both walls or both open (fewer, longer walls)."""
    by: dict[tuple, list[dict]] = defaultdict(list)
    for s in segs:
        axis = "x" if abs(s["a"][1] - s["b"][1]) < 1e-6 else "y"
        by[(axis, s["a"][1] if axis == "x" else s["a"][0], s["open"])].append(s)
    out = []
    for (axis, _fixed, _open), group in sorted(by.items()):
        k = 0 if axis == "x" else 1
        group.sort(key=lambda s: s["a"][k])
        cur = dict(group[0])
        for s in group[1:]:
            if abs(s["a"][k] - cur["b"][k]) < 1e-6:
                cur["b"] = s["b"]
            else:
                out.append(cur)
                cur = dict(s)
        out.append(cur)
    return out


def _cut_walls(segments: list[dict], holes: dict, rooms: dict[str, Room], ids: IdCounter, thickness: float):
    """(walls cut at the door holes, {room pair: (centre, axis, width)} of the open segments)."""
    walls: dict[str, Wall] = {}
    openings: dict[tuple[str, str], tuple] = {}
    for s in sorted(segments, key=lambda s: (s["a"], s["b"])):
        (sx, sz), (ex, ez) = seg_key(s["a"], s["b"])
        along_x = abs(sz - ez) < 1e-6
        if s["open"]:
            pair = _rooms_beside(rooms, (sx, sz), (ex, ez))
            if pair is not None:
                mid, width = ((sx + ex) / 2, (sz + ez) / 2), math.hypot(ex - sx, ez - sz)
                if pair not in openings or width > openings[pair][2]:
                    openings[pair] = ((r4(mid[0]), r4(mid[1])), "x" if along_x else "y", width)
                continue
        lo0, hi0 = (sx, ex) if along_x else (sz, ez)
        cur = lo0
        parts = []
        for lo, hi in sorted(holes.get(seg_key((sx, sz), (ex, ez)), [])):
            if lo > cur + 1e-6:
                parts.append((cur, lo))
            cur = max(cur, hi)
        if hi0 > cur + 1e-6:
            parts.append((cur, hi0))
        for u, v in parts:
            wid = ids.new("wall")
            start, end = ((u, sz), (v, sz)) if along_x else ((sx, u), (sx, v))
            walls[wid] = Wall(wid, (r4(start[0]), r4(start[1])), (r4(end[0]), r4(end[1])), thickness,
                              r4(s["height"]))
    return walls, openings


def _rooms_beside(rooms: dict[str, Room], a, b) -> Optional[tuple[str, str]]:
    """The two rooms on either side of the middle of segment a-b, or None (an outer edge)."""
    mx, my = (a[0] + b[0]) / 2, (a[1] + b[1]) / 2
    nx, ny = (0.0, 0.05) if abs(a[1] - b[1]) < 1e-6 else (0.05, 0.0)
    left = next((rid for rid, r in rooms.items() if point_in_polygon(r.polygon, mx - nx, my - ny)), None)
    right = next((rid for rid, r in rooms.items() if point_in_polygon(r.polygon, mx + nx, my + ny)), None)
    if left is None or right is None or left == right:
        return None
    return tuple(sorted((left, right)))  # type: ignore[return-value]
