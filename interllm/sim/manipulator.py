"""Execute ``pickup(object, furniture)`` and ``place(object, furniture)`` with mink IK
(paper §IV-B eq. 2: the empirical manipulation cost is the mean of N_l trial costs).

For an action at a furniture:
1. sample ``sim.n_l`` base poses by ``sim.pose_protocol`` (``sim/base_poses.py``): ``window``
   (the committed results': a 15 cm window next to the target, with replacement) or ``reach``
   (the paper's: distinct free cells within the arm's reach of the target that the robot can
   drive to, visited in a tour whose driving time each trial includes);
2. per pose, solve IK with mink on a small dedicated model (fixed-base robot with its six arm
   joints, the furniture and the objects on it — in the ``reach`` protocol also the walls, door
   leaves and neighbouring furniture with their objects within ``IK_NEIGHBOURHOOD``; built once
   per layout and cached):
   a pre-grasp pose 0.10 m above the target, then the grasp pose, both top-down (gripper
   approach axis pointing down), with joint limits (``mink.ConfigurationLimit``) and
   collision avoidance between the arm and the furniture / other objects
   (``mink.CollisionAvoidanceLimit``);
3. a trial succeeds when both solves converge (position error <= ``sim.ik_tol`` [m], orientation
   error <= ``ROT_TOL`` [rad]) within ``sim.ik_max_iters`` iterations, the final arm has no
   contact with the furniture or another object, and the target is inside the gripper;
4. trial time = drive to the pose / base_speed (``reach`` protocol) + arm motion time along the
   joint-space path (tuck -> pre-grasp -> grasp, straight lines in joint space) + grasp_time for
   a successful trial; for a failed trial the drive and the arm motion it made. The arm moves at
   ``joint_speed`` [rad/s] in the open and slows down near obstacles, as a speed-and-separation
   controller does: within ``sim.arm_slow_distance`` [m] of a neighbouring object, another
   furniture, a wall or a door leaf its speed falls linearly with the distance, down to
   ``sim.arm_min_speed`` of ``joint_speed`` at contact (``mj_geomDistance`` every
   ``ARM_SAMPLE_STEP`` rad of the path). The surface the arm works on does not slow it: every
   grasp ends on it. So a cluttered spot or an object by a wall takes longer even when every trial
   succeeds, and the time says where the difficulty is;
5. sr = successes / trials, t = mean trial time, c_man = γ_man·(1 − sr) + t; the action
   succeeds when any trial succeeded and is executed from the first successful pose.

Pickup attaches the object to the gripper (kinematically: it keeps its pose in the gripper
frame); place puts it upright on the surface at the target spot (``scene.move_object``) and
releases it. The high-level state (holding) changes in ``World.execute`` when the action
succeeded. While held, the scene graph still lists the object on the furniture it was taken
from; ``World.state.holding`` is the truth.

``Manipulator`` owns the cache of the small IK models (one per furniture layout).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Optional

import mink
import mujoco
import numpy as np

from interllm.config import SimConfig
from interllm.core.actions import Action, State
from interllm.core.frames import GRIP_FRAME, WORLD_FRAME, wxyz_to_xyzw, yaw_quat_wxyz
from interllm.core.results import ActionResult, ManipulationTrial, ObjectEvent, man_cost
from interllm.scene.graph import SceneGraph
from interllm.sim.base_poses import PRE_GRASP_HEIGHT, BasePose, sample_base_poses
from interllm.sim.belief import BeliefMap
from interllm.sim.build import build_local_spec, local_furniture
from interllm.sim.physics import MujocoWorld
from interllm.sim.robot import ARM_GEOMS, ARM_JOINTS, GRIP_SITE, TUCK

ROT_TOL = 0.1  # [rad] orientation tolerance of IK convergence
IK_NEIGHBOURHOOD = 1.6  # [m] reach protocol: what the arm could touch (pose_reach 0.8 + arm reach 0.76, rounded)
GRASP_MIN_HEIGHT = 0.02  # [m] grasp point (gripper site) at least this high above the surface
INSIDE_MARGIN = 0.02  # [m] the gripper site may be this far outside the object's box
PLACE_GAP = 0.02  # [m] clearance to other objects when placing
STALL_ITERS = 25  # stop an IK solve after this many iterations without progress
ARM_SAMPLE_STEP = 0.1  # [rad] joint-space spacing of the clearance samples along an arm motion


@dataclass
class LocalIK:
    """A cached small IK model around one furniture."""

    model: mujoco.MjModel
    configuration: mink.Configuration
    base_body: int
    grip_site: int
    arm_geoms: list[int]
    robot_geoms: set[int]
    furniture_geoms: list[int]
    object_geoms: dict[str, int]
    structure_geoms: list[int]  # walls and door leaves (reach protocol; else empty)
    support_geom: int  # the furniture the action is at (the surface the arm works on)
    _limits: dict = field(default_factory=dict, repr=False)  # avoid geoms -> IK limits (``limits``)

    def limits(self, avoid: Sequence[int]) -> list:
        """The IK limits against ``avoid``: joint limits, and collision avoidance of the arm against
        those geoms (built once per set of geoms: building them costs as much as a few solves)."""
        key = tuple(avoid)
        if key not in self._limits:
            limits = [mink.ConfigurationLimit(self.model)]
            if key:
                limits.append(mink.CollisionAvoidanceLimit(self.model, [(self.arm_geoms, list(key))],
                                                           minimum_distance_from_collisions=0.005,
                                                           collision_detection_distance=0.08))
            self._limits[key] = limits
        return self._limits[key]

    def obstacles(self, but: tuple[str, ...] = ()) -> list[int]:
        """Every geom the arm must not touch: furniture, walls, doors, objects other than ``but``."""
        return self.furniture_geoms + self.structure_geoms + \
            [g for oid, g in sorted(self.object_geoms.items()) if oid not in but]


def ik_neighbourhood(cfg: SimConfig) -> float:
    """[m] how far around the furniture the IK model reaches (0: the furniture alone)."""
    return IK_NEIGHBOURHOOD if cfg.pose_protocol == "reach" else 0.0


def _layout_key(scene: SceneGraph, furniture_id: str, exclude: tuple[str, ...], neighbourhood: float) -> tuple:
    fids = local_furniture(scene, furniture_id, neighbourhood)
    objs = tuple(sorted((o.id, tuple(round(v, 6) for v in o.position), tuple(o.size))
                        for fid in fids for o in scene.objects_on(fid) if o.id not in exclude))
    return (furniture_id, neighbourhood, objs)


def build_local_ik(scene: SceneGraph, furniture_id: str, cfg: SimConfig, exclude: tuple[str, ...] = ()) -> LocalIK:
    """The small IK model of a furniture's current layout (fixed-base arm, the furniture, its
    objects; in the reach protocol also what stands around it)."""
    spec = build_local_spec(scene, furniture_id, cfg, exclude_objects=exclude, neighbourhood=ik_neighbourhood(cfg))
    model = spec.compile()
    names = {g: (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or "") for g in range(model.ngeom)}
    ik = LocalIK(
        model=model, configuration=mink.Configuration(model), base_body=model.body("robot/base").id,
        grip_site=model.site(GRIP_SITE).id, arm_geoms=[model.geom(n).id for n in ARM_GEOMS],
        robot_geoms={g for g, n in names.items() if n.startswith("robot/")},
        furniture_geoms=[g for g, n in names.items() if n.startswith("furniture/")],
        object_geoms={n.split("/", 1)[1]: g for g, n in names.items() if n.startswith("object/")},
        structure_geoms=[g for g, n in names.items() if n.startswith(("wall/", "door/"))],
        support_geom=model.geom(f"furniture/{furniture_id}").id)
    assert model.nq == len(ARM_JOINTS), "the local IK model must have only the arm joints"
    return ik


def _topdown_rotation(base_xy, target_xy) -> np.ndarray:
    """Gripper frame with its approach axis (x) pointing down and the fingers' axis (y)
    horizontal, perpendicular to the base->target direction."""
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
    posture.set_target(TUCK)
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
        conf.integrate_inplace(v, cfg.ik_dt)
    return _Solve(conf.q.copy(), pe, re, False, reason)


def _contacts(ik: LocalIK, q: np.ndarray, obstacles: set[int]) -> bool:
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


def _run_trials(cfg: SimConfig, ik: LocalIK, poses: list[BasePose], target: np.ndarray, inside_box,
                avoid: list[int]):
    """One trial per base pose; returns (trials, per-trial (q_pre, q_grasp) or None)."""
    trials: list[ManipulationTrial] = []
    sols: list[Optional[tuple[np.ndarray, np.ndarray]]] = []
    for bp in poses:
        trial, sol = _trial(cfg, ik, bp, target, inside_box, avoid)
        trials.append(trial)
        sols.append(sol)
    return trials, sols


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
    open, slower within ``sim.arm_slow_distance`` of one of ``obstacles`` (module doc, step 4)."""
    length = float(np.linalg.norm(q_to - q_from))
    if cfg.arm_slow_distance <= 0 or length == 0.0:
        return length / cfg.joint_speed
    n = max(1, math.ceil(length / ARM_SAMPLE_STEP))
    qs = [q_from + (q_to - q_from) * ((i + 0.5) / n) for i in range(n)]
    t = 0.0
    for d in _clearances(ik, qs, obstacles, cfg.arm_slow_distance):
        t += (length / n) / (cfg.joint_speed * max(cfg.arm_min_speed, d / cfg.arm_slow_distance))
    return t


