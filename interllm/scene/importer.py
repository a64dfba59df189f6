"""Import a ProcTHOR house (schema 1.0.0, as ``allenai/procthor`` writes it) into a SceneGraph.

ProcTHOR's floor is the x-z plane with y up; we map (x, z) -> (x, y) and y -> z. What each part of
the house becomes (every defaulted or dropped item is counted in the ``ImportReport``, one line per
reason, never one warning per item):

- ``rooms[i]``: ``id``, ``roomType`` (Kitchen, LivingRoom, Bedroom, Bathroom; others by name),
  ``floorPolygon`` [{x, y, z}] -> a room with that polygon.
- ``walls[i]``: ``id`` ``wall|<room>|x0|z0|x1|z1``, ``polygon``. A wall shared by two rooms is
  listed once per room and imported once; the ``wall|exterior|...`` copies are skipped. A wall
  with ``"empty": true`` is ProcTHOR's open connection between two rooms: no wall, and an opening
  as wide as the shared edge joins the rooms. A house with no walls gets them from its room
  polygons: every edge not shared by two rooms, and every shared edge with a door of the file on it
  (cut at the door); a shared edge without a door is an open connection (so a house with neither
  walls nor doors is fully open inside, and the report says so).
- ``doors[i]``: ``room0``, ``room1``, ``wall0``, ``holePolygon`` (x along the wall from its first
  polygon point [m]) or ``assetPosition``, ``openable`` / ``openness`` (doorframes, without them,
  are open). A door with ``room0 == room1`` leads outside: dropped (the outside is not on the map),
  its wall stays closed. A door closed in the file (openness 0) stays closed: our robot does not
  open doors. ``windows`` are ignored.
- ``objects[i]``: the type comes from the id prefix (``Sofa|2|1``) or else the ``assetId`` prefix;
  the footprint and height from ``axisAlignedBoundingBox.size`` when the file has it, else from
  the catalog's size turned by ``rotation.y``; ``position`` is the box centre. Wall-mounted types
  (paintings, televisions on the wall, ...) are kept off the floor grid (not imported, nor their
  children). ``children`` are absolute world positions: each is put on its parent's top surface,
  moved inside the parent's footprint when its box would stick out. Types not in the catalog keep
  their box (or a default one) and their snake_case name as category.

Untidy houses are repaired, not rejected (``interllm.scene.repair``; ``ImportOptions(strict=True)``,
``interllm scene import-procthor --strict``, rejects them as a house author wants): a parent whose
child lies off its footprint is checked against its rotation and its ``axisAlignedBoundingBox``; a child
more than ``CHILD_SLACK`` off its parent goes to the nearest surface, the floor, or is dropped;
furniture the robot cannot reach is kept, marked unreachable, and left out of missions. The house is
rejected only when a child cannot be repaired (all listed) or no command of the catalog can be hosted.
"""

from __future__ import annotations

import math
import re
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional

from interllm.io import InputFileError, read_json
from interllm.scene.catalog import Catalog, load_catalog
from interllm.scene.geometry import r4
from interllm.scene.graph import Door, Furniture, Room, SceneGraph, SceneObject, Wall
from interllm.scene.repair import (
    CHILD_SLACK,
    check_parent_footprint,
    child_points,
    footprint_distance,
    mark_unreachable,
    place_stray_child,
    reject_unhostable,
)
from interllm.scene.validate import SceneValidationError, looks_like_scene

ROOM_TYPES = {"kitchen": "kitchen", "livingroom": "living_room", "bedroom": "bedroom", "bathroom": "bathroom",
              "diningroom": "dining_room", "office": "study", "study": "study", "laundryroom": "laundry_room"}
