"""``MujocoWorld``: the MuJoCo model of a whole house with the robot, and its poses and contacts.

Everything is kinematic and deterministic: poses are set and contacts queried (``mj_kinematics``
+ ``mj_collision``); no wall-clock time enters a result. A held object keeps its pose in the
gripper frame (``attach`` / ``release``) and moves with the hand on every ``forward``.
"""

from __future__ import annotations

import math
from typing import Optional

import mujoco
import numpy as np

from interllm.config import SimConfig
from interllm.core.results import Trajectory
from interllm.scene.graph import SceneGraph
from interllm.sim.build import build_world_spec
from interllm.sim.robot import BASE_GEOM, BASE_JOINTS, GRIP_SITE, robot_parts


def contact_radius(sim_cfg: SimConfig, resolution: float) -> float:
    """Radius [m] of the base's contact cylinder: ``sim.footprint_radius`` (the true footprint,
    which hits whatever the driven path passes closer to than that), or by default the map's
    radius less half a cell diagonal: the grid inflates obstacles cell by cell, up to that much
    optimistically, so a cell the map calls free then never touches a wall or furniture and only
    door leaves (which the presumed map does not hold) are hit."""
    if sim_cfg.footprint_radius is not None:
        return float(sim_cfg.footprint_radius)
    return sim_cfg.robot_radius - resolution * math.sqrt(0.5) - 1e-3


class MujocoWorld:
    """MjModel/MjData of ``scene`` with the robot (``sim_cfg``), on grids of ``resolution`` [m]."""

    def __init__(self, scene: SceneGraph, sim_cfg: SimConfig, resolution: float) -> None:
        self.spec = build_world_spec(scene, robot=True, sim_cfg=sim_cfg)
        self.parts = robot_parts(sim_cfg.robot)
        # set before compiling: the broad phase bounds each geom by its compiled size (geom_rbound)
        self.contact_radius = contact_radius(sim_cfg, resolution)
        self.spec.geom(BASE_GEOM).size[0] = self.contact_radius
        self.model = self.spec.compile()
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._base_qadr = np.array([m.jnt_qposadr[m.joint(n).id] for n in BASE_JOINTS])
        self._arm_qadr = np.array([m.jnt_qposadr[m.joint(n).id] for n in self.parts.joints])
        self._grip_site = m.site(GRIP_SITE).id
        self.base_geom = m.geom(BASE_GEOM).id
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
        self._obj_qadr = {oid: int(m.jnt_qposadr[m.joint(f"object/{oid}").id]) for oid in scene.objects}
        self.held: Optional[str] = None  # the object in the gripper
        self.held_offset: Optional[tuple[np.ndarray, np.ndarray]] = None  # (pos, quat) in the grip frame

    def reset(self, scene: SceneGraph, base_pose: tuple[float, float, float]) -> None:
        """Everything at its initial pose: the objects where ``scene`` has them, the arm tucked,
        the base at ``base_pose`` (x [m], y [m], yaw [rad]), nothing held."""
        mujoco.mj_resetData(self.model, self.data)
        self.held = None
        self.held_offset = None
        self.set_base(*base_pose)
        self._set_arm(self.parts.tuck)
        self.place_objects(scene)
        self.forward()

    # ---- poses -------------------------------------------------------------------------
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
        if self.held is not None and self.held_offset is not None:
            self._carry(self.held)
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

    def place_objects(self, scene: SceneGraph) -> None:
        for oid, o in scene.objects.items():
            self.set_object_pose(oid, o.position)

    # ---- holding -----------------------------------------------------------------------
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
        self.held = object_id
        self.held_offset = (r_s.T @ (p_o - p_s), q_rel)

    def release(self) -> None:
        self.held = None
        self.held_offset = None

    def _carry(self, object_id: str) -> None:
        p_s, r_s = self.grip_pose()
        off, q_rel = self.held_offset  # type: ignore[misc]
        q_s = np.zeros(4)
        mujoco.mju_mat2Quat(q_s, r_s.ravel())
        q = np.zeros(4)
        mujoco.mju_mulQuat(q, q_s, q_rel)
        self.set_object_pose(object_id, p_s + r_s @ off, q)

    # ---- contacts ----------------------------------------------------------------------
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

    def geom_footprint(self, geom_id: int) -> tuple[float, float, float, float]:
        """Axis-aligned (x0, y0, x1, y1) [m] of a box geom at its current pose."""
        pos = self.data.geom_xpos[geom_id]
        mat = self.data.geom_xmat[geom_id].reshape(3, 3)
        half = self.model.geom_size[geom_id]
        ext = np.abs(mat[:2, :2]) @ half[:2]  # AABB half extents in x, y
        return pos[0] - ext[0], pos[1] - ext[1], pos[0] + ext[0], pos[1] + ext[1]

    # ---- trajectories ------------------------------------------------------------------
    def sample(self, t: float) -> tuple[float, np.ndarray, np.ndarray]:
        """(time [s], base pose [3], arm q [6]) for a trajectory sample."""
        return t, np.array(self.robot_pose), self.arm_q

    def make_trajectory(self, samples) -> Trajectory:
        names = self.parts.joints
        if not samples:
            return Trajectory.empty(len(names), names)
        t = np.array([s[0] for s in samples], dtype=float)
        base = np.array([s[1] for s in samples], dtype=float)
        joints = np.array([s[2] for s in samples], dtype=float)
        return Trajectory(t=t, base=base, joints=joints, joint_names=names)
