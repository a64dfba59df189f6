"""``World``: the one stateful wrapper around the MuJoCo model of a scene (paper §III, §IV-B).

It owns MjModel/MjData of the whole house with the robot, the robot's belief map
(``presumed_grid``: every door presumed open, plus cells blocked where collisions were felt;
kept across the actions of a mission), the reference ``true_grid`` (never used for planning),
the current scene graph (objects move when placed), the high-level ``state`` and the simulated
mission ``clock`` [s]. ``execute(action)`` runs navigate / pickup / place with the functions of
``navigation.py`` and ``manipulation.py`` and returns an ``ActionResult``.

Everything is kinematic and deterministic: poses are set and contacts queried
(``mj_kinematics`` + ``mj_collision``); no wall-clock time enters a result.
"""

from __future__ import annotations

import math
from typing import Optional

import mujoco
import numpy as np
from scipy import ndimage

from interllm.config import SimConfig
from interllm.core.actions import Action, State
from interllm.core.results import ActionResult, Trajectory
from interllm.planning.search import GridSearch
from interllm.scene.graph import Mission, SceneGraph
from interllm.scene.grid import OccupancyGrid, rasterize
from interllm.sim.build import build_world_spec
from interllm.sim.robot import ARM_JOINTS, BASE_GEOM, BASE_JOINTS, GRIP_SITE, TUCK

ANCHOR_RINGS = (0.25, 0.5, 1.0)  # [m] beyond the robot radius: how far an anchor may be from a footprint


def footprint_distance(xy: np.ndarray, fp: tuple[float, float, float, float]) -> np.ndarray:
    """Distance [m] from points (..., 2) to an axis-aligned rectangle (x0, y0, x1, y1) (0 inside)."""
    x0, y0, x1, y1 = fp
    dx = np.maximum(np.maximum(x0 - xy[..., 0], 0.0), xy[..., 0] - x1)
    dy = np.maximum(np.maximum(y0 - xy[..., 1], 0.0), xy[..., 1] - y1)
    return np.hypot(dx, dy)


