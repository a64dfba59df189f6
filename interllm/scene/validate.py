"""Scene validation: JSON Schema structure, then semantic checks, with precise error messages.

Every failure raises ``SceneValidationError`` whose message reads
``<source>: $.objects[3].furniture: unknown furniture 'desk_9'; ...`` (file, JSON path, problem).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import jsonschema
import networkx as nx

from interllm.scene.graph import SceneGraph
from interllm.scene.grid import rasterize
from interllm.scene.schema import scene_json_schema


class SceneValidationError(ValueError):
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
    """Structural check of a scene dict against ``scene_json_schema()``."""
    v = jsonschema.Draft202012Validator(scene_json_schema())
    errors = sorted(v.iter_errors(d), key=lambda e: (list(map(str, e.absolute_path)), e.message))
    if errors:
        e = errors[0]
        raise SceneValidationError(source, _json_path(e.absolute_path), e.message)


def _index(d: dict, key: str) -> dict[str, int]:
    return {rec["id"]: i for i, rec in enumerate(d.get(key, []))}


def validate_scene(scene: SceneGraph | dict, source: str = "<scene>", robot_radius: float = 0.25,
                   resolution: float = 0.05, check_reachability: bool = True) -> SceneGraph:
    """Validate a scene (object or dict); return it as a SceneGraph.

    Checks: JSON Schema; ids unique across rooms/furniture/objects/doors/walls; references
    (furniture.room, objects.furniture, doors.rooms) exist; objects lie over their furniture; rooms
    connected by doors; every room and furniture reachable on the presumed grid (robot_radius [m],
    resolution [m/cell]) from the largest free region, which must touch every room.
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
    for i, o in enumerate(d["objects"]):
        if o["furniture"] not in furn:
            hint = " (an object rests on exactly one furniture, not a room)" if o["furniture"] in rooms else ""
            raise SceneValidationError(source, f"$.objects[{i}].furniture",
                                       f"unknown furniture {o['furniture']!r}{hint}; valid furniture: "
                                       f"{sorted(furn)[:20]}")
        f = d["furniture"][furn[o["furniture"]]]
        (cx, cy), (sx, sy, _) = f["center"], f["size"]
        x, y = o["position"][0], o["position"][1]
        if not (cx - sx / 2 - 1e-6 <= x <= cx + sx / 2 + 1e-6 and cy - sy / 2 - 1e-6 <= y <= cy + sy / 2 + 1e-6):
            raise SceneValidationError(source, f"$.objects[{i}].position",
                                       f"({x}, {y}) is not over its furniture {f['id']!r} "
                                       f"(footprint centre {tuple(f['center'])}, size {sx} x {sy} m)")
    for i, dr in enumerate(d.get("doors", [])):
        for j, r in enumerate(dr["rooms"]):
            if r not in rooms:
                raise SceneValidationError(source, f"$.doors[{i}].rooms[{j}]",
                                           f"unknown room {r!r}; valid rooms: {sorted(rooms)}")
        if dr["rooms"][0] == dr["rooms"][1]:
            raise SceneValidationError(source, f"$.doors[{i}].rooms", "a door must join two different rooms")
    sg = SceneGraph.from_dict(d)
    g = sg.room_graph()
    if len(sg.rooms) > 1 and not nx.is_connected(g):
        comps = sorted((sorted(c) for c in nx.connected_components(g)), key=len)
        raise SceneValidationError(source, "$.doors",
                                   f"rooms are not connected by doors: {comps[0]} cannot be reached from "
                                   f"{comps[-1][:5]}; add a door between them")
    if check_reachability:
        from interllm.scene.generator import unreachable

        grid = rasterize(sg, resolution, robot_radius, doors="presumed")
        bad = unreachable(sg, grid, robot_radius)
        if bad:
            x = bad[0]
            key, idx = ("rooms", rooms[x]) if x in rooms else ("furniture", furn[x])
            raise SceneValidationError(source, f"$.{key}[{idx}]",
                                       f"{x!r} is not reachable by a robot of radius {robot_radius} m on the "
                                       f"presumed grid (also unreachable: {bad[1:6]}); leave at least "
                                       f"{2 * robot_radius} m of free floor around it and through its doors")
    return sg


def load_scene_file(path: str | Path, robot_radius: float = 0.25, resolution: float = 0.05,
                    check_reachability: bool = True) -> SceneGraph:
    """Read and validate a scene JSON file (our format; see ``importer`` for ProcTHOR houses)."""
    path = Path(path)
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise SceneValidationError(str(path), "$", "file not found") from None
    except json.JSONDecodeError as e:
        raise SceneValidationError(str(path), "$", f"invalid JSON at line {e.lineno} column {e.colno}: {e.msg}") \
            from None
    return validate_scene(d, str(path), robot_radius, resolution, check_reachability)
