"""The furniture and objects of a ProcTHOR house (module doc of ``importer``).

Each of ``objects[i]`` is a furniture (wall-mounted types are left out, with their children); its
``children`` are objects on its top surface, moved inside its footprint when their box would stick
out. Without ``strict`` a child far off its parent is repaired (``interllm.scene.repair``). A child
below the top of a closed receptacle (``CLOSED_RECEPTACLES``) stays where the file has it, marked
``placement: "inside"``: the robot does not open doors, so its pickup fails and no mission asks for it.
"""

from __future__ import annotations

import math
from typing import Optional

from interllm.scene.geometry import point_in_polygon, r4
from interllm.scene.graph import Furniture, Room, SceneObject
from interllm.scene.procthor_db import counter_shape, load_database
from interllm.scene.procthor_format import (
    CHILD_ALIASES,
    WALL_MOUNTED,
    Conversion,
    ImportReport,
    category_of,
    required,
    type_name,
    xz_point,
)
from interllm.scene.repair import (
    CHILD_SLACK,
    check_parent_footprint,
    child_points,
    footprint_distance,
    place_stray_child,
)
from interllm.scene.shaped_furniture import arm_towards_wall, front_side, opposite, shaped_parts
from interllm.scene.validate import SceneValidationError

DEFAULT_FURNITURE_SIZE = (1.0, 0.6, 0.75)  # [m]
DEFAULT_OBJECT_SIZE = (0.1, 0.1, 0.1)  # [m]
CHILD_MARGIN = 0.01  # [m] a child moved onto its parent keeps this far inside the footprint
# furniture that closes over what it holds: a child below its top is inside it (placement "inside")
CLOSED_RECEPTACLES = {"fridge", "safe", "box"}
INSIDE_MARGIN = 0.05  # [m] a child whose box ends this far below its receptacle's top is inside it


def convert_objects(d: dict, cv: Conversion, rooms: dict[str, Room]
                    ) -> tuple[dict[str, Furniture], dict[str, SceneObject], dict[str, str], dict[str, str]]:
    """(furniture, objects, {our id: the file's id}, {our id: JSON path}) of ``objects[i]``: the furniture
    first, then their children (a stray child may go to any furniture). Without ``strict`` a child that
    cannot be repaired does not stop the others: all of them are listed in one error."""
    source, strict = cv.source, cv.opts.strict
    furniture: dict[str, Furniture] = {}
    objects: dict[str, SceneObject] = {}
    raw_ids: dict[str, str] = {}
    paths: dict[str, str] = {}
    kids: list[tuple[Furniture, dict, str]] = []
    for i, o in enumerate(d.get("objects", []) or []):
        p = f"$.objects[{i}]"
        cv.at = p
        f = _furniture(o, p, cv, rooms)
        if f is None:
            continue
        furniture[f.id] = f
        raw_ids[f.id], paths[f.id] = str(o["id"]), p
        kids += [(f, c, f"{p}.children[{j}]") for j, c in enumerate(_flatten(o.get("children", []) or []))]
    broken = []
    for f, c, cp in kids:
        cv.at = cp
        try:
            placed = _child(c, f, cp, cv, (furniture, rooms))
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