class World:
    """A scene in MuJoCo with the robot, its belief map, state and simulated clock.

    scene: the house (copied; ``self.scene`` is the current one, objects move on place).
    sim_cfg: robot, control and cost parameters (``SimConfig``); defaults to ``SimConfig()``.
    grid_resolution: [m] per cell of the occupancy grids.
    """

    def __init__(self, scene: SceneGraph, sim_cfg: Optional[SimConfig] = None, grid_resolution: float = 0.05):
        self.cfg = sim_cfg or SimConfig()
        self.cfg.validate()
        self.resolution = float(grid_resolution)
        self.initial_scene = scene.copy()
        self.scene = scene.copy()
        self.spec = build_world_spec(self.scene, robot=True, sim_cfg=self.cfg)
        self.model = self.spec.compile()
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._base_qadr = np.array([m.jnt_qposadr[m.joint(n).id] for n in BASE_JOINTS])
        self._arm_qadr = np.array([m.jnt_qposadr[m.joint(n).id] for n in ARM_JOINTS])
        self._grip_site = m.site(GRIP_SITE).id
        self.base_geom = m.geom(BASE_GEOM).id
        # The grid inflates obstacles cell by cell, which can be up to half a cell diagonal
        # optimistic; shrink the base's contact cylinder by that much so that a cell the map
        # calls free never touches a wall or furniture (door leaves are what the map misses).
        self.contact_radius = self.cfg.robot_radius - self.resolution * math.sqrt(0.5) - 1e-3
        m.geom_size[self.base_geom][0] = self.contact_radius
        # The house model is only asked for the base's contacts (base_contacts); objects resting on
        # furniture and the arm would otherwise add contacts to every mj_collision for nothing.
        static = {"wall", "door", "furniture", "floor"}
        for g in range(m.ngeom):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
            if g != self.base_geom and name.partition("/")[0] not in static:
                m.geom_contype[g] = m.geom_conaffinity[g] = 0
        # static obstacles the base may hit: geom id -> (kind, scene id)
        self.obstacle_geoms: dict[int, tuple[str, str]] = {}
        for g in range(m.ngeom):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
            kind, _, sid = name.partition("/")
            if kind in ("wall", "door", "furniture") and sid:
                self.obstacle_geoms[g] = (kind, sid)
        self._obj_qadr = {oid: int(m.jnt_qposadr[m.joint(f"object/{oid}").id]) for oid in self.scene.objects}
        self.true_grid: OccupancyGrid = rasterize(self.scene, self.resolution, self.cfg.robot_radius, doors="true")
        self._initial_presumed = rasterize(self.scene, self.resolution, self.cfg.robot_radius, doors="presumed")
        lab, n = ndimage.label(self._initial_presumed.free, structure=np.ones((3, 3), dtype=bool))
        sizes = np.bincount(lab.ravel())[1:]
        self._main_component = (lab == (int(np.argmax(sizes)) + 1)) if n else np.zeros_like(lab, dtype=bool)
        self._anchors: dict[str, tuple[float, float]] = {}
        self.presumed_grid: OccupancyGrid = self._initial_presumed.copy()
        self.search = GridSearch(self.presumed_grid)
        self.state = State(None, None, None)
        self.clock = 0.0
        self.held_offset: Optional[tuple[np.ndarray, np.ndarray]] = None  # (pos, quat) in the grip frame
        self.log: list[ActionResult] = []
        self._ik_cache: dict = {}  # manipulation: (furniture, objects) -> IK model (see manipulation.py)
        self._set_arm(TUCK)
        self._place_objects()
        self.forward()

    # ---- low-level pose access ---------------------------------------------------------
    @property
    def robot_pose(self) -> tuple[float, float, float]:
        """Base pose x [m], y [m], yaw [rad]."""
        q = self.data.qpos[self._base_qadr]
        return float(q[0]), float(q[1]), float(q[2])

    @property
    def arm_q(self) -> np.ndarray:
        """Arm joint angles [rad] (6)."""
        return self.data.qpos[self._arm_qadr].copy()

    def set_base(self, x: float, y: float, yaw: float) -> None:
        self.data.qpos[self._base_qadr] = (x, y, yaw)

    def _set_arm(self, q) -> None:
        self.data.qpos[self._arm_qadr] = np.asarray(q, dtype=float)

    def set_arm(self, q) -> None:
        self._set_arm(q)
        self.forward()

    def forward(self) -> None:
        """Update kinematics and move a held object with the gripper."""
        mujoco.mj_kinematics(self.model, self.data)
        if self.state.holding is not None and self.held_offset is not None:
            self._attach_update(self.state.holding)
            mujoco.mj_kinematics(self.model, self.data)

    def grip_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Gripper site position [m] and rotation matrix (3x3) in the world frame."""
        return self.data.site_xpos[self._grip_site].copy(), self.data.site_xmat[self._grip_site].reshape(3, 3).copy()

    def object_pose(self, object_id: str) -> tuple[np.ndarray, np.ndarray]:
        """Object position [m] and quaternion (w, x, y, z) from its free joint."""
        a = self._obj_qadr[object_id]
        return self.data.qpos[a:a + 3].copy(), self.data.qpos[a + 3:a + 7].copy()

    def set_object_pose(self, object_id: str, pos, quat=(1.0, 0.0, 0.0, 0.0)) -> None:
        a = self._obj_qadr[object_id]
        self.data.qpos[a:a + 3] = pos
        self.data.qpos[a + 3:a + 7] = quat

    def _place_objects(self) -> None:
        for oid, o in self.scene.objects.items():
            self.set_object_pose(oid, o.position)

    def attach(self, object_id: str) -> None:
        """Grasp: keep the object's current pose relative to the gripper site from now on."""
        p_s, r_s = self.grip_pose()
        p_o, q_o = self.object_pose(object_id)
        q_s = np.zeros(4)
        mujoco.mju_mat2Quat(q_s, r_s.ravel())
        q_rel = np.zeros(4)
        q_sinv = np.zeros(4)
        mujoco.mju_negQuat(q_sinv, q_s)
        mujoco.mju_mulQuat(q_rel, q_sinv, q_o)
        self.held_offset = (r_s.T @ (p_o - p_s), q_rel)

    def _attach_update(self, object_id: str) -> None:
        p_s, r_s = self.grip_pose()
        off, q_rel = self.held_offset  # type: ignore[misc]
        q_s = np.zeros(4)
        mujoco.mju_mat2Quat(q_s, r_s.ravel())
        q = np.zeros(4)
        mujoco.mju_mulQuat(q, q_s, q_rel)
        self.set_object_pose(object_id, p_s + r_s @ off, q)

    def base_contacts(self) -> list[tuple[int, np.ndarray, str, str]]:
        """Contacts of the robot base with walls / door leaves / furniture at the current
        configuration: (geom id, contact point [m], kind, scene id). Call after ``forward()``."""
        mujoco.mj_collision(self.model, self.data)
        n = self.data.ncon
        if n == 0:
            return []
        c = self.data.contact
        g1, g2 = c.geom1[:n], c.geom2[:n]  # static geoms may touch each other too: keep the base's
        hit = np.flatnonzero((g1 == self.base_geom) | (g2 == self.base_geom))
        out = []
        for i in hit.tolist():
            other = int(g2[i]) if int(g1[i]) == self.base_geom else int(g1[i])
            if other in self.obstacle_geoms:
                kind, sid = self.obstacle_geoms[other]
                out.append((other, c.pos[i].copy(), kind, sid))
        return out

    def sample(self, t: float) -> tuple[float, np.ndarray, np.ndarray]:
        """(time, base pose [3], arm q [6]) for a trajectory sample."""
        return t, np.array(self.robot_pose), self.arm_q

    @staticmethod
    def make_trajectory(samples) -> Trajectory:
        if not samples:
            return Trajectory.empty(len(ARM_JOINTS), ARM_JOINTS)
        t = np.array([s[0] for s in samples], dtype=float)
        base = np.array([s[1] for s in samples], dtype=float)
        joints = np.array([s[2] for s in samples], dtype=float)
        return Trajectory(t=t, base=base, joints=joints, joint_names=ARM_JOINTS)

    # ---- mission-level API -------------------------------------------------------------
    def reset(self, mission: Mission) -> State:
        """Start a mission: the initial scene, a fresh belief map, the robot at ``mission.start``
        next to ``mission.start_furniture``, hand free, clock 0."""
        if mission.start_furniture not in self.initial_scene.furniture:
            raise ValueError(f"mission {mission.id!r}: start_furniture {mission.start_furniture!r} is not "
                             f"in scene {self.initial_scene.id!r}")
        self.scene = self.initial_scene.copy()
        mujoco.mj_resetData(self.model, self.data)
        self.presumed_grid = self._initial_presumed.copy()
        self.search = GridSearch(self.presumed_grid)
        self.state = State(mission.start_furniture, self.scene.furniture[mission.start_furniture].room, None)
        self.held_offset = None
        self.clock = 0.0
        self.log = []
        self.set_base(*mission.start)
        self._set_arm(TUCK)
        self._place_objects()
        self.forward()
        return self.state

    def anchor(self, furniture_id: str) -> tuple[float, float]:
        """Goal point [m] for navigating to a furniture: the free cell of the initial presumed
        map next to it (within robot_radius + 0.25 m of its footprint, widening to 0.5 and 1 m
        if needed), in the largest connected free region, closest to the furniture centre."""
        if furniture_id in self._anchors:
            return self._anchors[furniture_id]
        if furniture_id not in self.scene.furniture:
            raise KeyError(f"unknown furniture {furniture_id!r}; valid: {sorted(self.scene.furniture)}")
        f = self.scene.furniture[furniture_id]
        g = self._initial_presumed
        cells = np.argwhere(g.free & self._main_component)
        if len(cells) == 0:
            cells = np.argwhere(g.free)
        pts = g.cell_to_world(cells)
        d_fp = footprint_distance(pts, f.footprint)
        for ring in ANCHOR_RINGS:
            ok = d_fp <= self.cfg.robot_radius + ring
            if ok.any():
                cand = pts[ok]
                dc = np.hypot(cand[:, 0] - f.center[0], cand[:, 1] - f.center[1])
                k = int(np.argmin(np.round(dc, 9)))
                a = (float(cand[k, 0]), float(cand[k, 1]))
                self._anchors[furniture_id] = a
                return a
        raise ValueError(f"furniture {furniture_id!r} has no free cell within "
                         f"{self.cfg.robot_radius + ANCHOR_RINGS[-1]:.2f} m of its footprint; the robot cannot "
                         f"reach it (check the scene layout or sim.robot_radius)")

    def presumed_path(self, start_xy, furniture_id: str) -> Optional[np.ndarray]:
        """Shortest path [N, 2] on the current belief map from ``start_xy`` to the furniture's
        anchor, or None. This is the paper's presumed path p^pre."""
        return self.search.path(start_xy, self.anchor(furniture_id))

    def block_cells(self, xy_center, radius: float) -> int:
        """Mark belief cells within ``radius`` [m] of a point as occupied; returns how many changed."""
        g = self.presumed_grid
        rc = g.world_to_cell(np.asarray(xy_center, dtype=float))
        rad = int(math.ceil(radius / g.resolution))
        r0, r1 = max(0, rc[0] - rad), min(g.shape[0], rc[0] + rad + 1)
        c0, c1 = max(0, rc[1] - rad), min(g.shape[1], rc[1] + rad + 1)
        if r0 >= r1 or c0 >= c1:
            return 0
        rr, cc = np.mgrid[r0:r1, c0:c1]
        ctr = g.cell_to_world(np.stack([rr, cc], -1))
        m = np.hypot(ctr[..., 0] - xy_center[0], ctr[..., 1] - xy_center[1]) <= radius
        before = int(g.occupied[r0:r1, c0:c1].sum())
        g.occupied[r0:r1, c0:c1] |= m
        return int(g.occupied[r0:r1, c0:c1].sum()) - before

    def block_geom(self, geom_id: int, inflate: float) -> int:
        """Mark the belief cells of a box geom's footprint grown by ``inflate`` [m] as occupied."""
        g = self.presumed_grid
        pos = self.data.geom_xpos[geom_id]
        mat = self.data.geom_xmat[geom_id].reshape(3, 3)
        half = self.model.geom_size[geom_id]
        ext = np.abs(mat[:2, :2]) @ half[:2]  # AABB half extents in x, y
        x0, y0 = pos[0] - ext[0] - inflate, pos[1] - ext[1] - inflate
        x1, y1 = pos[0] + ext[0] + inflate, pos[1] + ext[1] + inflate
        c0, r0 = g.world_to_cell(np.array([x0, y0]))[::-1]
        c1, r1 = g.world_to_cell(np.array([x1, y1]))[::-1]
        r0, c0 = max(0, r0), max(0, c0)
        r1, c1 = min(g.shape[0] - 1, r1), min(g.shape[1] - 1, c1)
        if r0 > r1 or c0 > c1:
            return 0
        before = int(g.occupied[r0:r1 + 1, c0:c1 + 1].sum())
        g.occupied[r0:r1 + 1, c0:c1 + 1] = True
        return int(g.occupied[r0:r1 + 1, c0:c1 + 1].sum()) - before

    def execute(self, action: Action) -> ActionResult:
        """Run one high-level action; advances ``clock`` by ``result.time`` and, on success,
        applies its effects to ``state`` (a failed action leaves ``state`` unchanged)."""
        from interllm.sim.manipulation import execute_pickup, execute_place
        from interllm.sim.navigation import execute_navigate

        fn = {"navigate": execute_navigate, "pickup": execute_pickup, "place": execute_place}[action.kind]
        t0 = self.clock
        res = fn(self, action)
        res.t_start = t0
        self.clock = t0 + res.time
        self.log.append(res)
        return res