def _trial(cfg: SimConfig, ik: LocalIK, bp: BasePose, target: np.ndarray, inside_box, avoid: list[int]):
    """One trial from base pose ``bp``: drive there, pre-grasp and grasp IK, contact and grip checks.
    Returns (ManipulationTrial, (q_pre, q_grasp) or None); time [s] = drive + arm motion (+ grasp)."""
    pose = (round(bp.x, 6), round(bp.y, 6), round(bp.yaw, 6))
    drive_s = bp.drive / cfg.base_speed
    if not bp.free:
        return ManipulationTrial(pose, False, 0.0, "no_free_pose", 0.0), None
    ik.model.body_pos[ik.base_body] = (bp.x, bp.y, 0.0)
    ik.model.body_quat[ik.base_body] = yaw_quat_wxyz(bp.yaw)
    rot = _topdown_rotation((bp.x, bp.y), target[:2])
    near = [g for g in avoid if g != ik.support_geom]  # what slows the arm (module doc, step 4)
    s1 = solve_ik(ik, TUCK, target + np.array([0.0, 0.0, PRE_GRASP_HEIGHT]), rot, cfg, avoid)
    t_arm = arm_motion_time(cfg, ik, TUCK, s1.q, near)
    if not s1.converged:
        return ManipulationTrial(pose, False, drive_s + t_arm, s1.reason, round(s1.pos_err, 6)), None
    s2 = solve_ik(ik, s1.q, target, rot, cfg, avoid)
    t_fail = drive_s + t_arm + arm_motion_time(cfg, ik, s1.q, s2.q, near)
    if not s2.converged:
        return ManipulationTrial(pose, False, t_fail, s2.reason, round(s2.pos_err, 6)), None
    obstacles = set(avoid)
    if _contacts(ik, s1.q, obstacles) or _contacts(ik, s2.q, obstacles):
        return ManipulationTrial(pose, False, t_fail, "collision", round(s2.pos_err, 6)), None
    ik.configuration.update(s2.q)
    site = ik.configuration.data.site_xpos[ik.grip_site]
    lo, hi = inside_box
    if not (np.all(site >= lo - INSIDE_MARGIN) and np.all(site <= hi + INSIDE_MARGIN)):
        return ManipulationTrial(pose, False, t_fail, "not_in_gripper", round(s2.pos_err, 6)), None
    return ManipulationTrial(pose, True, t_fail + cfg.grasp_time, "", round(s2.pos_err, 6)), (s1.q, s2.q)


