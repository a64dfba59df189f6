"""The small IK model around one furniture, and what the manipulation trials compute on it.

``LocalIK`` is a compiled model with a fixed-base robot (its six arm joints only), the furniture
the action is at and the objects on it; in the ``reach`` protocol also the walls, door leaves
and neighbouring furniture with their objects within ``IK_NEIGHBOURHOOD`` (``build_local_ik``).
On it: ``solve_ik`` drives the gripper site to a pose with mink (joint limits and collision
avoidance of the arm against given geoms), ``arm_touches`` tells whether the arm touches an
obstacle at a configuration, ``arm_clearance`` how far it is from them, and ``arm_motion_time``
how long a straight joint-space motion takes when the arm slows down near obstacles.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import mink
import mujoco
import numpy as np

from interllm.config import SimConfig
from interllm.scene.graph import SceneGraph
from interllm.sim.build import build_local_spec, local_furniture
from interllm.sim.robot import GRIP_SITE, RobotParts, robot_parts

ROT_TOL = 0.1  # [rad] orientation tolerance of IK convergence
IK_NEIGHBOURHOOD = 1.6  # [m] reach protocol: what the arm could touch (pose_reach 0.8 + arm reach 0.76, rounded)
STALL_ITERS = 25  # stop an IK solve after this many iterations without progress
# [m or rad] the largest joint move of one IK step: the collision limits are linearised where the
# step starts, so a longer step can carry a link through a table top it did not yet see
MAX_IK_STEP = 0.05
ARM_SAMPLE_STEP = 0.1  # [rad] joint-space spacing of the clearance samples along an arm motion


class ArmCollisionLimit(mink.CollisionAvoidanceLimit):
    """mink's collision avoidance over exactly the given (arm geom, obstacle geom) pairs.

    mink drops a pair whose bodies it takes for parent and child by their welds. In the local IK
    model the base is welded to the world, so the arm's first moving link (ManipulaTHOR's arm root,
    Stretch's lift carriage) counts as the world's child and would lose every pair with furniture,
    walls and objects, which are welded to the world too: the IK would drive it into a table that
    the final contact check then finds. No arm geom is an obstacle's parent or child, so every
    given pair is kept (sorted: a fixed constraint order)."""

    def _construct_geom_id_pairs(self, geom_pairs):
        return sorted({(min(a, b), max(a, b)) for arm, obstacles in geom_pairs for a in arm for b in obstacles
                       if a != b})


@dataclass
class LocalIK:
    """A cached small IK model around one furniture."""

    model: mujoco.MjModel
    configuration: mink.Configuration
    parts: RobotParts
    base_body: int
    grip_site: int
    arm_geoms: list[int]
    robot_geoms: set[int]
    furniture_geoms: list[int]
    object_geoms: dict[str, int]
    structure_geoms: list[int]  # walls and door leaves (reach protocol; else empty)
    support_geoms: tuple[int, ...]  # the furniture the action is at (the surface the arm works on; one geom per part)
    _limits: dict = field(default_factory=dict, repr=False)  # avoid geoms -> IK limits (``limits``)

    def limits(self, avoid: Sequence[int]) -> list:
        """The IK limits against ``avoid``: joint limits, and collision avoidance of the arm against
        those geoms (built once per set of geoms: building them costs as much as a few solves)."""
        key = tuple(avoid)
        if key not in self._limits:
            limits = [mink.ConfigurationLimit(self.model)]
            if key:
                limits.append(ArmCollisionLimit(self.model, [(self.arm_geoms, list(key))],
                                                minimum_distance_from_collisions=0.005,
                                                collision_detection_distance=0.2))
            self._limits[key] = limits
        return self._limits[key]

    def obstacles(self, but: tuple[str, ...] = ()) -> list[int]:
        """Every geom the arm must not touch: furniture, walls, doors, objects other than ``but``."""
        return self.furniture_geoms + self.structure_geoms + \
            [g for oid, g in sorted(self.object_geoms.items()) if oid not in but]


def ik_neighbourhood(cfg: SimConfig) -> float:
    """[m] how far around the furniture the IK model reaches (0: the furniture alone): base poses
    up to ``sim.pose_reach`` away plus the arm's reach."""
    if cfg.pose_protocol != "reach":
        return 0.0
    reach = robot_parts(cfg.robot).reach
    return IK_NEIGHBOURHOOD if reach is None else round(cfg.pose_reach + reach.radius + 0.05, 1)