def _furniture(o: dict, p: str, cv: Conversion, rooms: dict[str, Room]) -> Optional[Furniture]:
    """The furniture of ProcTHOR object ``o`` (at JSON path ``p``), or None for a wall-mounted one.
    Without ``strict`` its footprint is checked against its children (``repair.check_parent_footprint``)."""
    cat, source, ids, rep, strict = cv.cat, cv.source, cv.ids, cv.rep, cv.opts.strict
    raw = str(required(o, "id", source, p))
    tname = type_name(o)
    fcat, known = category_of(tname, cat.furniture)
    if fcat in WALL_MOUNTED:
        rep.add(f"wall-mounted {fcat}: kept off the floor grid (not imported)", raw)
        for c in o.get("children", []) or []:
            rep.add("child of a wall-mounted object: dropped with it", str(c.get("id")))
        return None
    pos = required(o, "position", source, p)
    fx, fy = xz_point(pos, source, f"{p}.position")
    if not known:
        rep.add("furniture type not in the catalog: its own name as category", tname)
    csize = cat.furniture[fcat].size if known else None
    sx, sy, h = _box(o, csize, rep, "furniture", DEFAULT_FURNITURE_SIZE)
    if not strict:
        points = child_points(_flatten(o.get("children", []) or []))
        sx, sy = check_parent_footprint(o, p, (fx, fy), (sx, sy), csize, points, rep)
    top = float(pos.get("y", h / 2)) + h / 2 if isinstance(o.get("axisAlignedBoundingBox"), dict) else h
    room = next((rid for rid, r in rooms.items() if point_in_polygon(r.polygon, fx, fy)), None)
    if room is None:
        raise SceneValidationError(source, f"{p}.position", f"({fx}, {fy}) is inside no room's floorPolygon")
    desc = cat.furniture[fcat].description if known else ""
    box = (fx - sx / 2, fy - sy / 2, fx + sx / 2, fy + sy / 2)
    return Furniture(ids.new(fcat), fcat, room, (r4(fx), r4(fy)), (r4(sx), r4(sy), r4(top)), desc,
                     parts=_shape_parts(o, raw, box, rooms[room], rep), asset=database_asset(o))


def _flatten(children: list) -> list:
    """Children and their children (ProcTHOR nests at most one level in practice), in file order."""
    out = []
    for c in children:
        out.append(c)
        out.extend(_flatten(c.get("children", []) or []) if isinstance(c, dict) else [])
    return out


def _child(c: dict, f: Furniture, cp: str, cv: Conversion, world: tuple[dict, dict]
           ) -> Optional[tuple[str, SceneObject]]:
    """An object resting on furniture ``f``: on its top surface, inside its footprint; without ``strict``
    a child far off ``f`` goes to another surface, the floor, or is dropped (None). ``world``: (furniture,
    rooms) of the house; ``cp``: the child's JSON path."""
    cat, source, ids, rep, strict = cv.cat, cv.source, cv.ids, cv.rep, cv.opts.strict
    craw = str(required(c, "id", source, cp))
    tname = type_name(c)
    ocat, known = category_of(tname, cat.objects)
    ocat = CHILD_ALIASES.get(ocat, ocat)
    known = ocat in cat.objects
    if not known:
        rep.add("object type not in the catalog: its own name as category", tname)
    oc = cat.objects.get(ocat)
    sx, sy, sz = _box(c, oc.size if oc else None, rep, "object", DEFAULT_OBJECT_SIZE)
    if "position" in c:
        ox, oy = xz_point(c["position"], source, f"{cp}.position")
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
        moved = place_stray_child(craw, cp, (ox, oy), (sx, sy), world=world, cat=cat, new_id=ids.new, rep=rep)
        if moved is None:
            return None
        f = moved
    x0, y0, x1, y1 = _nearest_box(f, ox, oy)
    mx = min(sx / 2 + CHILD_MARGIN, (x1 - x0) / 2)
    my = min(sy / 2 + CHILD_MARGIN, (y1 - y0) / 2)
    nx, ny = min(max(ox, x0 + mx), x1 - mx), min(max(oy, y0 + my), y1 - my)
    if math.hypot(nx - ox, ny - oy) > 0.01 and not stray:
        rep.add("object not over its parent's top: moved onto it", craw)
    oid = ids.new(ocat)
    if _inside(c, f, sz):
        rep.add("object inside a closed receptacle (fridge, safe, box): kept and marked inside; no mission "
                "asks for it, since the robot does not open doors", craw)
        y = float(c["position"].get("y", 0.0))
        return oid, SceneObject(oid, ocat, f.id, (r4(nx), r4(ny), r4(max(y, sz / 2))), (r4(sx), r4(sy), r4(sz)),
                                oc.usage if oc else "", "inside",
                                unreachable=f"inside {f.id}, which is closed: the robot does not open doors",
                                asset=database_asset(c))
    high = f.surface_height >= cat.placement.high_min
    obj = SceneObject(oid, ocat, f.id, (r4(nx), r4(ny), r4(f.surface_height + sz / 2)),
                      (r4(sx), r4(sy), r4(sz)), oc.usage if oc else "", "high" if high else "front",
                      asset=database_asset(c))
    return oid, obj