ALIASES = {"countertop": "kitchen_counter", "shelvingunit": "bookshelf", "shelf": "bookshelf",
           "tvstand": "tv_stand", "diningtable": "dining_table", "coffeetable": "coffee_table",
           "sidetable": "side_table", "armchair": "armchair", "cellphone": "cellphone", "houseplant": "house_plant",
           "remotecontrol": "remote_control", "sinkbasin": "sink", "garbagecan": "garbage_can",
           "keychain": "key_chain", "creditcard": "credit_card", "soapbottle": "soap_bottle",
           "spraybottle": "spray_bottle", "dishsponge": "dish_sponge", "toiletpaper": "toilet_paper",
           "tissuebox": "tissue_box", "desklamp": "desk_lamp", "floorlamp": "floor_lamp", "dogbed": "dog_bed",
           "laundryhamper": "laundry_hamper", "clothesdryer": "clothes_dryer", "washingmachine": "washing_machine",
           "alarmclock": "alarm_clock", "waterbottle": "water_bottle", "footstool": "ottoman",
           "walldecor": "painting", "wallphoto": "painting"}
CHILD_ALIASES = {"house_plant": "small_plant"}  # a plant standing on furniture is a small one
# Types ProcTHOR hangs on walls (its wall-object pass: windows, paintings, wall televisions) or fixes
# to them: never floor obstacles. A television that is a child (on a TV stand) is an object.
WALL_MOUNTED = {"painting", "television", "window", "blinds", "mirror", "light_switch", "towel_holder",
                "hand_towel_holder", "toilet_paper_hanger", "doorframe", "doorway"}
SCHEMA = "1.0.0"  # metadata.schema of the houses this importer reads
DEFAULT_FURNITURE_SIZE = (1.0, 0.6, 0.75)  # [m]
DEFAULT_OBJECT_SIZE = (0.1, 0.1, 0.1)  # [m]
CHILD_MARGIN = 0.01  # [m] a child moved onto its parent keeps this far inside the footprint


@dataclass
class ImportReport:
    """What an import defaulted, dropped or moved: {reason: [item, ...]}."""

    items: dict[str, list[str]] = field(default_factory=lambda: defaultdict(list))

    def add(self, reason: str, item: str) -> None:
        self.items[reason].append(item)

    def lines(self, examples: int = 3) -> list[str]:
        """One line per reason: ``<count> × <reason> (e.g. a, b, c)``, sorted by reason."""
        out = []
        for reason in sorted(self.items):
            got = self.items[reason]
            uniq = list(dict.fromkeys(got))
            more = ", ..." if len(uniq) > examples else ""
            out.append(f"{len(got)} × {reason} (e.g. {', '.join(uniq[:examples])}{more})")
        return out


def _snake(name: str) -> str:
    return re.sub(r"(?<!^)(?=[A-Z])", "_", name).lower()


def _type_name(o: dict) -> str:
    """ProcTHOR's object type: the alphabetic prefix of the id (``Sofa|2|1``), else of the assetId
    (``Sofa_208_1``, ``Wall_Decor_Painting_6``), else "object"."""
    head = str(o.get("id", "")).split("|")[0]
    if head.isalpha() and head.lower() not in ("small", "surface"):
        return head
    asset = str(o.get("assetId", ""))
    parts = [p for p in asset.split("_") if p.isalpha()]
    if parts[:2] == ["Wall", "Decor"]:  # Wall_Decor_Painting_6, Wall_Decor_Photo_3V
        return "WallDecor"
    return parts[0] if parts else "object"


def _category(type_name: str, known: dict) -> tuple[str, bool]:
    """(our category, whether the catalog knows it) of a ProcTHOR type name."""
    key = type_name.replace("_", "").lower()
    name = ALIASES.get(key, _snake(type_name))
    return name, name in known


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


def _seg_key(a, b) -> tuple:
    return tuple(sorted([(round(a[0], 3), round(a[1], 3)), (round(b[0], 3), round(b[1], 3))]))


