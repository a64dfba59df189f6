"""``World``: one scene in the simulator (paper §III, §IV-B), the ``WorldView`` the planners use.

It composes the MuJoCo model of the house (``physics``: poses, contacts, the held object), the
robot's belief map (``belief``: presumed and true grids, blocked cells, search, anchors; kept
across the actions of a mission), a ``Navigator`` and a ``Manipulator``, and holds the current
scene graph (objects move when placed), the high-level ``state`` and the simulated mission
``clock`` [s]. ``execute(action)`` runs one action and is the one place where an action's effects
on ``state`` are applied (``core.actions.apply_effects``, on success only).
"""

from __future__ import annotations

from typing import Optional

import numpy as np

from interllm.config import SimConfig
from interllm.core.actions import Action, State, apply_effects
from interllm.core.results import ActionResult
from interllm.scene.graph import Mission, SceneGraph
from interllm.scene.grid import OccupancyGrid, rasterize
from interllm.sim.belief import BeliefMap
from interllm.sim.manipulator import Manipulator
from interllm.sim.measurements import MISSING, MeasurementStore, differences
from interllm.sim.navigator import Navigator
from interllm.sim.physics import MujocoWorld


class World:
    """A scene in MuJoCo with the robot, its belief map, state and simulated clock.

    scene: the house (copied; ``self.scene`` is the current one, objects move on place).
    sim_cfg: robot, control and cost parameters (``SimConfig``); defaults to ``SimConfig()``.
    grid_resolution: [m] per cell of the occupancy grids.
    grids: {"presumed", "true"} grids of this scene already made (the scenes stage's ``grid.npz``);
        rasterized here when not given.
    measurements: manipulation measurements on this scene's initial map already made (the scenes
        stage's ``measurements.json``, ``sim.measurements``); the world adds its own to it, so
        later missions use them too. A fresh store when not given.
    """

    def __init__(self, scene: SceneGraph, sim_cfg: Optional[SimConfig] = None, grid_resolution: float = 0.05,
                 grids: Optional[dict[str, OccupancyGrid]] = None,
                 measurements: Optional[MeasurementStore] = None) -> None:
        self.cfg = sim_cfg or SimConfig()
        self.cfg.validate()
        self.resolution = float(grid_resolution)
        self.initial_scene = scene.copy()
        self.scene = scene.copy()
        self.physics = MujocoWorld(self.scene, self.cfg, self.resolution)
        if grids is None:
            grids = {d: rasterize(self.scene, self.resolution, self.cfg.robot_radius, doors=d)
                     for d in ("true", "presumed")}
        self.belief = BeliefMap(grids["presumed"], grids["true"], self.initial_scene.furniture, self.cfg.robot_radius,
                                clearance=(self.cfg.clearance_cost, self.cfg.clearance_band),
                                footprint_extra=self.physics.contact_radius - self.cfg.robot_radius)
        self.navigator = Navigator(self.cfg, self.resolution)
        self.manipulator = Manipulator(self.cfg)
        self.state = State(None, None, None)
        self.clock = 0.0
        self.log: list[ActionResult] = []
        self._measured: dict[tuple, Optional[ActionResult]] = {}  # this mission's, on any map
        self.measurements = MeasurementStore(self.cfg, self.resolution, self.initial_scene)
        if measurements is not None:
            if diff := differences(self.measurements.made_with, measurements.made_with):
                raise ValueError(f"World(measurements=...) got a store made with another scene, simulator config or "
                                 f"code ({'; '.join(d[:200] for d in diff[:3])}); build it with this world's")
            self.measurements = measurements
        self.physics.reset(self.scene, (0.0, 0.0, 0.0))

    @property
    def robot_pose(self) -> tuple[float, float, float]:
        """Base pose x [m], y [m], yaw [rad]."""
        return self.physics.robot_pose

    def reset(self, mission: Mission) -> State:
        """Start a mission: the initial scene, a fresh belief map, the robot at ``mission.start``
        next to ``mission.start_furniture``, hand free, clock 0."""
        if mission.start_furniture not in self.initial_scene.furniture:
            raise ValueError(f"mission {mission.id!r}: start_furniture {mission.start_furniture!r} is not "
                             f"in scene {self.initial_scene.id!r}")
        self.scene = self.initial_scene.copy()
        self.belief.reset()
        self.state = State(mission.start_furniture, self.scene.furniture[mission.start_furniture].room, None)
        self.clock = 0.0
        self.log = []
        self._measured = {}
        self.physics.reset(self.scene, tuple(mission.start))
        return self.state

    @property
    def map_version(self) -> int:
        """Which presumed map ``presumed_path`` searches: 0 the initial one, else a number no other
        map of this world had (``BeliefMap.version``)."""
        return self.belief.version

    def anchor(self, furniture_id: str) -> tuple[float, float]:
        """The goal point [m] of a navigation to ``furniture_id`` (``BeliefMap.anchor``)."""
        return self.belief.anchor(furniture_id)

    def presumed_path(self, start_xy, furniture_id: str) -> Optional[np.ndarray]:
        """The paper's presumed path p^pre [N, 2] [m] on the current belief map, or None."""
        return self.belief.presumed_path(start_xy, furniture_id)

    def measure_manipulation(self, action: Action) -> Optional[ActionResult]:
        """Ground truth for a cost inference: the N_l-trial measurement of a pickup or place in the
        scene as it is now, with the robot at the furniture's anchor (where a navigate to it ends),
        the hand free for a pickup and holding the object for a place. A scratch measurement: the
        scene, state, clock, map and robot are untouched. None when the action cannot be tried
        (``Manipulator.measure``). Memoised per action, layout of the furniture's surroundings and
        map for the mission; on the initial map also in ``measurements``, across missions and stages."""
        if action.kind not in ("pickup", "place"):
            raise ValueError(f"measure_manipulation takes a pickup or place, got {action}")
        if action.furniture not in self.scene.furniture:
            return None
        exclude = (action.obj,) if action.kind == "place" else ()
        key = (str(action), self.manipulator.layout_key(self.scene, action.furniture, exclude))
        memo = (self.belief.version, key)  # a map a collision changed is measured on again
        if memo not in self._measured:
            self._measured[memo] = self._measure(action, key)
        return self._measured[memo]

    def _measure(self, action: Action, key: tuple) -> Optional[ActionResult]:
        """The measurement of ``action``: from ``measurements`` on the initial map (belief version 0,
        where a measurement depends on its key alone: ``sim.measurements``), else made now."""
        initial_map = self.belief.version == 0
        if initial_map and (kept := self.measurements.get(key)) is not MISSING:
            return kept
        result = self.manipulator.measure(self.belief, self.scene, action, self.anchor(action.furniture))
        if initial_map:
            self.measurements.put(key, result)
        return result

    def execute(self, action: Action) -> ActionResult:
        """Run one high-level action; advances ``clock`` by ``result.time`` and, on success,
        applies its effects to ``state`` (a failed action leaves ``state`` unchanged)."""
        t0 = self.clock
        if action.kind == "navigate":
            res = self.navigator.navigate(self.physics, self.belief, self.scene, t0, action)
            if not self.cfg.persistent_map:
                self.belief.forget()  # replanned around what it hit within this action only
        elif action.kind == "pickup":
            res = self.manipulator.pickup(self.physics, self.belief, self.scene, self.state, t0, action)
        else:
            res = self.manipulator.place(self.physics, self.belief, self.scene, self.state, t0, action)
        res.t_start = t0
        self.clock = t0 + res.time
        if res.success:
            self.state = apply_effects(action, self.state, self.scene.furniture_rooms, self.scene.objects)
        self.log.append(res)
        return res
