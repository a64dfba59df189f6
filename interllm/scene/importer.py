"""Import ProcTHOR-style house JSON into a SceneGraph.

ProcTHOR's floor is the x-z plane with y up; we map (x, z) -> (x, y) and y -> z. Layout read:
- ``rooms[i]``: ``id``, ``roomType`` ("Kitchen", "LivingRoom", ...), ``floorPolygon`` [{x, y, z}, ...].
- ``walls[i]``: ``id`` (``wall|<room>|x0|z0|x1|z1``) and optional ``polygon``; a wall shared by
  two rooms appears once per room and is imported once.
- ``doors[i]``: ``room0``, ``room1``, ``wall0`` (wall id), ``holePolygon`` (two corners in the wall's
  frame: x along the wall from its start [m]) or else ``assetPosition`` (x along the wall),
  ``openness`` in [0, 1] for openable doors (non-openable doorways count as fully open).
- ``objects[i]``: top-level objects are furniture (receptacles): ``id`` ("DiningTable|2|1"),
  ``position`` {x, y, z} [m], optional ``rotation`` {y: degrees}; their ``children`` are the
  objects resting on them.
Sizes come from our catalog (ProcTHOR stores asset ids, not extents). Missing optional fields get
defaults and a ``warnings.warn``; missing required fields or contradictions raise
``SceneValidationError`` with the JSON path.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path
from typing import Any

from interllm.io import InputFileError, read_json
from interllm.scene.catalog import Catalog, load_catalog
from interllm.scene.geometry import r4
from interllm.scene.graph import Door, Furniture, Room, SceneGraph, SceneObject, Wall
from interllm.scene.validate import SceneValidationError

ROOM_TYPES = {"kitchen": "kitchen", "livingroom": "living_room", "bedroom": "bedroom", "bathroom": "bathroom",
              "diningroom": "dining_room", "office": "study", "study": "study", "laundryroom": "laundry_room"}
ALIASES = {"countertop": "kitchen_counter", "shelvingunit": "bookshelf", "shelf": "bookshelf",
           "tvstand": "tv_stand", "diningtable": "dining_table", "coffeetable": "coffee_table",
           "sidetable": "side_table", "armchair": "armchair", "cellphone": "cellphone",
           "remotecontrol": "remote_control", "sinkbasin": "bathroom_counter", "watch": "glasses"}
DEFAULT_FURNITURE_SIZE = (1.0, 0.6, 0.75)  # [m]
DEFAULT_OBJECT_SIZE = (0.1, 0.1, 0.1)  # [m]


def _snake(name: str) -> str:
    return re.sub(r"(?<!^)(?=[A-Z])", "_", name).lower()


def _category(raw_id: str, known: dict, kind: str, path: str) -> str:
    base = raw_id.split("|")[0]
    key = base.replace("_", "").lower()
    if key in ALIASES:
        return ALIASES[key]
    snake = _snake(base)
    if snake in known:
        return snake
    warnings.warn(f"{path}: {kind} type {base!r} is not in the catalog; imported as {snake!r} with "
                  "default size", stacklevel=3)
    return snake


def _xz(p: Any, source: str, path: str) -> tuple[float, float]:
    if not isinstance(p, dict) or "x" not in p or "z" not in p:
        raise SceneValidationError(source, path, "expected a point {x, y, z} with keys x and z")
    return float(p["x"]), float(p["z"])


def _req(d: dict, key: str, source: str, path: str) -> Any:
    if not isinstance(d, dict) or key not in d:
        raise SceneValidationError(source, f"{path}.{key}", "required field is missing")
    return d[key]


def _inside(poly, x, y) -> bool:
    inside = False
    n = len(poly)
    for i in range(n):
        (ax, ay), (bx, by) = poly[i], poly[(i + 1) % n]
        if (ay > y) != (by > y) and x < ax + (y - ay) * (bx - ax) / (by - ay):
            inside = not inside
    return inside


def import_procthor(house: str | Path | dict, catalog: Catalog | None = None, scene_id: str | None = None,
                    wall_thickness: float = 0.1) -> SceneGraph:
    """Convert a ProcTHOR house (path to JSON or dict) into a SceneGraph (see module docstring)."""
    cat = catalog or load_catalog()
    if isinstance(house, dict):
        d, source = house, "<procthor house>"
    else:
        source = str(house)
        try:
            d = read_json(house)
        except InputFileError as e:
            raise SceneValidationError(source, "$", e.problem) from None
    if not isinstance(d, dict):
        raise SceneValidationError(source, "$", f"a ProcTHOR house is a JSON object, got {type(d).__name__}")
    at = ["$"]  # the JSON path being converted, for the message when a field has the wrong type
    try:
        return _convert(d, cat, source, scene_id, wall_thickness, at)
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as e:
        if isinstance(e, SceneValidationError):
            raise
        detail = f"missing field {e}" if isinstance(e, KeyError) else f"{type(e).__name__}: {e}"
        raise SceneValidationError(source, at[0], f"a field has the wrong type or is missing ({detail}); "
                                   f"see ProcTHOR's house format") from None


def _convert(d: dict, cat: Catalog, source: str, scene_id: str | None, wall_thickness: float,
             at: list[str]) -> SceneGraph:
    counters: dict[str, int] = {}

    def new_id(kind: str) -> str:
        counters[kind] = counters.get(kind, 0) + 1
        return f"{kind}_{counters[kind]}"

    rooms: dict[str, Room] = {}
    room_map: dict[str, str] = {}
    for i, r in enumerate(_req(d, "rooms", source, "$")):
        p = f"$.rooms[{i}]"
        at[0] = p
        rid_raw = str(_req(r, "id", source, p))
        poly = _req(r, "floorPolygon", source, p)
        if not isinstance(poly, list) or len(poly) < 3:
            raise SceneValidationError(source, f"{p}.floorPolygon", "needs at least 3 points")
        pts = tuple(tuple(r4(v) for v in _xz(q, source, f"{p}.floorPolygon[{j}]")) for j, q in enumerate(poly))
        if "roomType" not in r:
            warnings.warn(f"{source}: {p}.roomType missing; using 'room'", stacklevel=2)
        rt_raw = str(r.get("roomType", "room"))
        rtype = ROOM_TYPES.get(rt_raw.replace("_", "").lower(), _snake(rt_raw))
        if rid_raw in room_map:
            raise SceneValidationError(source, f"{p}.id", f"duplicate room id {rid_raw!r}")
        rid = new_id(rtype)
        room_map[rid_raw] = rid
        area2 = sum(a[0] * b[1] - b[0] * a[1] for a, b in zip(pts, pts[1:] + pts[:1], strict=True))
        rooms[rid] = Room(rid, rtype, pts if area2 > 0 else tuple(reversed(pts)))

    # Walls: segment per distinct (x0, z0, x1, z1); ids from ProcTHOR wall ids or polygons.
    wall_geo: dict[str, tuple[tuple[float, float], tuple[float, float], float]] = {}
    for i, w in enumerate(d.get("walls", [])):
        p = f"$.walls[{i}]"
        at[0] = p
        wid = str(_req(w, "id", source, p))
        height = 2.5
        if "polygon" in w and isinstance(w["polygon"], list) and len(w["polygon"]) >= 2:
            pts = [(_xz(q, source, f"{p}.polygon[{j}]"), float(q.get("y", 0.0))) for j, q in enumerate(w["polygon"])]
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
        wall_geo[wid] = (a, b, height)

    doors: dict[str, Door] = {}
    holes: dict[tuple, list[tuple[float, float]]] = {}
    for i, dr in enumerate(d.get("doors", [])):
        p = f"$.doors[{i}]"
        at[0] = p
        r0, r1 = str(_req(dr, "room0", source, p)), str(_req(dr, "room1", source, p))
        for key, r in (("room0", r0), ("room1", r1)):
            if r not in room_map:
                raise SceneValidationError(source, f"{p}.{key}", f"unknown room {r!r}; valid: {sorted(room_map)}")
        if r0 == r1:
            raise SceneValidationError(source, f"{p}.room1", "a door must join two different rooms")
        w0 = str(_req(dr, "wall0", source, p))
        if w0 not in wall_geo:
            raise SceneValidationError(source, f"{p}.wall0", f"unknown wall {w0!r}")
        (ax, az), (bx, bz), _ = wall_geo[w0]
        length = ((bx - ax) ** 2 + (bz - az) ** 2) ** 0.5
        if abs(ax - bx) > 1e-6 and abs(az - bz) > 1e-6:
            raise SceneValidationError(source, f"{p}.wall0", "only axis-aligned walls are supported")
        if "holePolygon" in dr:
            hp = dr["holePolygon"]
            lo, hi = sorted((float(hp[0]["x"]), float(hp[1]["x"])))
        elif "assetPosition" in dr:
            width = 1.0
            warnings.warn(f"{source}: {p}.holePolygon missing; using assetPosition and width {width} m",
                          stacklevel=2)
            mid = float(dr["assetPosition"]["x"])
            lo, hi = mid - width / 2, mid + width / 2
        else:
            raise SceneValidationError(source, f"{p}.holePolygon", "required field is missing "
                                       "(or give assetPosition)")
        if lo < -1e-6 or hi > length + 1e-6 or hi <= lo:
            raise SceneValidationError(source, f"{p}.holePolygon",
                                       f"opening [{lo}, {hi}] m is not inside wall {w0!r} of length {length:.3f} m")
        ux, uz = (bx - ax) / length, (bz - az) / length
        mid = (lo + hi) / 2
        center = (r4(ax + ux * mid), r4(az + uz * mid))
        axis = "x" if abs(az - bz) < 1e-6 else "y"
        openable = bool(dr.get("openable", False))
        if openable and "openness" not in dr:
            warnings.warn(f"{source}: {p}.openness missing for an openable door; assuming fully open",
                          stacklevel=2)
        open_fraction = r4(min(max(float(dr.get("openness", 1.0)), 0.0), 1.0)) if openable else 1.0
        did = new_id("door")
        doors[did] = Door(did, (room_map[r0], room_map[r1]), center, axis, r4(hi - lo), open_fraction, "low")
        key = tuple(sorted([(round(ax, 3), round(az, 3)), (round(bx, 3), round(bz, 3))]))
        c_along = center[0 if axis == "x" else 1]
        holes.setdefault(key, []).append((c_along - (hi - lo) / 2, c_along + (hi - lo) / 2))

    walls: dict[str, Wall] = {}
    done = set()
    for wid in wall_geo:
        a, b, height = wall_geo[wid]
        key = tuple(sorted([(round(a[0], 3), round(a[1], 3)), (round(b[0], 3), round(b[1], 3))]))
        if key in done:
            continue
        done.add(key)
        (sx, sz), (ex, ez) = key
        along_x = abs(sz - ez) < 1e-6
        s, e = (sx, ex) if along_x else (sz, ez)
        cuts = sorted(holes.get(key, []))
        segs, cur = [], s
        for lo, hi in cuts:
            if lo > cur + 1e-6:
                segs.append((cur, lo))
            cur = max(cur, hi)
        if e > cur + 1e-6:
            segs.append((cur, e))
        for u, v in segs:
            nid = new_id("wall")
            start, end = ((u, sz), (v, sz)) if along_x else ((sx, u), (sx, v))
            walls[nid] = Wall(nid, (r4(start[0]), r4(start[1])), (r4(end[0]), r4(end[1])), wall_thickness,
                              r4(height))

    furniture: dict[str, Furniture] = {}
    objects: dict[str, SceneObject] = {}
    raw_ids: dict[str, str] = {}
    for i, o in enumerate(d.get("objects", [])):
        p = f"$.objects[{i}]"
        at[0] = p
        raw = str(_req(o, "id", source, p))
        fx, fy = _xz(_req(o, "position", source, p), source, f"{p}.position")
        fcat = _category(raw, cat.furniture, "furniture", p)
        size = cat.furniture[fcat].size if fcat in cat.furniture else DEFAULT_FURNITURE_SIZE
        rot = float((o.get("rotation") or {}).get("y", 0.0)) % 180.0
        if abs(rot - 90.0) < 45.0:
            size = (size[1], size[0], size[2])
        room = next((rid for rid, r in rooms.items() if _inside(r.polygon, fx, fy)), None)
        if room is None:
            raise SceneValidationError(source, f"{p}.position", f"({fx}, {fy}) is inside no room's floorPolygon")
        fid = new_id(fcat)
        raw_ids[fid] = raw
        desc = cat.furniture[fcat].description if fcat in cat.furniture else ""
        furniture[fid] = Furniture(fid, fcat, room, (r4(fx), r4(fy)), tuple(r4(v) for v in size), desc)
        for j, c in enumerate(o.get("children", []) or []):
            cp = f"{p}.children[{j}]"
            at[0] = cp
            craw = str(_req(c, "id", source, cp))
            ocat = _category(craw, cat.objects, "object", cp)
            oc = cat.objects.get(ocat)
            osize = oc.size if oc else DEFAULT_OBJECT_SIZE
            if "position" in c:
                ox, oy = _xz(c["position"], source, f"{cp}.position")
            else:
                warnings.warn(f"{source}: {cp}.position missing; placing it at the centre of {raw!r}",
                              stacklevel=2)
                ox, oy = fx, fy
            fx0, fy0, fx1, fy1 = furniture[fid].footprint
            if not (fx0 - 1e-6 <= ox <= fx1 + 1e-6 and fy0 - 1e-6 <= oy <= fy1 + 1e-6):
                raise SceneValidationError(source, f"{cp}.position",
                                           f"({ox}, {oy}) is not over its parent {raw!r} (footprint "
                                           f"{tuple(round(v, 3) for v in furniture[fid].footprint)})")
            oid = new_id(ocat)
            raw_ids[oid] = craw
            placement = "high" if size[2] >= cat.placement.high_min else "front"
            objects[oid] = SceneObject(oid, ocat, fid, (r4(ox), r4(oy), r4(size[2] + osize[2] / 2)),
                                       tuple(r4(v) for v in osize), oc.usage if oc else "", placement)
    for k, rid in room_map.items():
        raw_ids[rid] = k
    return SceneGraph(id=scene_id or str(d.get("id", "procthor_house")), seed=0, rooms=rooms, walls=walls,
                      doors=doors, furniture=furniture, objects=objects,
                      meta={"importer": "procthor", "source_ids": dict(sorted(raw_ids.items()))})
