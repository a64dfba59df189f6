"""Scene graph: typed records (rooms, doors, walls, furniture, objects) over a networkx graph.

Coordinates are metres in the world frame: x east, y north, z up. The floor is z = 0.
Node ids are stable strings used everywhere (prompts, plans, MuJoCo names, logs):
``room ids`` like ``kitchen_1``, ``furniture ids`` like ``dining_table_1``, ``object ids`` like
``apple_2``. Ids are unique across all three kinds.

Edges of the graph (``SceneGraph.graph``):
- ``(object, furniture)`` relation ``on``
- ``(furniture, room)`` relation ``in``
- ``(room, room)`` relation ``connected`` with attribute ``door`` (door id)
"""

from __future__ import annotations

import copy
import json
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, field, fields
from typing import Any

import networkx as nx

SCHEMA_VERSION = 1
# Record fields written to the scene file only when set, so that scenes without them keep their bytes.
OMITTED_WHEN_EMPTY = frozenset({"unreachable", "parts", "asset"})

Vec2 = tuple[float, float]
Vec3 = tuple[float, float, float]
Box2 = tuple[float, float, float, float]  # axis-aligned rectangle (x0, y0, x1, y1) [m]


@dataclass(frozen=True)
class Room:
    id: str
    type: str  # catalog room type, e.g. "kitchen"
    polygon: tuple[Vec2, ...]  # floor polygon, counter-clockwise [m]

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        xs = [p[0] for p in self.polygon]
        ys = [p[1] for p in self.polygon]
        return min(xs), min(ys), max(xs), max(ys)

    @property
    def center(self) -> Vec2:
        x0, y0, x1, y1 = self.bounds
        return ((x0 + x1) / 2, (y0 + y1) / 2)


@dataclass(frozen=True)
class Wall:
    id: str
    start: Vec2  # [m]
    end: Vec2  # [m]
    thickness: float  # [m]
    height: float  # [m]


@dataclass(frozen=True)
class Door:
    """A door opening in a wall between two rooms.

    ``center`` is the middle of the opening, ``axis`` the direction of the wall it sits in
    ("x": wall runs along x, so the robot crosses along y; "y": the converse). ``width`` is the
    opening width. ``open_fraction`` in [0, 1] is how far the leaf is open: 1.0 leaves the
    whole opening free; less than 1.0 leaves a leaf blocking ``(1 - open_fraction) * width`` of
    it, hinged at the ``hinge`` end ("low" = smaller coordinate along the axis, "high").
    The presumed map (what the planner believes) treats every door as fully open.
    """

    id: str
    rooms: tuple[str, str]
    center: Vec2
    axis: str  # "x" or "y"
    width: float
    open_fraction: float = 1.0
    hinge: str = "low"

    def leaf_segment(self) -> tuple[Vec2, Vec2] | None:
        """The part of the opening the leaf blocks, as a segment along the wall, or None."""
        blocked = (1.0 - self.open_fraction) * self.width
        if blocked <= 1e-9:
            return None
        cx, cy = self.center
        lo = -self.width / 2
        a, b = (lo, lo + blocked) if self.hinge == "low" else (-lo - blocked, -lo)
        if self.axis == "x":
            return (cx + a, cy), (cx + b, cy)
        return (cx, cy + a), (cx, cy + b)


@dataclass(frozen=True)
class Furniture:
    id: str
    category: str  # catalog furniture category, e.g. "dining_table"
    room: str  # room id
    center: Vec2  # footprint centre [m]
    size: Vec3  # footprint x, y extent and height of the top surface [m] (axis-aligned)
    description: str = ""
    unreachable: str = ""  # why the robot cannot reach it ("": reachable); kept, left out of missions
    # A furniture that is no box (an L- or C-shaped counter): the rectangles (x0, y0, x1, y1) [m] it
    # stands on, all inside ``footprint``; empty: the footprint box itself. Omitted from the file when
    # empty, so box-shaped scenes keep their bytes.
    parts: tuple[Box2, ...] = ()
    asset: str = ""  # the ProcTHOR asset it is (asset-database.json id; "": none, omitted then)

    @property
    def surface_height(self) -> float:
        return self.size[2]

    @property
    def footprint(self) -> Box2:
        """The bounding box (x0, y0, x1, y1) [m] of the footprint (the whole footprint when ``parts``
        is empty)."""
        cx, cy = self.center
        return cx - self.size[0] / 2, cy - self.size[1] / 2, cx + self.size[0] / 2, cy + self.size[1] / 2

    @property
    def boxes(self) -> tuple[Box2, ...]:
        """The rectangles the furniture occupies: ``parts``, or the footprint alone."""
        return self.parts or (self.footprint,)


