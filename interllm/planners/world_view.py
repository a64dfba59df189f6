"""What a planner may see and do of the world: the written type both the MuJoCo world
(``interllm.sim.world.World``) and the symbolic test world (tests/helpers/planners.py) satisfy."""

from __future__ import annotations

from typing import Optional, Protocol

import numpy as np

from interllm.core.actions import Action, State
from interllm.core.results import ActionResult
from interllm.scene.graph import Mission, SceneGraph


class WorldView(Protocol):
    scene: SceneGraph  # the current scene graph (objects move when placed)
    state: State  # the high-level state
    clock: float  # [s] simulated mission time

    @property
    def robot_pose(self) -> tuple[float, float, float]:
        """Base pose x [m], y [m], yaw [rad]."""

    def reset(self, mission: Mission) -> State:
        """Start a mission: the initial scene, the robot at the mission's start, clock 0."""

    def execute(self, action: Action) -> ActionResult:
        """Run one action; advances ``clock``; applies its effects to ``state`` on success."""

    def anchor(self, furniture_id: str) -> tuple[float, float]:
        """The goal point [m] of a navigation to ``furniture_id``."""

    def measure_manipulation(self, action: Action) -> Optional[ActionResult]:
        """Ground truth of a manipulation's cost now, measured without changing the mission (None:
        it cannot be tried)."""

    def presumed_path(self, start_xy, furniture_id: str) -> Optional[np.ndarray]:
        """The path [N, 2] [m] the robot's map presumes from ``start_xy`` to the furniture, or None."""

    @property
    def map_version(self) -> int:
        """Which map ``presumed_path`` searches: equal numbers, equal paths (0: the initial map)."""