@dataclass(frozen=True)
class ImportOptions:
    """How forgiving an import is. strict: reject a child far off its parent, and (in ``validate_scene``)
    unreachable furniture, as a house author wants; else repair them (``interllm.scene.repair``).
    robot_radius [m], resolution [m/cell]: the grid on which reachability is judged.
    objects_per_command: the reachable objects a command needs to be hostable."""

    strict: bool = False
    robot_radius: float = 0.25
    resolution: float = 0.05
    objects_per_command: int = 3


def import_procthor(house: str | Path | dict, catalog: Catalog | None = None, scene_id: str | None = None,
                    wall_thickness: float = 0.1, report: Optional[ImportReport] = None,
                    opts: Optional[ImportOptions] = None) -> SceneGraph:
    """Convert a ProcTHOR house (path to JSON or dict) into a SceneGraph (see module docstring).

    scene_id: default the house's ``id``, else the file's name (``procthor_house`` for a dict).
    report: filled with what was defaulted, dropped, moved or repaired (also in
    ``scene.meta["import_report"]``), and a house of another ``metadata.schema`` than 1.0.0.
    opts: ``ImportOptions`` (default: repair untidy houses; ``strict=True``: reject them).
    Raises ``SceneValidationError`` with the JSON path when a required field is missing or wrong, when
    the file is a scene in this project's format already, or (without strict) when children cannot be
    repaired (all listed) or no command of the catalog can be hosted.
    """
    cat = catalog or load_catalog()
    rep = report if report is not None else ImportReport()
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
    if looks_like_scene(d):
        raise SceneValidationError(source, "$", f"this is already a scene in interllm's format, not a "
                                                f"ProcTHOR house: use it as it is, "
                                                f"scene.import_path={source} (check it with "
                                                f"`interllm scene validate {source}`)")
    _check_schema_version(d, rep)
    if scene_id is None and not d.get("id") and not isinstance(house, dict):  # the file's name, not a default
        scene_id = re.sub(r"[^A-Za-z0-9_.-]+", "_", Path(house).stem) or None
    at = ["$"]  # the JSON path being converted, for the message when a field has the wrong type
    try:
        return _convert(d, cat, source, scene_id, wall_thickness, at, rep, opts or ImportOptions())
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as e:
        if isinstance(e, SceneValidationError):
            raise
        detail = f"missing field {e}" if isinstance(e, KeyError) else f"{type(e).__name__}: {e}"
        raise SceneValidationError(source, at[0], f"a field has the wrong type or is missing ({detail}); "
                                   f"see ProcTHOR's house format") from None


def _check_schema_version(d: dict, rep: ImportReport) -> None:
    """A house of another ProcTHOR schema than the one this importer reads is converted all the same,
    with a line in the report (most fields keep their meaning across versions)."""
    meta = d.get("metadata")
    version = meta.get("schema") if isinstance(meta, dict) else None
    if version is not None and str(version) != SCHEMA:
        rep.add(f"schema {version!r}: not the ProcTHOR schema {SCHEMA} this importer knows; converted as "
                f"{SCHEMA}: check the result (topdown.png) and the lines above", "$.metadata.schema")


class _Ids:
    def __init__(self) -> None:
        self.counters: dict[str, int] = {}

    def new(self, kind: str) -> str:
        self.counters[kind] = self.counters.get(kind, 0) + 1
        return f"{kind}_{self.counters[kind]}"


def _convert(d: dict, cat: Catalog, source: str, scene_id: str | None, wall_thickness: float,
             at: list[str], rep: ImportReport, opts: ImportOptions) -> SceneGraph:
    ids = _Ids()
    rooms, room_map = _rooms(d, source, at, ids, rep)
    walls_in = _walls(d, source, at, rep)
    doors, holes, door_pairs = _doors(d, source, at, ids, rep, room_map, walls_in)
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
    furniture, objects, raw_ids, paths = _objects(d, cat, source, at, ids, rep, rooms, opts.strict)
    for k, rid in room_map.items():
        raw_ids[rid] = k
    scene = SceneGraph(id=scene_id or str(d.get("id", "procthor_house")), seed=0, rooms=rooms, walls=walls,
                       doors=doors, furniture=furniture, objects=objects,
                       meta={"importer": "procthor", "source_ids": dict(sorted(raw_ids.items()))})
    if not opts.strict:
        at[0] = "$.objects"
        if mark_unreachable(scene, opts.robot_radius, opts.resolution, rep, paths):
            reject_unhostable(scene, cat, source, opts.objects_per_command)
    scene.meta["import_report"] = rep.lines()
    return scene


