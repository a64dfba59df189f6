"""Scene validation: JSON Schema structure, then semantic checks, with precise error messages.

Every failure raises ``SceneValidationError`` whose message reads
``<source>: $.objects[3].furniture: unknown furniture 'desk_9'; ...`` (file, JSON path, problem).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Optional

import jsonschema
import networkx as nx
import numpy as np

from interllm.config import SCENE_LIMITS
from interllm.errors import UserError
from interllm.io import NAME_RULE, InputFileError, name_problem, read_json, shown
from interllm.scene.graph import SceneGraph
from interllm.scene.grid import rasterize
from interllm.scene.reachability import unreachable
from interllm.scene.schema import scene_json_schema


class SceneValidationError(UserError, ValueError):
    """A scene is invalid. Attributes: source (file), path (JSON path), problem (what is wrong)."""

    def __init__(self, source: str, path: str, problem: str):
        self.source, self.path, self.problem = source, path, problem
        super().__init__(f"{source}: {path}: {problem}")


def _json_path(parts) -> str:
    out = "$"
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else f".{p}"
    return out


def validate_dict(d: Any, source: str = "<scene>") -> None:
    """Structural check of a scene dict against ``scene_json_schema()``, and every number of its
    geometry finite (JSON Schema lets the NaN and Infinity that Python's json reads pass)."""
    check_scene_id(d, source)
    check_scene_size(d, source)
    v = jsonschema.Draft202012Validator(scene_json_schema())
    errors = sorted(v.iter_errors(d), key=lambda e: (list(map(str, e.absolute_path)), e.message))
    if errors:
        e = errors[0]
        raise SceneValidationError(source, _json_path(e.absolute_path), e.message)
    for key in ("rooms", "walls", "doors", "furniture", "objects"):
        bad = _non_finite(d.get(key, []), [key])
        if bad is not None:
            path, x = bad
            raise SceneValidationError(source, _json_path(path), f"{x} is not a number a scene can use; "
                                                                 f"write a finite number (in metres)")


def check_scene_id(d: Any, source: str, at: str = "$.id", fix: str = "rename it in the file") -> None:
    """The scene id names the scene's folders (data/scenes/<id>/): SceneValidationError unless it
    is one safe file name (``interllm.io.NAME_RULE``). A missing id is left to the schema."""
    if isinstance(d, dict) and "id" in d and (problem := name_problem(d["id"])) is not None:
        raise SceneValidationError(source, at, f"the scene id {shown(d['id'])} {problem}: it becomes a folder "
                                               f"name (data/scenes/<id>/), so it must be {NAME_RULE}; {fix}")


def check_scene_size(d: Any, source: str) -> None:
    """SceneValidationError when a scene has more rooms, furniture or objects than the stages accept
    (``interllm.config.SCENE_LIMITS``), before any work (or a schema check that would quote them all)."""
    if not isinstance(d, dict):
        return
    for key, limit in SCENE_LIMITS.items():
        items = d.get(key)
        if isinstance(items, list) and len(items) > limit:
            raise SceneValidationError(source, f"$.{key}", f"{len(items)} {key}: more than the {limit} the stages "
                                                           f"accept (interllm.config.SCENE_LIMITS, about 3 times the "
                                                           f"huge house); split the house or drop {key}")


def _non_finite(v: Any, at: list) -> Optional[tuple[list, float]]:
    """(JSON path, value) of the first NaN or infinite number in ``v``, or None."""
    if isinstance(v, float) and not math.isfinite(v):
        return at, v
    items = v.items() if isinstance(v, dict) else enumerate(v) if isinstance(v, list) else ()
    for k, x in items:
        bad = _non_finite(x, at + [k])
        if bad is not None:
            return bad
    return None


def _index(d: dict, key: str) -> dict[str, int]:
    return {rec["id"]: i for i, rec in enumerate(d.get(key, []))}


def _inside(poly: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Even-odd rule: which of ``pts`` (N x 2) lie inside polygon ``poly`` (K x 2)."""
    x, y = pts[:, 0:1], pts[:, 1:2]
    x0, y0 = poly[:, 0], poly[:, 1]
    x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
    crosses = (y0 > y) != (y1 > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
    return ((crosses & (x < xc)).sum(axis=1) % 2) == 1


def room_overlaps(d: dict, step: float = 0.05, min_area: float = 0.01) -> list[tuple[int, int, float, tuple]]:
    """Pairs of rooms whose floor polygons share more than ``min_area`` [m²] (sampled on a
    ``step`` [m] lattice of cell centres, so rooms that only share an edge do not count):
    (index a, index b, shared area [m²], a point in the shared part)."""
    polys = [np.asarray(r["polygon"], dtype=float) for r in d.get("rooms", [])]
    boxes = [(p[:, 0].min(), p[:, 1].min(), p[:, 0].max(), p[:, 1].max()) for p in polys]
    out = []
    for a in range(len(polys)):
        for b in range(a + 1, len(polys)):
            x0, y0 = max(boxes[a][0], boxes[b][0]), max(boxes[a][1], boxes[b][1])
            x1, y1 = min(boxes[a][2], boxes[b][2]), min(boxes[a][3], boxes[b][3])
            if x1 - x0 <= step or y1 - y0 <= step:
                continue
            xs = np.arange(x0 + step / 2, x1, step)
            ys = np.arange(y0 + step / 2, y1, step)
            pts = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
            both = _inside(polys[a], pts) & _inside(polys[b], pts)
            area = float(both.sum()) * step * step
            if area > min_area:
                px, py = pts[np.argmax(both)]
                out.append((a, b, area, (round(float(px), 2), round(float(py), 2))))
    return out


def validate_scene(scene: SceneGraph | dict, source: str = "<scene>", robot_radius: float = 0.25,
                   resolution: float = 0.05, check_reachability: bool = True) -> SceneGraph:
    """Validate a scene (object or dict); return it as a SceneGraph.

    Checks: JSON Schema; ids unique across rooms/furniture/objects/doors/walls; references
    (furniture.room, objects.furniture, doors.rooms) exist; objects lie over their furniture; rooms
    do not overlap; rooms connected by doors; every room and furniture reachable on the presumed grid (robot_radius [m],
    resolution [m/cell]) from the largest free region, which must touch every room (furniture marked
    ``unreachable``, as the ProcTHOR importer keeps it, is exempt).
    """
    d = json.loads(scene.to_json()) if isinstance(scene, SceneGraph) else scene
    validate_dict(d, source)
    seen: dict[str, str] = {}
    for key in ("rooms", "furniture", "objects", "doors", "walls"):
        for i, rec in enumerate(d.get(key, [])):
            if rec["id"] in seen:
                raise SceneValidationError(source, f"$.{key}[{i}].id",
                                           f"duplicate id {rec['id']!r} (already used in {seen[rec['id']]})")
            seen[rec["id"]] = f"$.{key}[{i}]"
    rooms, furn = _index(d, "rooms"), _index(d, "furniture")
    for i, f in enumerate(d["furniture"]):
        if f["room"] not in rooms:
            raise SceneValidationError(source, f"$.furniture[{i}].room",
                                       f"unknown room {f['room']!r}; valid rooms: {sorted(rooms)}")
    for i, f in enumerate(d["furniture"]):
        _check_parts(f, source, f"$.furniture[{i}].parts")
    for i, o in enumerate(d["objects"]):
        if o["furniture"] not in furn:
            hint = " (an object rests on exactly one furniture, not a room)" if o["furniture"] in rooms else ""
            raise SceneValidationError(source, f"$.objects[{i}].furniture",
                                       f"unknown furniture {o['furniture']!r}{hint}; valid furniture: "
                                       f"{sorted(furn)[:20]}")
        f = d["furniture"][furn[o["furniture"]]]
        (cx, cy), (sx, sy, _) = f["center"], f["size"]
        x, y = o["position"][0], o["position"][1]
        boxes = f.get("parts") or [(cx - sx / 2, cy - sy / 2, cx + sx / 2, cy + sy / 2)]
        if not any(b[0] - 1e-6 <= x <= b[2] + 1e-6 and b[1] - 1e-6 <= y <= b[3] + 1e-6 for b in boxes):
            shape = f"parts {[list(b) for b in boxes]}" if f.get("parts") else \
                f"footprint centre {tuple(f['center'])}, size {sx} x {sy} m"
            raise SceneValidationError(source, f"$.objects[{i}].position",
                                       f"({x}, {y}) is not over its furniture {f['id']!r} ({shape})")
    for i, dr in enumerate(d.get("doors", [])):
        for j, r in enumerate(dr["rooms"]):
            if r not in rooms:
                raise SceneValidationError(source, f"$.doors[{i}].rooms[{j}]",
                                           f"unknown room {r!r}; valid rooms: {sorted(rooms)}")
        if dr["rooms"][0] == dr["rooms"][1]:
            raise SceneValidationError(source, f"$.doors[{i}].rooms", "a door must join two different rooms")
    for a, b, area, at in room_overlaps(d):
        ra, rb = d["rooms"][a]["id"], d["rooms"][b]["id"]
        raise SceneValidationError(source, f"$.rooms[{b}].polygon",
                                   f"room {rb!r} overlaps room {ra!r} ($.rooms[{a}]) by about {area:.2f} m² "
                                   f"(for example at {at}); rooms must have disjoint floor polygons (they may "
                                   f"share walls)")
    sg = SceneGraph.from_dict(d)
    g = sg.room_graph()
    if len(sg.rooms) > 1 and not nx.is_connected(g):
        comps = sorted((sorted(c) for c in nx.connected_components(g)), key=len)
        raise SceneValidationError(source, "$.doors",
                                   f"rooms are not connected by doors: {comps[0]} cannot be reached from "
                                   f"{comps[-1][:5]}; add a door between them")
    if check_reachability:
        grid = rasterize(sg, resolution, robot_radius, doors="presumed")
        marked = {x for x, f in sg.furniture.items() if f.unreachable}  # kept by the importer, said why
        bad = [x for x in unreachable(sg, grid, robot_radius) if x not in marked]
        if bad:
            raise _unreachable_error(d, bad, source, robot_radius)
    return sg


def _unreachable_error(d: dict, bad: list[str], source: str, robot_radius: float) -> SceneValidationError:
    """The message for unreachable rooms or furniture (``bad``, ids): furniture outside every room is
    named as such, not only as unreachable."""
    rooms, furn = _index(d, "rooms"), _index(d, "furniture")
    polys = [np.asarray(r["polygon"], dtype=float) for r in d["rooms"]]
    for x in bad:
        f = d["furniture"][furn[x]] if x in furn else None
        if f is not None and not any(_inside(p, np.asarray([f["center"]], dtype=float))[0] for p in polys):
            return SceneValidationError(source, f"$.furniture[{furn[x]}].center",
                                        f"furniture {x!r} at {tuple(f['center'])} lies outside every room; "
                                        f"move it inside its room {f['room']!r} "
                                        f"($.rooms[{rooms[f['room']]}].polygon)")
    x = bad[0]
    key, idx = ("rooms", rooms[x]) if x in rooms else ("furniture", furn[x])
    others = f" (also unreachable: {bad[1:6]})" if len(bad) > 1 else ""
    return SceneValidationError(source, f"$.{key}[{idx}]",
                                f"{x!r} is not reachable by a robot of radius {robot_radius} m on the "
                                f"presumed grid{others}; leave at least {2 * robot_radius} m of free floor "
                                f"around it and through its doors")


def load_scene_file(path: str | Path, robot_radius: float = 0.25, resolution: float = 0.05,
                    check_reachability: bool = True) -> SceneGraph:
    """Read and validate a scene JSON file (our format; see ``importer`` for ProcTHOR houses)."""
    path = Path(path)
    try:
        d = read_json(path)
    except InputFileError as e:
        raise SceneValidationError(str(path), "$", e.problem) from None
    if looks_like_procthor(d):
        raise SceneValidationError(str(path), "$", f"this is a ProcTHOR house, not a scene in our format: convert it "
                                                   f"with `interllm scene import-procthor {path} --out my_scene/`, "
                                                   f"then use scene.import_path=my_scene/scene.json")
    return validate_scene(d, str(path), robot_radius, resolution, check_reachability)


def looks_like_procthor(d: Any) -> bool:
    """ProcTHOR's house JSON: rooms with ``floorPolygon`` or objects with ``assetId``."""
    if not isinstance(d, dict):
        return False
    rooms, objs = d.get("rooms"), d.get("objects")
    return (isinstance(rooms, list) and any(isinstance(r, dict) and "floorPolygon" in r for r in rooms)) or \
        (isinstance(objs, list) and any(isinstance(o, dict) and "assetId" in o for o in objs))


def looks_like_scene(d: Any) -> bool:
    """A scene in this project's format: its ``schema_version``, or rooms with a ``polygon`` and a
    ``furniture`` list."""
    if not isinstance(d, dict):
        return False
    rooms = d.get("rooms")
    return "schema_version" in d or (isinstance(d.get("furniture"), list) and isinstance(rooms, list)
                                     and any(isinstance(r, dict) and "polygon" in r for r in rooms))


def _check_parts(f: dict, source: str, at: str) -> None:
    """A furniture's ``parts`` are non-empty rectangles inside its bounding box (centre +- size / 2)."""
    (cx, cy), (sx, sy, _) = f["center"], f["size"]
    for j, (x0, y0, x1, y1) in enumerate(f.get("parts") or ()):
        if not (x0 < x1 and y0 < y1):
            raise SceneValidationError(source, f"{at}[{j}]", f"[{x0}, {y0}, {x1}, {y1}] is empty: a part is "
                                                             f"[x0, y0, x1, y1] with x0 < x1 and y0 < y1")
        tol = 1e-3
        if x0 < cx - sx / 2 - tol or x1 > cx + sx / 2 + tol or y0 < cy - sy / 2 - tol or y1 > cy + sy / 2 + tol:
            raise SceneValidationError(source, f"{at}[{j}]", f"[{x0}, {y0}, {x1}, {y1}] sticks out of the furniture's "
                                                             f"box (centre {tuple(f['center'])}, size {sx} x {sy} m); "
                                                             f"grow size or move the part")
