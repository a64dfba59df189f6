"""The state of one attempt at generating a house, shared by the generator's stages.

``generate_scene`` makes a ``BuildState`` per seed attempt; the floor plan (``floor_plans``), the
furniture (``furnishing``) and the objects (``surface_objects``, ``graded_objects``) fill it in that
order, all drawing from its one random generator, so the order of the stages fixes the house.
A stage that cannot complete raises ``Retry`` and the generator tries the next seed attempt.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from interllm.config import SceneConfig
from interllm.errors import UserError
from interllm.scene.asset_source import CatalogSizes
from interllm.scene.catalog import Catalog, CommandSpec
from interllm.scene.graph import Door, Furniture, Room, SceneObject, Wall


class SceneGenerationError(UserError, RuntimeError):
    """No valid scene for this scene config; the message says which requirement failed and what to change."""


class Retry(Exception):
    """This attempt failed; another seed attempt may succeed."""


@dataclass
class BuildState:
    """A house under construction: the catalog, the scene config, the attempt's random generator,
    the robot's base radius [m], and the rooms, walls, doors, furniture and objects placed so far."""

    cat: Catalog
    cfg: SceneConfig
    rng: np.random.Generator
    robot_radius: float
    rooms: dict[str, Room] = field(default_factory=dict)
    # room id -> the floor inside its walls (x0, y0, x1, y1) [m]
    interiors: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)
    walls: dict[str, Wall] = field(default_factory=dict)
    doors: dict[str, Door] = field(default_factory=dict)
    furniture: dict[str, Furniture] = field(default_factory=dict)
    objects: dict[str, SceneObject] = field(default_factory=dict)
    counters: dict[str, int] = field(default_factory=dict)
    k: int = 3  # graded design: easy instances each command gets (mission.objects_per_command)
    footprint_extra: float = 0.05  # [m] graded design: the robot's true footprint beyond robot_radius
    easy: set[str] = field(default_factory=set)  # graded design: the easy instances placed
    # graded design: furniture id -> the part of its surface kept free of objects (x0, y0, x1, y1) [m]
    keep_clear: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)
    # scene.assets: the size (and asset) of every piece drawn (None: the catalog's sizes)
    assets: CatalogSizes | None = None
    # furniture id -> the chairs reserved around it (scene.assets=procthor), seated once the targets stand
    pending_chairs: dict[str, list[Furniture]] = field(default_factory=dict)
    seated_chairs: int = 0  # chairs seated from pending_chairs (furniture beyond scene.n_furniture)

    def __post_init__(self) -> None:
        if self.assets is None:
            self.assets = CatalogSizes(self.cat)

    def new_id(self, kind: str) -> str:
        """The next id of ``kind``: ``<kind>_1``, ``<kind>_2``, ..."""
        self.counters[kind] = self.counters.get(kind, 0) + 1
        return f"{kind}_{self.counters[kind]}"

    def targets(self, cmd: CommandSpec) -> set[str]:
        """The furniture ids a command may deliver to: its target categories, in its room type if any."""
        return {f.id for f in self.furniture.values() if f.category in cmd.target_furniture
                and (cmd.target_room_type is None or self.rooms[f.room].type == cmd.target_room_type)}