def _rooms(d, source, at, ids, rep) -> tuple[dict[str, Room], dict[str, str]]:
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
            rep.add("room without roomType: typed 'room'", rid_raw)
        rt_raw = str(r.get("roomType", "room"))
        rtype = ROOM_TYPES.get(rt_raw.replace("_", "").lower(), _snake(rt_raw))
        if rid_raw in room_map:
            raise SceneValidationError(source, f"{p}.id", f"duplicate room id {rid_raw!r}")
        rid = ids.new(rtype)
        room_map[rid_raw] = rid
        area2 = sum(a[0] * b[1] - b[0] * a[1] for a, b in zip(pts, pts[1:] + pts[:1], strict=True))
        rooms[rid] = Room(rid, rtype, pts if area2 > 0 else tuple(reversed(pts)))
    return rooms, room_map


def _walls(d, source, at, rep) -> dict[str, dict]:
    """{wall id: {"a", "b", "height", "empty", "room"}} of the room walls of the file."""
    out: dict[str, dict] = {}
    for i, w in enumerate(d.get("walls", []) or []):
        p = f"$.walls[{i}]"
        at[0] = p
        wid = str(_req(w, "id", source, p))
        if wid.startswith("wall|exterior") or str(w.get("roomId", "")) == "exterior":
            rep.add("exterior wall copy: skipped (the room's own wall is imported)", wid)
            continue
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
        if abs(a[0] - b[0]) > 1e-6 and abs(a[1] - b[1]) > 1e-6:
            raise SceneValidationError(source, p, "only axis-aligned walls are supported")
        out[wid] = {"a": a, "b": b, "height": height, "empty": bool(w.get("empty", False)),
                    "room": str(w.get("roomId", ""))}
    return out


def _doors(d, source, at, ids, rep, room_map, walls_in):
    """(doors, openings per wall segment key [(lo, hi) along the line], the room pairs with a door)."""
    doors: dict[str, Door] = {}
    holes: dict[tuple, list[tuple[float, float]]] = {}
    pairs: set[tuple[str, str]] = set()
    for i, dr in enumerate(d.get("doors", []) or []):
        p = f"$.doors[{i}]"
        at[0] = p
        r0, r1 = str(_req(dr, "room0", source, p)), str(_req(dr, "room1", source, p))
        for key, r in (("room0", r0), ("room1", r1)):
            if r not in room_map:
                raise SceneValidationError(source, f"{p}.{key}", f"unknown room {r!r}; valid: {sorted(room_map)}")
        if r0 == r1:
            rep.add("exterior door: dropped (the outside is not on the map; its wall stays closed)",
                    str(dr.get("id", p)))
            continue
        w0 = str(_req(dr, "wall0", source, p))
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
        holes.setdefault(_seg_key((ax, az), (bx, bz)), []).append((c_along - (hi - lo) / 2, c_along + (hi - lo) / 2))
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
        key = _seg_key(w["a"], w["b"])
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


def _cut_walls(segments: list[dict], holes: dict, rooms: dict[str, Room], ids: _Ids, thickness: float):
    """(walls cut at the door holes, {room pair: (centre, axis, width)} of the open segments)."""
    walls: dict[str, Wall] = {}
    openings: dict[tuple[str, str], tuple] = {}
    for s in sorted(segments, key=lambda s: (s["a"], s["b"])):
        (sx, sz), (ex, ez) = _seg_key(s["a"], s["b"])
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
        for lo, hi in sorted(holes.get(_seg_key((sx, sz), (ex, ez)), [])):
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
    left = next((rid for rid, r in rooms.items() if _inside(r.polygon, mx - nx, my - ny)), None)
    right = next((rid for rid, r in rooms.items() if _inside(r.polygon, mx + nx, my + ny)), None)
    if left is None or right is None or left == right:
        return None
    return tuple(sorted((left, right)))  # type: ignore[return-value]


