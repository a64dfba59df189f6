"""Semantic catalog: room types, furniture and object categories, household commands, size presets.

The catalog is data (``interllm/scene/catalog/*.json``); this module loads it into frozen records,
checks its internal consistency (every name it references exists) and answers the questions the
generator and the mission sampler ask ("which furniture may hold a mug?", "which furniture ids of
this scene satisfy the breakfast command?").

Units: sizes in metres [m].
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import Any, Optional

from interllm.config import SceneConfig
from interllm.errors import UserError
from interllm.scene.graph import SceneGraph

CATALOG_DIR = Path(__file__).with_name("catalog")


class CatalogError(UserError, ValueError):
    """The catalog data is inconsistent, or a name is not in it (the message lists valid names)."""


@dataclass(frozen=True)
class FurnitureCategory:
    name: str
    size: tuple[float, float, float]  # along the wall [m], depth [m], surface height [m]
    mount: str  # "wall" | "center"
    holds: tuple[str, ...]  # object categories that may rest on it
    description: str = ""


@dataclass(frozen=True)
class ObjectCategory:
    name: str
    usage: str
    size: tuple[float, float, float]  # box extents x, y, z [m]


@dataclass(frozen=True)
class RoomType:
    name: str
    space_rank: int  # larger rooms are given to lower ranks
    core: tuple[str, ...]  # furniture placed first, in order
    optional: tuple[tuple[str, float], ...]  # (furniture category, weight)


@dataclass(frozen=True)
class CommandSpec:
    id: str
    text: str
    categories: tuple[str, ...]  # object categories that satisfy the command
    target_furniture: tuple[str, ...]  # furniture categories receiving the objects
    target_room_type: Optional[str]  # room type of the target furniture (None = any room)
    paper: bool = False  # one of the paper's three commands

    def resolve_targets(self, scene: SceneGraph) -> tuple[str, ...]:
        """Furniture ids of ``scene`` that satisfy this command's target (sorted); furniture marked
        unreachable is none."""
        out = []
        for f in scene.furniture.values():
            if f.category not in self.target_furniture or f.unreachable:
                continue
            if self.target_room_type is not None and scene.rooms[f.room].type != self.target_room_type:
                continue
            out.append(f.id)
        return tuple(sorted(out))

    def valid_objects(self, scene: SceneGraph) -> tuple[str, ...]:
        """Object ids that satisfy the command, are not already on one of its targets and are not
        marked unreachable."""
        targets = set(self.resolve_targets(scene))
        return tuple(sorted(o.id for o in scene.objects.values()
                            if o.category in self.categories and o.furniture not in targets and not o.unreachable))


@dataclass(frozen=True)
class Placement:
    """Thresholds of object placements [m] (see furniture.json)."""

    front_edge_max: float  # a "front" object's centre is this close to a free edge
    deep_edge_min: float  # a "deep" object's centre is at least this far from every free edge
    high_min: float  # surfaces at least this high are "high"
    clutter_gap_max: float  # a "clutter" object's box is this close to a neighbour's box
    surface_margin: float  # object boxes stay this far inside the surface
    object_gap: float  # minimum gap between object boxes
    free_ring: float  # free floor kept around every furniture
    door_clear_depth: float  # free floor kept in front of every door opening


@dataclass(frozen=True)
class Catalog:
    furniture: dict[str, FurnitureCategory]
    objects: dict[str, ObjectCategory]
    rooms: dict[str, RoomType]
    commands: tuple[CommandSpec, ...]
    program: tuple[str, ...]
    extra_rooms: tuple[str, ...]
    presets: dict[str, dict[str, int]]
    placement: Placement
    min_objects_per_command: int

    def command(self, command_id: str) -> CommandSpec:
        for c in self.commands:
            if c.id == command_id:
                return c
        raise CatalogError(f"unknown command id {command_id!r}; valid ids: {[c.id for c in self.commands]}")

    def paper_commands(self) -> tuple[CommandSpec, ...]:
        return tuple(c for c in self.commands if c.paper)

    def furniture_for(self, object_category: str) -> tuple[str, ...]:
        """Furniture categories that may hold ``object_category``."""
        return tuple(n for n, f in self.furniture.items() if object_category in f.holds)

    def room_types_for_house(self, n_rooms: int) -> list[str]:
        """Room types of a house of ``n_rooms`` rooms: the program, then the extras cycled."""
        out = list(self.program[:n_rooms])
        i = 0
        while len(out) < n_rooms:
            out.append(self.extra_rooms[i % len(self.extra_rooms)])
            i += 1
        return out

    def preset(self, name: str) -> dict[str, int]:
        if name not in self.presets:
            raise CatalogError(f"unknown scene size preset {name!r}; valid presets: {sorted(self.presets)}")
        return dict(self.presets[name])

    def scene_config(self, name: str, **overrides: Any) -> SceneConfig:
        """A validated SceneConfig for a size preset, e.g. ``scene_config("tiny", seed=3)``."""
        cfg = replace(SceneConfig(name=name), **self.preset(name), **overrides)
        cfg.validate()
        return cfg


def _load(name: str) -> dict:
    path = CATALOG_DIR / name
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as e:
        raise CatalogError(f"{path}:{e.lineno}:{e.colno}: invalid JSON: {e.msg}") from None


def _check_names(names, valid, where: str) -> None:
    for n in names:
        if n not in valid:
            raise CatalogError(f"{where}: unknown name {n!r}; valid names: {sorted(valid)}")


def build_catalog(furniture: dict, objects: dict, rooms: dict, commands: dict, presets: dict) -> Catalog:
    """Build and cross-check a catalog from the five JSON documents (see ``catalog/*.json``)."""
    objs = {n: ObjectCategory(n, v["usage"], tuple(float(x) for x in v["size"]))
            for n, v in objects["categories"].items()}
    furn = {}
    for n, v in furniture["categories"].items():
        if v["mount"] not in ("wall", "center"):
            raise CatalogError(f"furniture.json: categories.{n}.mount must be 'wall' or 'center'")
        _check_names(v["holds"], objs, f"furniture.json: categories.{n}.holds")
        furn[n] = FurnitureCategory(n, tuple(float(x) for x in v["size"]), v["mount"], tuple(v["holds"]),
                                    v.get("description", ""))
    rtypes = {}
    for n, v in rooms["types"].items():
        _check_names(v["core"], furn, f"rooms.json: types.{n}.core")
        _check_names(v["optional"], furn, f"rooms.json: types.{n}.optional")
        rtypes[n] = RoomType(n, int(v["space_rank"]), tuple(v["core"]),
                             tuple((k, float(w)) for k, w in v["optional"].items()))
    _check_names(rooms["program"], rtypes, "rooms.json: program")
    _check_names(rooms["extra"], rtypes, "rooms.json: extra")
    cmds = []
    for i, c in enumerate(commands["commands"]):
        _check_names(c["categories"], objs, f"commands.json: commands[{i}].categories")
        _check_names(c["target"]["furniture"], furn, f"commands.json: commands[{i}].target.furniture")
        rt = c["target"].get("room_type")
        if rt is not None:
            _check_names([rt], rtypes, f"commands.json: commands[{i}].target.room_type")
        cmds.append(CommandSpec(c["id"], c["text"], tuple(c["categories"]), tuple(c["target"]["furniture"]),
                                rt, bool(c.get("paper", False))))
    ids = [c.id for c in cmds]
    if len(set(ids)) != len(ids):
        raise CatalogError(f"commands.json: duplicate command ids in {ids}")
    p = furniture["placement"]
    return Catalog(
        furniture=furn, objects=objs, rooms=rtypes, commands=tuple(cmds),
        program=tuple(rooms["program"]), extra_rooms=tuple(rooms["extra"]),
        presets={k: {kk: int(vv) for kk, vv in v.items()} for k, v in presets.items() if not k.startswith("_")},
        placement=Placement(**{k: float(v) for k, v in p.items()}),
        min_objects_per_command=int(commands["min_objects_per_command"]),
    )


@lru_cache(maxsize=1)
def load_catalog() -> Catalog:
    """The packaged catalog (cached)."""
    return build_catalog(_load("furniture.json"), _load("objects.json"), _load("rooms.json"),
                         _load("commands.json"), _load("presets.json"))


def scene_config(name: str, **overrides: Any) -> SceneConfig:
    """Shortcut for ``load_catalog().scene_config(name, **overrides)``."""
    return load_catalog().scene_config(name, **overrides)