def _precondition_fail(cfg: SimConfig, action: Action, reason: str) -> ActionResult:
    return ActionResult(action=action, success=False, cost=man_cost(0.0, 0.0, cfg.gamma_man), time=0.0,
                        success_rate=0.0, reason=f"{action}: {reason}")


def _result(cfg: SimConfig, action: Action, trials, reason_fail: str) -> tuple[ActionResult, int]:
    n = len(trials)
    succ = [i for i, t in enumerate(trials) if t.success]
    sr = len(succ) / n if n else 0.0
    t_mean = float(np.mean([t.time for t in trials])) if n else 0.0
    ok = bool(succ)
    reason = ""
    if not ok:
        counts: dict[str, int] = {}
        for t in trials:
            counts[t.reason] = counts.get(t.reason, 0) + 1
        why = ", ".join(f"{k} x{v}" for k, v in sorted(counts.items()))
        reason = f"{action}: {reason_fail} from all {n} sampled base poses ({why})"
    res = ActionResult(action=action, success=ok, cost=man_cost(sr, t_mean, cfg.gamma_man), time=t_mean,
                       success_rate=sr, trials=trials, reason=reason)
    return res, (succ[0] if ok else -1)


def _execute_motion(physics: MujocoWorld, pose, q_pre, q_grasp, t0: float, duration: float, at_grasp) -> list:
    """Play tuck -> pre -> grasp -> (at_grasp) -> pre -> tuck in the world; returns samples
    spread over [t0, t0 + duration]."""
    physics.set_base(*pose)
    legs = [(TUCK, q_pre), (q_pre, q_grasp), (q_grasp, q_pre), (q_pre, TUCK)]
    lens = [float(np.linalg.norm(b - a)) for a, b in legs]
    total = sum(lens) or 1.0
    samples = []
    t = t0
    physics.set_arm(TUCK)
    samples.append(physics.sample(t))
    for k, ((a, b), ln) in enumerate(zip(legs, lens, strict=False)):
        steps = 6
        for i in range(1, steps + 1):
            physics.set_arm(a + (b - a) * i / steps)
            t += duration * (ln / total) / steps
            samples.append(physics.sample(t))
        if k == 1:
            at_grasp(t)
    return samples