def layout_key(scene: SceneGraph, furniture_id: str, exclude: tuple[str, ...], neighbourhood: float) -> tuple:
    """What an IK model of a furniture depends on in the scene: the furniture within
    ``neighbourhood`` [m] of it and every object on them but ``exclude``, with positions and sizes."""
    fids = local_furniture(scene, furniture_id, neighbourhood)
    objs = tuple(sorted((o.id, tuple(round(v, 6) for v in o.position), tuple(o.size))
                        for fid in fids for o in scene.objects_on(fid) if o.id not in exclude))
    return (furniture_id, neighbourhood, objs)


def build_local_ik(scene: SceneGraph, furniture_id: str, cfg: SimConfig, exclude: tuple[str, ...] = ()) -> LocalIK:
    """The small IK model of a furniture's current layout (fixed-base arm, the furniture, its
    objects; in the reach protocol also what stands around it)."""
    spec = build_local_spec(scene, furniture_id, cfg, exclude_objects=exclude, neighbourhood=ik_neighbourhood(cfg))
    model = spec.compile()
    parts = robot_parts(cfg.robot)
    names = {g: (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or "") for g in range(model.ngeom)}
    ik = LocalIK(
        model=model, configuration=mink.Configuration(model), parts=parts, base_body=model.body("robot/base").id,
        grip_site=model.site(GRIP_SITE).id, arm_geoms=[model.geom(n).id for n in parts.arm_geoms],
        robot_geoms={g for g, n in names.items() if n.startswith("robot/")},
        furniture_geoms=[g for g, n in names.items() if n.startswith("furniture/")],
        object_geoms={n.split("/", 1)[1]: g for g, n in names.items() if n.startswith("object/")},
        structure_geoms=[g for g, n in names.items() if n.startswith(("wall/", "door/"))],
        support_geoms=tuple(g for g, n in names.items()
                            if n == f"furniture/{furniture_id}" or n.startswith(f"furniture/{furniture_id}/")))
    assert model.nq == len(parts.joints), "the local IK model must have only the arm joints"
    return ik


def topdown_rotation(base_xy, target_xy, reach_yaw: float | None = None) -> np.ndarray:
    """Gripper frame with its approach axis (x) pointing down and the fingers' axis (y)
    horizontal, perpendicular to the base->target direction, or to the world direction
    ``reach_yaw`` [rad] the arm reaches along (a robot whose arm is off the base's centre)."""
    if reach_yaw is not None:
        target_xy = (base_xy[0] + math.cos(reach_yaw), base_xy[1] + math.sin(reach_yaw))
    d = np.array([target_xy[0] - base_xy[0], target_xy[1] - base_xy[1]], dtype=float)
    n = float(np.linalg.norm(d))
    d = d / n if n > 1e-9 else np.array([1.0, 0.0])
    x = np.array([0.0, 0.0, -1.0])
    y = np.array([-d[1], d[0], 0.0])
    z = np.cross(x, y)
    return np.stack([x, y, z], axis=1)


def _rot_err(r: np.ndarray, rt: np.ndarray) -> float:
    c = (np.trace(r.T @ rt) - 1.0) / 2.0
    return float(math.acos(max(-1.0, min(1.0, c))))


@dataclass
class _Solve:
    q: np.ndarray
    pos_err: float
    rot_err: float
    converged: bool
    reason: str


def solve_ik(ik: LocalIK, q0: np.ndarray, target_pos: np.ndarray, target_rot: np.ndarray, cfg,
             avoid: list[int]) -> _Solve:
    """Drive the gripper site to a pose; arm joints only, with joint limits and collision
    avoidance of the arm against the geoms in ``avoid``."""
    conf = ik.configuration
    conf.update(np.asarray(q0, dtype=float))
    task = mink.FrameTask(GRIP_SITE, "site", position_cost=1.0, orientation_cost=0.3, lm_damping=1e-3)
    task.set_target(mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(target_rot),
                                                           np.asarray(target_pos, dtype=float)))
    posture = mink.PostureTask(ik.model, cost=1e-3)
    posture.set_target(ik.parts.tuck)
    limits = ik.limits(avoid)
    best = math.inf
    since = 0
    reason = "ik_no_convergence"
    pe = re = math.inf
    for _ in range(cfg.ik_max_iters + 1):
        p = conf.data.site_xpos[ik.grip_site]
        r = conf.data.site_xmat[ik.grip_site].reshape(3, 3)
        pe = float(np.linalg.norm(p - target_pos))
        re = _rot_err(r, target_rot)
        if pe <= cfg.ik_tol and re <= ROT_TOL:
            return _Solve(conf.q.copy(), pe, re, True, "")
        score = pe + 0.1 * re
        if score < best - 1e-4:
            best, since = score, 0
        else:
            since += 1
            if since >= STALL_ITERS:
                break
        try:
            v = mink.solve_ik(conf, [task, posture], cfg.ik_dt, "daqp", damping=1e-3, limits=limits)
        except mink.NoSolutionFound:
            reason = "ik_infeasible"
            break
        step = float(np.max(np.abs(v))) * cfg.ik_dt
        conf.integrate_inplace(v * min(1.0, MAX_IK_STEP / step) if step > 0 else v, cfg.ik_dt)
    return _Solve(conf.q.copy(), pe, re, False, reason)