def _box(o: dict, catalog_size, rep: ImportReport, what: str, default) -> tuple[float, float, float]:
    """(x extent, z extent, height) [m]: the file's axisAlignedBoundingBox, else the catalog size turned by
    rotation.y (the bounding box of the turned footprint), else ``default`` (reported)."""
    aabb = o.get("axisAlignedBoundingBox")
    if isinstance(aabb, dict) and isinstance(aabb.get("size"), dict):
        s = aabb["size"]
        return float(s["x"]), float(s["z"]), float(s["y"])
    size = catalog_size
    if size is None:
        rep.add(f"{what} without a bounding box, type not in the catalog: default size {default}", str(o.get("id")))
        size = default
    yaw = math.radians(float((o.get("rotation") or {}).get("y", 0.0)))
    c, s_ = abs(math.cos(yaw)), abs(math.sin(yaw))
    return size[0] * c + size[1] * s_, size[0] * s_ + size[1] * c, size[2]


def _objects(d, cat, source, at, ids, rep, rooms, strict: bool):
    """(furniture, objects, {our id: the file's id}, {our id: JSON path}) of ``objects[i]``: the furniture
    first, then their children (a stray child may go to any furniture). Without ``strict`` a child that
    cannot be repaired does not stop the others: all of them are listed in one error."""
    furniture: dict[str, Furniture] = {}
    objects: dict[str, SceneObject] = {}
    raw_ids: dict[str, str] = {}
    paths: dict[str, str] = {}
    kids: list[tuple[Furniture, dict, str]] = []
    for i, o in enumerate(d.get("objects", []) or []):
        p = f"$.objects[{i}]"
        at[0] = p
        f = _furniture(o, p, cat, source, ids, rep, rooms, strict)
        if f is None:
            continue
        furniture[f.id] = f
        raw_ids[f.id], paths[f.id] = str(o["id"]), p
        kids += [(f, c, f"{p}.children[{j}]") for j, c in enumerate(_flatten(o.get("children", []) or []))]
    broken = []
    for f, c, cp in kids:
        at[0] = cp
        try:
            placed = _child(c, f, cat, source, cp, ids, rep, (furniture, rooms), strict)
        except SceneValidationError as e:
            if strict:
                raise
            broken.append(f"{e.path}: {e.problem}")
            continue
        if placed is not None:
            oid, obj = placed
            raw_ids[oid], paths[oid] = str(c.get("id")), cp
            objects[oid] = obj
    if broken:
        raise SceneValidationError(source, "$.objects", f"{len(broken)} child object(s) cannot be repaired: "
                                   + "; ".join(broken))
    return furniture, objects, raw_ids, paths