def place_spot(scene: SceneGraph, furniture_id: str, obj_size, near_xy, held: Optional[str]) -> Optional[np.ndarray]:
    """A free spot (x, y, z of the object's centre) [m] on a furniture's top surface, nearest to
    ``near_xy`` along the closest edge, inset so the object is fully on the surface and at
    least PLACE_GAP from every other object but ``held``; None if there is no room."""
    f = scene.furniture[furniture_id]
    x0, y0, x1, y1 = f.footprint
    sx, sy, sz = (float(v) for v in obj_size)
    m = 0.03
    lox, hix = x0 + sx / 2 + m, x1 - sx / 2 - m
    loy, hiy = y0 + sy / 2 + m, y1 - sy / 2 - m
    if lox > hix or loy > hiy:
        return None
    others = [o for o in scene.objects_on(furniture_id) if o.id != held]
    base = np.array([np.clip(near_xy[0], lox, hix), np.clip(near_xy[1], loy, hiy)])
    # candidates: growing offsets along x and y from the nearest point, ordered by distance
    offs = np.arange(-1.0, 1.0001, 0.05)
    cand = np.array([[base[0] + dx, base[1] + dy] for dx in offs for dy in offs])
    cand = cand[(cand[:, 0] >= lox - 1e-9) & (cand[:, 0] <= hix + 1e-9) & (cand[:, 1] >= loy - 1e-9)
                & (cand[:, 1] <= hiy + 1e-9)]
    d = np.hypot(cand[:, 0] - near_xy[0], cand[:, 1] - near_xy[1])
    for k in np.lexsort((cand[:, 1], cand[:, 0], np.round(d, 9))):
        cx, cy = cand[k]
        free = True
        for o in others:
            gx = abs(cx - o.position[0]) - (sx + o.size[0]) / 2
            gy = abs(cy - o.position[1]) - (sy + o.size[1]) / 2
            if gx < PLACE_GAP and gy < PLACE_GAP:
                free = False
                break
        if free:
            return np.array([round(float(cx), 6), round(float(cy), 6), round(f.surface_height + sz / 2, 6)])
    return None


@dataclass(frozen=True)
class _Goal:
    """Where the gripper goes for a pickup or place: target [m], the box the grip site must end in,
    the object left out of the IK model (the held one), and the failure text."""

    target: np.ndarray
    inside: tuple[np.ndarray, np.ndarray]
    ik_exclude: tuple[str, ...]
    what_failed: str
    spot: Optional[np.ndarray] = None  # place: the object's centre on the surface [m]