def arm_touches(ik: LocalIK, q: np.ndarray, obstacles: set[int]) -> bool:
    """Any contact between the arm and an obstacle at arm configuration q (the base stands on a
    cell the belief map calls free; its contacts are navigation's business)."""
    conf = ik.configuration
    conf.update(q)
    mujoco.mj_collision(ik.model, conf.data)
    c = conf.data.contact
    arm = set(ik.arm_geoms)
    for i in range(conf.data.ncon):
        g1, g2 = int(c.geom1[i]), int(c.geom2[i])
        if (g1 in arm and g2 in obstacles) or (g2 in arm and g1 in obstacles):
            return True
    return False


def arm_clearance(ik: LocalIK, q: np.ndarray, obstacles: Sequence[int], within: float) -> float:
    """[m] the smallest distance between the arm and an obstacle at arm configuration q, capped at
    ``within``: ``mj_geomDistance`` over the pairs whose bounding spheres come within ``within``
    (MuJoCo's contact margins miss box-box pairs, so they are not used here)."""
    return _clearances(ik, [q], obstacles, within)[0]


def _clearances(ik: LocalIK, qs: Sequence[np.ndarray], obstacles: Sequence[int], within: float) -> list[float]:
    """``arm_clearance`` at each configuration of ``qs`` (the geom arrays are set up once)."""
    if len(obstacles) == 0:
        return [within] * len(qs)
    conf, model = ik.configuration, ik.model
    arm, obs = np.asarray(ik.arm_geoms), np.asarray(obstacles, dtype=int)
    reach = model.geom_rbound[arm][:, None] + model.geom_rbound[obs][None, :] + within
    out = []
    for q in qs:
        conf.update(q)
        xpos = conf.data.geom_xpos
        near = np.linalg.norm(xpos[arm][:, None, :] - xpos[obs][None, :, :], axis=2) < reach
        best = within
        for a, o in zip(*np.nonzero(near), strict=True):
            best = min(best, mujoco.mj_geomDistance(model, conf.data, int(arm[a]), int(obs[o]), within, None))
        out.append(max(float(best), 0.0))
    return out


def arm_motion_time(cfg: SimConfig, ik: LocalIK, q_from: np.ndarray, q_to: np.ndarray,
                    obstacles: Sequence[int]) -> float:
    """[s] time of the straight joint-space motion q_from -> q_to: ``joint_speed`` [rad/s] in the
    open; within ``sim.arm_slow_distance`` [m] of one of ``obstacles`` the speed falls linearly with
    the clearance, down to ``sim.arm_min_speed`` of ``joint_speed`` at contact (clearance sampled
    every ``ARM_SAMPLE_STEP`` rad of the path)."""
    length = float(np.linalg.norm(_in_hinge_units(cfg, ik.parts, q_to - q_from)))
    if cfg.arm_slow_distance <= 0 or length == 0.0:
        return length / cfg.joint_speed
    n = max(1, math.ceil(length / ARM_SAMPLE_STEP))
    qs = [q_from + (q_to - q_from) * ((i + 0.5) / n) for i in range(n)]
    t = 0.0
    for d in _clearances(ik, qs, obstacles, cfg.arm_slow_distance):
        t += (length / n) / (cfg.joint_speed * max(cfg.arm_min_speed, d / cfg.arm_slow_distance))
    return t


def _in_hinge_units(cfg: SimConfig, parts: RobotParts, dq: np.ndarray) -> np.ndarray:
    """A joint-space step with each prismatic joint's travel [m] scaled to the hinge angle [rad]
    that takes as long (``link_speed`` [m/s] against ``sim.joint_speed`` [rad/s])."""
    if not any(parts.slide):
        return dq
    return np.where(parts.slide, dq * (cfg.joint_speed / parts.link_speed), dq)