def _furniture(o, p, cat, source, ids, rep, rooms, strict: bool) -> Optional[Furniture]:
    """The furniture of ProcTHOR object ``o`` (at JSON path ``p``), or None for a wall-mounted one.
    Without ``strict`` its footprint is checked against its children (``repair.check_parent_footprint``)."""
    raw = str(_req(o, "id", source, p))
    tname = _type_name(o)
    fcat, known = _category(tname, cat.furniture)
    if fcat in WALL_MOUNTED:
        rep.add(f"wall-mounted {fcat}: kept off the floor grid (not imported)", raw)
        for c in o.get("children", []) or []:
            rep.add("child of a wall-mounted object: dropped with it", str(c.get("id")))
        return None
    pos = _req(o, "position", source, p)
    fx, fy = _xz(pos, source, f"{p}.position")
    if not known:
        rep.add("furniture type not in the catalog: its own name as category", tname)
    csize = cat.furniture[fcat].size if known else None
    sx, sy, h = _box(o, csize, rep, "furniture", DEFAULT_FURNITURE_SIZE)
    if not strict:
        points = child_points(_flatten(o.get("children", []) or []))
        sx, sy = check_parent_footprint(o, p, (fx, fy), (sx, sy), csize, points, rep)
    top = float(pos.get("y", h / 2)) + h / 2 if isinstance(o.get("axisAlignedBoundingBox"), dict) else h
    room = next((rid for rid, r in rooms.items() if _inside(r.polygon, fx, fy)), None)
    if room is None:
        raise SceneValidationError(source, f"{p}.position", f"({fx}, {fy}) is inside no room's floorPolygon")
    desc = cat.furniture[fcat].description if known else ""
    return Furniture(ids.new(fcat), fcat, room, (r4(fx), r4(fy)), (r4(sx), r4(sy), r4(top)), desc)


def _flatten(children: list) -> list:
    """Children and their children (ProcTHOR nests at most one level in practice), in file order."""
    out = []
    for c in children:
        out.append(c)
        out.extend(_flatten(c.get("children", []) or []) if isinstance(c, dict) else [])
    return out


def _child(c: dict, f: Furniture, cat: Catalog, source: str, cp: str, ids: _Ids, rep: ImportReport,
           world: tuple[dict, dict], strict: bool) -> Optional[tuple[str, SceneObject]]:
    """An object resting on furniture ``f``: on its top surface, inside its footprint; without ``strict``
    a child far off ``f`` goes to another surface, the floor, or is dropped (None). ``world``: (furniture,
    rooms) of the house."""
    craw = str(_req(c, "id", source, cp))
    tname = _type_name(c)
    ocat, known = _category(tname, cat.objects)
    ocat = CHILD_ALIASES.get(ocat, ocat)
    known = ocat in cat.objects
    if not known:
        rep.add("object type not in the catalog: its own name as category", tname)
    oc = cat.objects.get(ocat)
    sx, sy, sz = _box(c, oc.size if oc else None, rep, "object", DEFAULT_OBJECT_SIZE)
    if "position" in c:
        ox, oy = _xz(c["position"], source, f"{cp}.position")
        if not (math.isfinite(ox) and math.isfinite(oy)):
            raise SceneValidationError(source, f"{cp}.position", f"({ox}, {oy}) is not a finite point; write the "
                                       f"child's world position in metres, or remove the child")
    else:
        rep.add("object without position: put at the centre of its parent", craw)
        ox, oy = f.center
    stray = footprint_distance(f.footprint, ox, oy) > CHILD_SLACK
    if stray and strict:
        raise SceneValidationError(source, f"{cp}.position",
                                   f"({ox}, {oy}) is not over its parent {f.id!r} (footprint "
                                   f"{tuple(round(v, 3) for v in f.footprint)}, more than {CHILD_SLACK} m away)")
    if stray:
        f = place_stray_child(craw, cp, (ox, oy), (sx, sy), world, cat, ids.new, rep)  # type: ignore[assignment]
        if f is None:
            return None
    x0, y0, x1, y1 = f.footprint
    mx = min(sx / 2 + CHILD_MARGIN, (x1 - x0) / 2)
    my = min(sy / 2 + CHILD_MARGIN, (y1 - y0) / 2)
    nx, ny = min(max(ox, x0 + mx), x1 - mx), min(max(oy, y0 + my), y1 - my)
    if math.hypot(nx - ox, ny - oy) > 0.01 and not stray:
        rep.add("object not over its parent's top: moved onto it", craw)
    oid = ids.new(ocat)
    high = f.surface_height >= cat.placement.high_min
    obj = SceneObject(oid, ocat, f.id, (r4(nx), r4(ny), r4(f.surface_height + sz / 2)),
                      (r4(sx), r4(sy), r4(sz)), oc.usage if oc else "", "high" if high else "front")
    return oid, obj