@dataclass(frozen=True)
class SceneObject:
    id: str
    category: str  # catalog object category, e.g. "apple"
    furniture: str  # furniture id it rests on
    position: Vec3  # centre of the object's box [m]; z = surface height + size z / 2 (inside a receptacle: lower)
    size: Vec3  # box extents [m]
    usage: str = ""  # semantic usage text ("for eating breakfast")
    placement: str = "front"  # "front" | "deep" | "high" | "clutter": how hard it is to reach; "inside": in a closed receptacle
    unreachable: str = ""  # why the robot cannot reach it ("": reachable); kept, left out of missions
    asset: str = ""  # the ProcTHOR asset it is (asset-database.json id; "": none, omitted then)


class _FurnitureRooms(Mapping):
    """furniture id -> room id over a furniture dict, without copying it."""

    def __init__(self, furniture: dict[str, Furniture]) -> None:
        self._f = furniture

    def __getitem__(self, key: str) -> str:
        return self._f[key].room

    def __contains__(self, key: object) -> bool:
        return key in self._f

    def __iter__(self):
        return iter(self._f)

    def __len__(self) -> int:
        return len(self._f)


@dataclass
class SceneGraph:
    """A house: rooms, walls, doors, furniture and objects, with their spatial relations."""

    id: str
    seed: int
    rooms: dict[str, Room] = field(default_factory=dict)
    walls: dict[str, Wall] = field(default_factory=dict)
    doors: dict[str, Door] = field(default_factory=dict)
    furniture: dict[str, Furniture] = field(default_factory=dict)
    objects: dict[str, SceneObject] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)

    # ---- graph view -------------------------------------------------------------------
    @property
    def graph(self) -> nx.Graph:
        g = nx.Graph()
        for r in self.rooms.values():
            g.add_node(r.id, kind="room", type=r.type)
        for f in self.furniture.values():
            g.add_node(f.id, kind="furniture", category=f.category)
            g.add_edge(f.id, f.room, relation="in")
        for o in self.objects.values():
            g.add_node(o.id, kind="object", category=o.category)
            g.add_edge(o.id, o.furniture, relation="on")
        for d in self.doors.values():
            g.add_edge(d.rooms[0], d.rooms[1], relation="connected", door=d.id)
        return g

    def room_graph(self) -> nx.Graph:
        g = nx.Graph()
        g.add_nodes_from(self.rooms)
        for d in self.doors.values():
            g.add_edge(*d.rooms, door=d.id)
        return g

    # ---- queries -----------------------------------------------------------------------
    def room_of(self, node_id: str) -> str:
        """Room id of a furniture or an object."""
        if node_id in self.objects:
            node_id = self.objects[node_id].furniture
        return self.furniture[node_id].room

    def objects_on(self, furniture_id: str) -> list[SceneObject]:
        return [o for o in self.objects.values() if o.furniture == furniture_id]

    def furniture_in(self, room_id: str) -> list[Furniture]:
        return [f for f in self.furniture.values() if f.room == room_id]

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        b = [r.bounds for r in self.rooms.values()]
        return min(v[0] for v in b), min(v[1] for v in b), max(v[2] for v in b), max(v[3] for v in b)

    def copy(self) -> SceneGraph:
        return copy.deepcopy(self)

    @property
    def furniture_rooms(self) -> Mapping[str, str]:
        """Room id of every furniture id, as a read-only live view (for ``apply_effects``)."""
        return _FurnitureRooms(self.furniture)

    def move_object(self, object_id: str, furniture_id: str, position: Vec3 | None = None) -> None:
        """Put an object on a furniture (used to apply place effects to a copy of the scene)."""
        o = self.objects[object_id]
        if position is None:
            f = self.furniture[furniture_id]
            position = (f.center[0], f.center[1], f.surface_height + o.size[2] / 2)
        self.objects[object_id] = SceneObject(**{**asdict(o), "furniture": furniture_id,
                                                 "position": tuple(position)})

    # ---- prompt view -------------------------------------------------------------------
    def to_prompt_dict(self) -> dict:
        """The JSON scene graph the LLM sees: rooms > furniture > objects with semantics."""
        out: dict[str, Any] = {"rooms": []}
        for r in sorted(self.rooms.values(), key=lambda r: r.id):
            furn = []
            for f in sorted(self.furniture_in(r.id), key=lambda f: f.id):
                objs = [{"id": o.id, "category": o.category, "usage": o.usage}
                        for o in sorted(self.objects_on(f.id), key=lambda o: o.id)]
                furn.append({"id": f.id, "category": f.category, "objects": objs})
            out["rooms"].append({"id": r.id, "type": r.type, "furniture": furn})
        return out

    # ---- (de)serialisation -------------------------------------------------------------
    def to_dict(self) -> dict:
        def recs(d):  # the records are flat (str, number and tuple fields): no deep copy as in asdict
            return [{f.name: getattr(v, f.name) for f in fields(v)
                     if f.name not in OMITTED_WHEN_EMPTY or getattr(v, f.name)} for _, v in sorted(d.items())]

        return {
            "schema_version": SCHEMA_VERSION,
            "id": self.id,
            "seed": self.seed,
            "meta": self.meta,
            "rooms": recs(self.rooms),
            "walls": recs(self.walls),
            "doors": recs(self.doors),
            "furniture": recs(self.furniture),
            "objects": recs(self.objects),
        }

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=1, sort_keys=True) + "\n"

    @classmethod
    def from_dict(cls, d: dict) -> SceneGraph:
        def tup(v):
            return tuple(tup(x) for x in v) if isinstance(v, list) else v

        def build(rec_cls, items: Iterable[dict]):
            out = {}
            for it in items:
                rec = rec_cls(**{k: tup(v) for k, v in it.items()})
                out[rec.id] = rec
            return out

        return cls(
            id=d["id"],
            seed=d.get("seed", 0),
            meta=d.get("meta", {}),
            rooms=build(Room, d["rooms"]),
            walls=build(Wall, d.get("walls", [])),
            doors=build(Door, d.get("doors", [])),
            furniture=build(Furniture, d["furniture"]),
            objects=build(SceneObject, d["objects"]),
        )

    @classmethod
    def from_json(cls, text: str) -> SceneGraph:
        return cls.from_dict(json.loads(text))


@dataclass(frozen=True)
class Goal:
    """Ground truth for one command: which object categories satisfy it and where they go."""

    categories: tuple[str, ...]  # any of these categories satisfies the command
    target_furniture: tuple[str, ...]  # the objects must end on one of these furniture ids
    n_objects: int  # how many distinct objects the command asks for


@dataclass(frozen=True)
class Command:
    id: str  # e.g. "breakfast"
    text: str  # the natural-language command
    goal: Goal


@dataclass(frozen=True)
class Mission:
    id: str  # e.g. "m000"
    scene_id: str
    start: Vec3  # robot start pose x [m], y [m], yaw [rad]
    start_furniture: str  # furniture the robot starts next to (its high-level at())
    commands: tuple[Command, ...]

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> Mission:
        cmds = tuple(
            Command(id=c["id"], text=c["text"],
                    goal=Goal(categories=tuple(c["goal"]["categories"]),
                              target_furniture=tuple(c["goal"]["target_furniture"]),
                              n_objects=int(c["goal"]["n_objects"])))
            for c in d["commands"])
        return cls(id=d["id"], scene_id=d["scene_id"], start=tuple(d["start"]),
                   start_furniture=d["start_furniture"], commands=cmds)