def _why_the_state_forbids(state: State, action: Action, holding: Optional[str]) -> str:
    """Why the robot's state does not allow ``action`` ("" when it does)."""
    if holding is None and state.holding is not None:
        return f"the hand is not free (holding {state.holding})"
    if holding is not None and state.holding != holding:
        return f"the robot is not holding {holding} (holding {state.holding or 'nothing'})"
    if state.at_furniture != action.furniture:
        return f"the robot is at {state.at_furniture}, not at {action.furniture}"
    return ""


def _unknown(scene: SceneGraph, action: Action) -> str:
    """Why ``action`` names something the scene does not have ("" when it names nothing unknown)."""
    if action.furniture not in scene.furniture:
        return f"unknown furniture {action.furniture!r}"
    if action.obj not in scene.objects:
        return f"unknown object {action.obj!r}"
    return ""


def _goal_at(scene: SceneGraph, action: Action, centre, exclude: tuple[str, ...], what_failed: str,
             spot=None) -> _Goal:
    """The gripper's target for the object centred at ``centre`` [m] on the action's furniture (at
    least GRASP_MIN_HEIGHT above the surface) and the box the grip site must end in."""
    o, f = scene.objects[action.obj], scene.furniture[action.furniture]
    centre = np.asarray(centre, dtype=float)
    target = np.array([centre[0], centre[1], max(centre[2], f.surface_height + GRASP_MIN_HEIGHT)])
    half = np.asarray(o.size, dtype=float) / 2
    return _Goal(target, (centre - half, centre + half + [0, 0, GRASP_MIN_HEIGHT]), exclude, what_failed, spot)


def _pickup_goal(scene: SceneGraph, action: Action) -> _Goal | str:
    """The grasp of ``action.obj`` where it stands, or why there is none."""
    why = _unknown(scene, action)
    if why:
        return why
    o = scene.objects[action.obj]
    if o.furniture != action.furniture:
        return f"{action.obj} is on {o.furniture}, not on {action.furniture}"
    return _goal_at(scene, action, o.position, (), "no collision-free grasp")


def _place_goal(scene: SceneGraph, action: Action, robot_xy) -> _Goal | str:
    """The release of the held ``action.obj`` at the free spot nearest ``robot_xy``, or why there is none."""
    why = _unknown(scene, action)
    if why:
        return why
    spot = place_spot(scene, action.furniture, scene.objects[action.obj].size, robot_xy, action.obj)
    if spot is None:
        return f"no free spot for {action.obj} on {action.furniture}"
    return _goal_at(scene, action, spot, (action.obj,), "no collision-free placing pose", spot)


