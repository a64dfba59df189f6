"""Forward kinematics of the robot's arm as a tree of link frames, for logging and replay.

``RobotKinematics`` compiles the robot of ``robot.py`` alone (fixed base, the six arm joints) and
reads the kinematic tree out of the compiled MjModel: every robot body is a frame named after it
without the ``robot/`` prefix (the base body is ``base_link``), plus ``grip`` for the gripper site.
A link's pose relative to its parent depends only on its own joint angle, so

    T_parent->child(q) = (body_pos, body_quat ⊗ axis_angle(jnt_axis, q))

when the hinge passes through the body origin (``jnt_pos == 0``, true for this robot and checked
at construction). ``link_poses`` evaluates that for many samples at once with numpy, which is
what the MCAP recorder needs (``/tf``: world->base_link from the base pose, then this chain).
``visuals`` lists the robot's geoms per frame (Foxglove SceneUpdate primitives and rerun boxes /
capsules / cylinders), so the logged robot looks like the simulated one.

Quaternions here are (x, y, z, w), the order Foxglove and rerun use; MuJoCo's are (w, x, y, z).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import mujoco
import numpy as np

from interllm.config import SimConfig
from interllm.core.frames import BASE_FRAME, GRIP_FRAME, wxyz_to_xyzw
from interllm.sim.robot import GRIP_SITE, PREFIX, add_robot, add_robot_assets, robot_parts

_GEOM_KIND = {int(mujoco.mjtGeom.mjGEOM_BOX): "box", int(mujoco.mjtGeom.mjGEOM_CYLINDER): "cylinder",
              int(mujoco.mjtGeom.mjGEOM_CAPSULE): "capsule", int(mujoco.mjtGeom.mjGEOM_SPHERE): "sphere"}


def _rotate_xyzw(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Vector ``v`` [3] rotated by the unit quaternion ``q`` (x, y, z, w)."""
    u, w = np.asarray(q[:3], dtype=float), float(q[3])
    return v + 2.0 * np.cross(u, np.cross(u, v) + w * v)


def frame_name(body_name: str) -> str:
    """MuJoCo robot body name -> frame id ("robot/base" -> "base_link", "robot/hand" -> "hand")."""
    return BASE_FRAME if body_name == PREFIX + "base" else body_name.removeprefix(PREFIX)