def _nearest_box(f: Furniture, x: float, y: float) -> tuple[float, float, float, float]:
    """The rectangle of ``f`` (its footprint, or the part of an L or C counter) nearest (x, y) [m]."""
    return min(f.boxes, key=lambda b: math.hypot(max(b[0] - x, 0.0, x - b[2]), max(b[1] - y, 0.0, y - b[3])))


def _shape_parts(o: dict, tname: str, box: tuple[float, float, float, float], room: Room,
                 rep: ImportReport) -> tuple:
    """The parts of an L- or C-shaped counter (its ``assetId`` names the shape): the back arm opposite
    the side its ``rotation.y`` faces, an L's side arm towards the nearer wall; () for other furniture."""
    shape = counter_shape(str(o.get("assetId") or ""))
    if shape is None or shape[0] not in ("L", "C"):
        return ()
    back = opposite(front_side(float((o.get("rotation") or {}).get("y", 0.0))))
    arm = arm_towards_wall(box, back, room.bounds) if shape[0] == "L" else None
    parts = shaped_parts(shape[0], box, back, arm)
    if parts:
        rep.add(f"{shape[0]}-shaped counter: {len(parts)} boxes (back along {back}"
                + (f", arm along {arm}, the side nearer a wall" if arm else "") + "), its inner corner free floor",
                f"{tname} {o.get('assetId')}")
    return parts


def _inside(c: dict, f: Furniture, size_z: float) -> bool:
    """A child of a closed receptacle whose centre lies below the receptacle's top: inside it."""
    pos = c.get("position")
    if f.category not in CLOSED_RECEPTACLES or not isinstance(pos, dict):
        return False
    y = pos.get("y")
    return isinstance(y, (int, float)) and float(y) + size_z / 2 < f.surface_height - INSIDE_MARGIN


def database_asset(o: dict) -> str:
    """The object's ``assetId`` when ProcTHOR's asset database has it (recorded as the piece's ``asset``),
    else ""."""
    aid = str(o.get("assetId") or "")
    return aid if aid in load_database().assets else ""


def _box(o: dict, catalog_size, rep: ImportReport, what: str, default) -> tuple[float, float, float]:
    """(x extent, z extent, height) [m]: the file's axisAlignedBoundingBox, else the bounding box of its
    ``assetId`` in ProcTHOR's asset database (``procthor_db``), else the catalog size, the last two turned
    by rotation.y (the bounding box of the turned footprint), else ``default`` (reported)."""
    aabb = o.get("axisAlignedBoundingBox")
    if isinstance(aabb, dict) and isinstance(aabb.get("size"), dict):
        s = aabb["size"]
        return float(s["x"]), float(s["z"]), float(s["y"])
    asset = load_database().assets.get(str(o.get("assetId") or ""))
    size = asset.size if asset is not None else catalog_size
    if size is None:
        rep.add(f"{what} without a bounding box, type not in the catalog: default size {default}", str(o.get("id")))
        size = default
    yaw = math.radians(float((o.get("rotation") or {}).get("y", 0.0)))
    c, s_ = abs(math.cos(yaw)), abs(math.sin(yaw))
    return size[0] * c + size[1] * s_, size[0] * s_ + size[1] * c, size[2]