class Manipulator:
    """Pickups and places by N_l IK trials (module doc); caches one IK model per furniture layout.

    cfg: IK, trial and cost parameters (``SimConfig``).
    """

    MAX_CACHED = 64  # IK models kept (oldest dropped first)

    def __init__(self, cfg: SimConfig) -> None:
        self.cfg = cfg
        self._ik: dict[tuple, LocalIK] = {}

    def layout_key(self, scene: SceneGraph, furniture_id: str, exclude: tuple[str, ...] = ()) -> tuple:
        """What the trials at a furniture depend on in the scene: the furniture within reach of it and
        every object on them but ``exclude``, with their positions and sizes."""
        return _layout_key(scene, furniture_id, exclude, ik_neighbourhood(self.cfg))

    def local_ik(self, scene: SceneGraph, furniture_id: str, exclude: tuple[str, ...] = ()) -> LocalIK:
        """The small IK model for a furniture's current layout (cached)."""
        key = self.layout_key(scene, furniture_id, exclude)
        hit = self._ik.get(key)
        if hit is not None:
            return hit
        ik = build_local_ik(scene, furniture_id, self.cfg, exclude)
        if len(self._ik) > self.MAX_CACHED:
            self._ik.pop(next(iter(self._ik)))
        self._ik[key] = ik
        return ik

    def _trials(self, belief: BeliefMap, scene: SceneGraph, action: Action, goal: _Goal, robot_xy) -> tuple:
        """Steps 1-3 and 5 of the module doc from ``robot_xy`` [m]: (result, poses, per-trial IK
        solutions, index of the first successful trial or -1). Touches neither the world nor the scene."""
        cfg = self.cfg
        poses = sample_base_poses(cfg, belief.presumed, belief.true, scene.furniture[action.furniture], goal.target,
                                  (float(robot_xy[0]), float(robot_xy[1])), action, cfg.n_l)
        if not poses:
            res = _precondition_fail(cfg, action, f"no free base pose next to {action.furniture} on the robot's map")
            return res, [], [], -1
        ik = self.local_ik(scene, action.furniture, exclude=goal.ik_exclude)
        trials, sols = _run_trials(cfg, ik, poses, goal.target, goal.inside, ik.obstacles(but=(action.obj,)))
        res, k = _result(cfg, action, trials, goal.what_failed)
        return res, poses, sols, k

    def _trials_then_motion(self, physics: MujocoWorld, belief: BeliefMap, scene: SceneGraph, clock: float,
                            action: Action, goal: _Goal, at_grasp) -> ActionResult:
        """Steps 1-5 of the module doc for a pickup or place whose preconditions hold: the N_l trials,
        then the motion from the first successful pose, calling ``at_grasp(result, t)`` when the
        gripper closes or opens."""
        x, y, _ = physics.robot_pose
        res, poses, sols, k = self._trials(belief, scene, action, goal, (x, y))
        if k < 0:
            res.trajectory = physics.make_trajectory([physics.sample(clock), physics.sample(clock + res.time)])
            return res
        q_pre, q_grasp = sols[k]
        samples = _execute_motion(physics, poses[k].pose, q_pre, q_grasp, clock, res.time, lambda t: at_grasp(res, t))
        physics.forward()
        res.trajectory = physics.make_trajectory(samples)
        return res

    def measure(self, belief: BeliefMap, scene: SceneGraph, action: Action, robot_xy) -> Optional[ActionResult]:
        """The N_l-trial measurement of ``action`` (pickup or place) as it would run with the robot at
        ``robot_xy`` [m], the hand free for a pickup and holding the object for a place — without
        moving anything: the ground truth of a cost inference. None when the action cannot be tried
        in ``scene`` (unknown ids, the object not on that furniture, no room to put it)."""
        goal = _pickup_goal(scene, action) if action.kind == "pickup" else _place_goal(scene, action, robot_xy)
        if isinstance(goal, str):
            return None
        return self._trials(belief, scene, action, goal, robot_xy)[0]

    def pickup(self, physics: MujocoWorld, belief: BeliefMap, scene: SceneGraph, state: State, clock: float,
               action: Action) -> ActionResult:
        """Pick up ``action.obj`` from ``action.furniture`` (see the module doc), starting at ``clock`` [s]."""
        if action.kind != "pickup":
            raise ValueError(f"Manipulator.pickup got a {action.kind!r} action: {action}")
        why = _why_the_state_forbids(state, action, holding=None)
        goal = _pickup_goal(scene, action) if not why else why
        if isinstance(goal, str):
            return _precondition_fail(self.cfg, action, goal)

        def grasp(res: ActionResult, t: float):
            physics.attach(action.obj)
            pos, quat = physics.held_offset
            res.object_events.append(ObjectEvent(t, action.obj, GRIP_FRAME, tuple(float(v) for v in pos),
                                                 wxyz_to_xyzw(quat)))

        return self._trials_then_motion(physics, belief, scene, clock, action, goal, grasp)

    def place(self, physics: MujocoWorld, belief: BeliefMap, scene: SceneGraph, state: State, clock: float,
              action: Action) -> ActionResult:
        """Place the held ``action.obj`` on ``action.furniture`` (see the module doc), starting at ``clock`` [s]."""
        if action.kind != "place":
            raise ValueError(f"Manipulator.place got a {action.kind!r} action: {action}")
        x, y, _ = physics.robot_pose
        why = _why_the_state_forbids(state, action, holding=action.obj)
        goal = _place_goal(scene, action, (x, y)) if not why else why
        if isinstance(goal, str):
            return _precondition_fail(self.cfg, action, goal)
        spot = goal.spot

        def release(res: ActionResult, t: float):
            physics.release()
            pos = (float(spot[0]), float(spot[1]), float(spot[2]))
            scene.move_object(action.obj, action.furniture, pos)
            physics.set_object_pose(action.obj, pos)
            res.object_events.append(ObjectEvent(t, action.obj, WORLD_FRAME, pos, (0.0, 0.0, 0.0, 1.0)))

        return self._trials_then_motion(physics, belief, scene, clock, action, goal, release)