def quat_mul_xyzw(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of (..., 4) quaternions in (x, y, z, w) order."""
    ax, ay, az, aw = np.moveaxis(np.asarray(a, dtype=float), -1, 0)
    bx, by, bz, bw = np.moveaxis(np.asarray(b, dtype=float), -1, 0)
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], axis=-1)


@dataclass(frozen=True)
class LinkVisual:
    """One robot geom drawn in a link frame. size: box half extents (3); cylinder / capsule
    (radius, half length) along the local z axis; sphere (radius,). pos [m], quat (x, y, z, w)."""

    frame: str
    name: str
    kind: str  # "box" | "cylinder" | "capsule" | "sphere"
    size: tuple[float, ...]
    pos: tuple[float, float, float]
    quat: tuple[float, float, float, float]
    rgba: tuple[float, float, float, float]


class RobotKinematics:
    """The arm's frame tree (parent frame, child frame, joint) and its forward kinematics.

    ``chain``: [(parent, child)] in tree order, base_link first as a parent (never a child);
    ``joint_names``: the arm joints (ARM_JOINTS order) that ``link_poses`` takes.
    """

    def __init__(self, sim_cfg: Optional[SimConfig] = None) -> None:
        spec = mujoco.MjSpec()
        add_robot_assets(spec)
        add_robot(spec.worldbody, sim_cfg or SimConfig(), mobile=False)
        self.model = m = spec.compile()
        self.joint_names = names = robot_parts((sim_cfg or SimConfig()).robot).joints
        qadr = {n: int(m.jnt_qposadr[m.joint(n).id]) for n in names}
        base_id = m.body(PREFIX + "base").id
        self.chain: list[tuple[str, str]] = []
        pos, quat, axis, col, slide = [], [], [], [], []
        for b in range(base_id + 1, m.nbody):  # bodies are numbered in tree order
            parent = int(m.body_parentid[b])
            self.chain.append((frame_name(m.body(parent).name), frame_name(m.body(b).name)))
            pos.append(m.body_pos[b].copy())
            quat.append(wxyz_to_xyzw(m.body_quat[b]))
            nj = int(m.body_jntnum[b])
            if nj > 1:
                raise ValueError(f"body {m.body(b).name} has {nj} joints; RobotKinematics supports one hinge "
                                 "per link")
            if nj == 1:
                j = int(m.body_jntadr[b])
                kind = int(m.jnt_type[j])
                if (kind not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
                        or np.any(m.jnt_pos[j] != 0) or m.qpos0[m.jnt_qposadr[j]] != 0):
                    raise ValueError(f"joint {m.joint(j).name}: RobotKinematics needs hinges through the "
                                     "body origin (jnt_pos = 0) or slides, with reference 0 (ref = 0)")
                axis.append(m.jnt_axis[j].copy())
                slide.append(kind == int(mujoco.mjtJoint.mjJNT_SLIDE))
                col.append(names.index(m.joint(j).name) if m.joint(j).name in qadr else -1)
            else:
                axis.append(np.zeros(3))
                slide.append(False)
                col.append(-1)
        site = m.site(GRIP_SITE)
        self.chain.append((frame_name(m.body(int(m.site_bodyid[site.id])).name), GRIP_FRAME))
        pos.append(m.site_pos[site.id].copy())
        quat.append(wxyz_to_xyzw(m.site_quat[site.id]))
        axis.append(np.zeros(3))
        slide.append(False)
        col.append(-1)
        self._pos = np.asarray(pos, dtype=float)  # [L, 3]
        self._quat = np.asarray(quat, dtype=float)  # [L, 4] xyzw
        self._axis = np.asarray(axis, dtype=float)  # [L, 3]
        self._col = np.asarray(col, dtype=int)  # [L] joint column or -1 (fixed)
        self._slide = np.asarray(slide, dtype=bool)  # [L] the link's joint is prismatic
        # a slide moves its body along its axis, which is given in the body frame: in the parent frame
        self._slide_dir = np.array([_rotate_xyzw(qt, ax) for qt, ax in zip(self._quat, self._axis, strict=True)])
        self.frames = tuple(c for _, c in self.chain)
        self._base_id = base_id

    def link_poses(self, joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Relative link poses for joint samples [N, J] (or one sample [J]) [rad] or [m] (slides).

        Returns (translations [N, L, 3] [m], quaternions [N, L, 4] xyzw), L = len(chain), each the
        pose of ``chain[l][1]`` in ``chain[l][0]``.
        """
        q = np.asarray(joints, dtype=float)
        one = q.ndim == 1
        q = q.reshape(-1, len(self.joint_names))
        n, nl = len(q), len(self.chain)
        val = np.where(self._col >= 0, q[:, np.clip(self._col, 0, None)], 0.0)  # [N, L]
        half = np.where(self._slide, 0.0, val) / 2.0
        rot = np.concatenate([self._axis[None] * np.sin(half)[..., None], np.cos(half)[..., None]], axis=-1)
        quat = quat_mul_xyzw(np.broadcast_to(self._quat, (n, nl, 4)), rot)
        trans = np.broadcast_to(self._pos, (n, nl, 3)).copy()
        if self._slide.any():
            trans += self._slide_dir[None] * np.where(self._slide, val, 0.0)[..., None]
        return (trans[0], quat[0]) if one else (trans, quat)

    def visuals(self) -> list[LinkVisual]:
        """Every visible robot geom as a LinkVisual in its body's frame (tree order)."""
        m = self.model
        out = []
        for g in range(m.ngeom):
            b = int(m.geom_bodyid[g])
            kind = _GEOM_KIND.get(int(m.geom_type[g]))
            if b < self._base_id or kind is None or m.geom_rgba[g][3] <= 0:
                continue
            sz = m.geom_size[g]
            size = {"box": tuple(sz[:3]), "cylinder": tuple(sz[:2]), "capsule": tuple(sz[:2]),
                    "sphere": (sz[0],)}[kind]
            out.append(LinkVisual(frame=frame_name(m.body(b).name), name=m.geom(g).name or f"geom_{g}",
                                  kind=kind, size=tuple(float(v) for v in size),
                                  pos=tuple(float(v) for v in m.geom_pos[g]),
                                  quat=wxyz_to_xyzw(m.geom_quat[g]),
                                  rgba=tuple(float(v) for v in m.geom_rgba[g])))
        return out


__all__ = ["BASE_FRAME", "GRIP_FRAME", "LinkVisual", "RobotKinematics", "frame_name", "quat_mul_xyzw"]
