"""JSON Schema (draft 2020-12) of ``SceneGraph.to_dict()``: the scene file format."""

from __future__ import annotations

from interllm.io import NAME_MAX
from interllm.scene.graph import SCHEMA_VERSION

_ID = {"type": "string", "pattern": r"^[A-Za-z0-9_.\-]+$", "minLength": 1}
# the scene's own id names its folders (data/scenes/<id>/, candidates/<id>.json): one safe file
# name (interllm.io.NAME_RULE, which validation checks first, with the reason)
_SCENE_ID = {"type": "string", "pattern": r"^[A-Za-z0-9_][A-Za-z0-9_.\-]*$", "minLength": 1, "maxLength": NAME_MAX}
_NUM = {"type": "number"}
_POS = {"type": "number", "exclusiveMinimum": 0}
_VEC2 = {"type": "array", "items": _NUM, "minItems": 2, "maxItems": 2}
_VEC3 = {"type": "array", "items": _NUM, "minItems": 3, "maxItems": 3}
_SIZE3 = {"type": "array", "items": _POS, "minItems": 3, "maxItems": 3}
PLACEMENTS = ("front", "deep", "high", "clutter", "inside")
_WHY = {"type": "string", "description": "why the robot cannot reach it (absent: reachable)"}
_ASSET = {"type": "string", "minLength": 1,
          "description": "the ProcTHOR asset it is (its asset-database.json id; a generated piece has its size)"}


def _record(props: dict, required: list[str]) -> dict:
    return {"type": "object", "properties": props, "required": required, "additionalProperties": False}


def scene_json_schema() -> dict:
    """The JSON Schema of a scene file (``SceneGraph.to_json()``)."""
    room = _record({"id": _ID, "type": {"type": "string", "minLength": 1},
                    "polygon": {"type": "array", "items": _VEC2, "minItems": 3}},
                   ["id", "type", "polygon"])
    wall = _record({"id": _ID, "start": _VEC2, "end": _VEC2, "thickness": _POS, "height": _POS},
                   ["id", "start", "end", "thickness", "height"])
    door = _record({"id": _ID, "rooms": {"type": "array", "items": _ID, "minItems": 2, "maxItems": 2},
                    "center": _VEC2, "axis": {"enum": ["x", "y"]}, "width": _POS,
                    "open_fraction": {"type": "number", "minimum": 0, "maximum": 1},
                    "hinge": {"enum": ["low", "high"]}},
                   ["id", "rooms", "center", "axis", "width"])
    furniture = _record({"id": _ID, "category": {"type": "string", "minLength": 1}, "room": _ID,
                         "center": _VEC2, "size": _SIZE3, "description": {"type": "string"},
                         "unreachable": _WHY,
                         "parts": {"type": "array", "items": {"type": "array", "items": _NUM, "minItems": 4,
                                                              "maxItems": 4},
                                   "description": "the rectangles [x0, y0, x1, y1] of a footprint that is "
                                                  "no box (an L- or C-shaped counter), inside the box "
                                                  "center +- size / 2"},
                         "asset": _ASSET},
                        ["id", "category", "room", "center", "size"])
    obj = _record({"id": _ID, "category": {"type": "string", "minLength": 1}, "furniture": _ID,
                   "position": _VEC3, "size": _SIZE3, "usage": {"type": "string"},
                   "placement": {"enum": list(PLACEMENTS)}, "unreachable": _WHY, "asset": _ASSET},
                  ["id", "category", "furniture", "position", "size"])
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://interllm.local/schemas/scene.json",
        "title": "Inter-LLM scene graph",
        "type": "object",
        "properties": {
            "schema_version": {"const": SCHEMA_VERSION},
            "id": _SCENE_ID,
            "seed": {"type": "integer"},
            "meta": {"type": "object"},
            "rooms": {"type": "array", "items": room, "minItems": 1},
            "walls": {"type": "array", "items": wall},
            "doors": {"type": "array", "items": door},
            "furniture": {"type": "array", "items": furniture},
            "objects": {"type": "array", "items": obj},
        },
        "required": ["schema_version", "id", "rooms", "furniture", "objects"],
        "additionalProperties": False,
    }
