"""The mobile manipulator ``sim.robot`` names, built in code with ``mujoco.MjSpec``.

A real robot (``robots.py``: ``manipulathor``, ``stretch``) is built from its description: a base
cylinder of the robot's footprint radius on the planar joints, and its serial chain as one body per
link (a joint where the link moves, a collision box where the description has one), ending in the
gripper site ``robot/grip``. ``robot_parts`` names what the rest of the simulator needs of it (the
arm's joints, its carry pose, the geoms that must not touch furniture).

The ``generic`` robot (the v1 robot of this project, not a real one) is built below by hand:
Base: a cylinder of radius ``sim_cfg.robot_radius`` [m] on a planar joint set (slide x, slide y,
hinge yaw), so the base pose is qpos[0:3] = (x [m], y [m], yaw [rad]).
Arm: 6 revolute joints (pan, shoulder pitch, elbow pitch, wrist roll, wrist pitch, hand roll)
mounted on a mast with the shoulder at ``SHOULDER_HEIGHT`` [m]; links give a reach of
``REACH`` [m] from the shoulder to the gripper site ``robot/grip`` (between the two fingers).
A camera ``robot/camera`` looks forward from the top of the mast.

Collision bits (contype / conaffinity) shared with ``build.py``:
static scene geoms (floor, walls, door leaves, furniture) = (1, 0); robot = (2, 1|4);
objects = (4, 1|4). So robot-vs-scene, robot-vs-object, object-vs-scene and object-vs-object
contacts are generated, robot-vs-robot and scene-vs-scene are not.

Everything is kinematic in the experiment (the base and arm are placed, contacts queried);
robot bodies have gravity compensation so a dynamic ``mj_step`` keeps them still.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import mujoco
import numpy as np

from interllm.config import SimConfig
from interllm.core.frames import yaw_quat_wxyz
from interllm.sim.robots import RobotDescription, describe
from interllm.sim.urdf_chain import ChainJoint

PREFIX = "robot/"
SHOULDER_HEIGHT = 0.80  # [m] above the floor
SHOULDER_FORWARD = 0.02  # [m] in front of the base centre
UPPER_ARM = 0.34  # [m]
FOREARM = 0.30  # [m]
WRIST_TO_GRIP = 0.12  # [m] wrist pitch axis to the gripper site
REACH = UPPER_ARM + FOREARM + WRIST_TO_GRIP  # [m] 0.76
BASE_HEIGHT = 0.32  # [m] top of the base cylinder
BASE_CLEARANCE = 0.02  # [m] between the floor and the bottom of the base

BASE_JOINTS = ("robot/x", "robot/y", "robot/yaw")
ARM_JOINTS = tuple(f"robot/j{i}" for i in range(1, 7))
ARM_RANGES = ((-2.9, 2.9), (-1.9, 1.9), (-2.6, 2.6), (-math.pi, math.pi), (-2.1, 2.1), (-math.pi, math.pi))
# tucked / carry pose: arm folded over the base, gripper above the base footprint
TUCK = np.array([0.0, -1.5, 2.6, 0.0, 1.0, 0.0])
GRIP_SITE = "robot/grip"
BASE_GEOM = "robot/base"
ARM_GEOMS = ("robot/upper_arm", "robot/forearm", "robot/wrist", "robot/hand", "robot/finger_l",
             "robot/finger_r")

CT_STATIC, CA_STATIC = 1, 0
CT_ROBOT, CA_ROBOT = 2, 1 | 4
CT_OBJECT, CA_OBJECT = 4, 1 | 4

_B = mujoco.mjtGeom.mjGEOM_BOX
_CYL = mujoco.mjtGeom.mjGEOM_CYLINDER
_CAP = mujoco.mjtGeom.mjGEOM_CAPSULE
_HINGE = mujoco.mjtJoint.mjJNT_HINGE
_SLIDE = mujoco.mjtJoint.mjJNT_SLIDE


@dataclass(frozen=True)
class RobotParts:
    """What the simulator needs of a robot: ``joints`` (the arm's joint names, IK order),
    ``tuck`` (their carry pose [rad] or [m]), ``arm_geoms`` (geoms that must not touch obstacles),
    ``slide`` (True where a joint is prismatic), ``heading`` [rad] (the side the arm reaches
    to, in the base frame), ``link_speed`` [m/s] (prismatic joints)."""

    joints: tuple[str, ...]
    tuck: np.ndarray
    arm_geoms: tuple[str, ...]
    slide: tuple[bool, ...]
    heading: float = 0.0
    link_speed: float = 0.1
    reach: Reach | None = None  # None: the generic robot (base_poses.arm_reach has its formula)


@dataclass(frozen=True)
class Reach:
    """Where a described robot's top-down gripper reaches, by forward kinematics of its
    ``reach_low`` / ``reach_high`` configurations: grasp-centre heights ``z_low`` .. ``z_high`` [m],
    the horizontal distance ``radius`` [m] from the base centre to the grasp centre at full
    extension (``radius_min`` retracted), and its ``lateral`` offset [m] from the line through the base centre along the
    arm's heading (positive: to the left of it)."""

    z_low: float
    z_high: float
    radius: float
    lateral: float
    radius_min: float  # [m] horizontal base-centre-to-grasp-centre distance with the arm retracted
    tilts: bool = False  # the arm pitches: beyond z_low / z_high it reaches sqrt(radius² - dz²)


@cache
def robot_parts(name: str) -> RobotParts:
    """The parts of robot ``name`` (``sim.robot``)."""
    desc = describe(name)
    if desc is None:
        return RobotParts(ARM_JOINTS, TUCK, ARM_GEOMS, (False,) * len(ARM_JOINTS))
    moving = desc.joints
    first = next(i for i, j in enumerate(desc.chain) if j.kind != "fixed")
    arm_links = [j.link for j in desc.chain[first:]] + [j.link for _, ch in desc.fingers for j in ch]
    return RobotParts(tuple(PREFIX + j.name for j in moving), np.array(desc.tuck, dtype=float),
                      tuple(PREFIX + link for link in arm_links if link in desc.boxes),
                      tuple(j.kind == "slide" for j in moving), desc.arm_heading, desc.link_speed, _reach(desc))


def grip_in_base(desc: RobotDescription, q) -> np.ndarray:
    """[m] the grasp centre in the base frame (origin: the footprint's centre on the floor) at the
    arm configuration ``q`` (the chain's moving joints, in order)."""
    spec = mujoco.MjSpec()
    _add_described_robot(spec.worldbody, desc, mobile=False, pose=(0.0, 0.0, 0.0))
    model = spec.compile()
    data = mujoco.MjData(model)
    data.qpos[:] = np.asarray(q, dtype=float)
    mujoco.mj_kinematics(model, data)
    return data.site_xpos[model.site(GRIP_SITE).id].copy()


def _reach(desc: RobotDescription) -> Reach:
    lo, hi = grip_in_base(desc, desc.reach_low), grip_in_base(desc, desc.reach_high)
    c, s = math.cos(desc.arm_heading), math.sin(desc.arm_heading)
    lateral = float(-s * hi[0] + c * hi[1])
    near = grip_in_base(desc, desc.reach_near) if desc.reach_near else np.zeros(3)
    return Reach(float(lo[2]), float(hi[2]), float(math.hypot(hi[0], hi[1])), lateral,
                 float(math.hypot(near[0], near[1])), desc.tilts)


def _robot_geom(body, name, **kw):
    return body.add_geom(name=name, contype=CT_ROBOT, conaffinity=CA_ROBOT, **kw)


def add_robot(parent, sim_cfg: SimConfig | None = None, mobile: bool = True,
              pose: tuple[float, float, float] = (0.0, 0.0, 0.0)):
    """Add the robot under ``parent`` (an MjsBody, usually ``spec.worldbody``); returns the base body.

    mobile: True adds the planar base joints (slide x, slide y, hinge yaw; qpos = the base pose
        [m, m, rad] relative to ``pose``). False makes a fixed base placed at ``pose`` whose
        ``body_pos`` / ``body_quat`` may be changed in the compiled model (used by the small IK
        models, whose only joints are the six arm joints).
    pose: x [m], y [m], yaw [rad] of the base body frame.
    """
    cfg = sim_cfg or SimConfig()
    desc = describe(cfg.robot)
    if desc is not None:
        return _add_described_robot(parent, desc, mobile, pose)
    r = cfg.robot_radius
    if mobile:
        base = parent.add_body(name="robot/base", pos=[0.0, 0.0, 0.0], gravcomp=1.0)
        base.add_joint(name=BASE_JOINTS[0], type=_SLIDE, axis=[1, 0, 0], damping=50.0)
        base.add_joint(name=BASE_JOINTS[1], type=_SLIDE, axis=[0, 1, 0], damping=50.0)
        base.add_joint(name=BASE_JOINTS[2], type=_HINGE, axis=[0, 0, 1], damping=50.0)
    else:
        base = parent.add_body(name="robot/base", pos=[pose[0], pose[1], 0.0], quat=yaw_quat_wxyz(pose[2]),
                               gravcomp=1.0)
    half_h = (BASE_HEIGHT - BASE_CLEARANCE) / 2
    _robot_geom(base, BASE_GEOM, type=_CYL, size=[r, half_h, 0], pos=[0, 0, BASE_CLEARANCE + half_h],
                rgba=[0.25, 0.3, 0.35, 1], mass=30.0)
    mast_h = SHOULDER_HEIGHT - BASE_HEIGHT + 0.45
    base.add_geom(name="robot/mast", type=_B, size=[0.05, 0.05, mast_h / 2],
                  pos=[-0.04, 0, BASE_HEIGHT + mast_h / 2], rgba=[0.5, 0.5, 0.55, 1],
                  contype=0, conaffinity=0, mass=3.0)
    # camera at the top of the mast looking along +x (camera looks along its -z, up = +y)
    mat = np.array([[0, 0, -1], [-1, 0, 0], [0, 1, 0]], dtype=float)  # columns: cam x, y, z in body
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, mat.ravel())
    base.add_camera(name="robot/camera", pos=[0.0, 0, BASE_HEIGHT + mast_h + 0.05], quat=q.tolist(),
                    fovy=60.0)

    sh = base.add_body(name="robot/shoulder", pos=[SHOULDER_FORWARD, 0, SHOULDER_HEIGHT], gravcomp=1.0)
    sh.add_joint(name=ARM_JOINTS[0], type=_HINGE, axis=[0, 0, 1], range=list(ARM_RANGES[0]),
                 limited=mujoco.mjtLimited.mjLIMITED_TRUE, damping=5.0, armature=0.1)
    sh.add_geom(name="robot/shoulder", type=_CYL, size=[0.05, 0.04, 0], rgba=[0.9, 0.5, 0.1, 1],
                contype=0, conaffinity=0, mass=1.0)
    ua = sh.add_body(name="robot/upper_arm", gravcomp=1.0)
    ua.add_joint(name=ARM_JOINTS[1], type=_HINGE, axis=[0, 1, 0], range=list(ARM_RANGES[1]),
                 limited=mujoco.mjtLimited.mjLIMITED_TRUE, damping=5.0, armature=0.1)
    _robot_geom(ua, "robot/upper_arm", type=_CAP, fromto=[0, 0, 0, UPPER_ARM, 0, 0], size=[0.035, 0, 0],
                rgba=[0.9, 0.5, 0.1, 1], mass=1.5)
    fa = ua.add_body(name="robot/forearm", pos=[UPPER_ARM, 0, 0], gravcomp=1.0)
    fa.add_joint(name=ARM_JOINTS[2], type=_HINGE, axis=[0, 1, 0], range=list(ARM_RANGES[2]),
                 limited=mujoco.mjtLimited.mjLIMITED_TRUE, damping=5.0, armature=0.1)
    _robot_geom(fa, "robot/forearm", type=_CAP, fromto=[0.04, 0, 0, FOREARM, 0, 0], size=[0.03, 0, 0],
                rgba=[0.9, 0.9, 0.9, 1], mass=1.0)
    w1 = fa.add_body(name="robot/wrist_roll", pos=[FOREARM, 0, 0], gravcomp=1.0)
    w1.add_joint(name=ARM_JOINTS[3], type=_HINGE, axis=[1, 0, 0], range=list(ARM_RANGES[3]),
                 limited=mujoco.mjtLimited.mjLIMITED_TRUE, damping=2.0, armature=0.05)
    w1.add_geom(name="robot/wrist_roll", type=_CYL, size=[0.03, 0.02, 0], rgba=[0.3, 0.3, 0.3, 1],
                contype=0, conaffinity=0, mass=0.3)
    w2 = w1.add_body(name="robot/wrist", gravcomp=1.0)
    w2.add_joint(name=ARM_JOINTS[4], type=_HINGE, axis=[0, 1, 0], range=list(ARM_RANGES[4]),
                 limited=mujoco.mjtLimited.mjLIMITED_TRUE, damping=2.0, armature=0.05)
    _robot_geom(w2, "robot/wrist", type=_CAP, fromto=[0.0, 0, 0, 0.04, 0, 0], size=[0.025, 0, 0],
                rgba=[0.3, 0.3, 0.3, 1], mass=0.3)
    hand = w2.add_body(name="robot/hand", pos=[0.04, 0, 0], gravcomp=1.0)
    hand.add_joint(name=ARM_JOINTS[5], type=_HINGE, axis=[1, 0, 0], range=list(ARM_RANGES[5]),
                   limited=mujoco.mjtLimited.mjLIMITED_TRUE, damping=2.0, armature=0.05)
    _robot_geom(hand, "robot/hand", type=_B, size=[0.015, 0.055, 0.02], pos=[0.015, 0, 0],
                rgba=[0.2, 0.2, 0.2, 1], mass=0.3)
    tip = WRIST_TO_GRIP - 0.04  # gripper site along the hand x axis
    for side, y in (("l", 0.045), ("r", -0.045)):
        _robot_geom(hand, f"robot/finger_{side}", type=_B, size=[(tip - 0.02) / 2 + 0.01, 0.006, 0.012],
                    pos=[0.03 + (tip - 0.02) / 2 - 0.005, y, 0], rgba=[0.15, 0.15, 0.15, 1], mass=0.05)
    hand.add_site(name=GRIP_SITE, pos=[tip, 0, 0], size=[0.01, 0, 0], rgba=[0, 1, 0, 0.6])
    return base


def _base_body(parent, mobile: bool, pose):
    if not mobile:
        return parent.add_body(name="robot/base", pos=[pose[0], pose[1], 0.0], quat=yaw_quat_wxyz(pose[2]),
                               gravcomp=1.0)
    base = parent.add_body(name="robot/base", pos=[0.0, 0.0, 0.0], gravcomp=1.0)
    for name, typ, axis in zip(BASE_JOINTS, (_SLIDE, _SLIDE, _HINGE), ([1, 0, 0], [0, 1, 0], [0, 0, 1]), strict=True):
        base.add_joint(name=name, type=typ, axis=axis, damping=50.0)
    return base


def _add_link(parent, joint: ChainJoint, box, moving: bool):
    """One chain link: a body at the joint's frame, its joint, and its collision box (a robot
    collision geom once the chain moves; before that, a visual part of the base)."""
    body = parent.add_body(name=PREFIX + joint.link, pos=list(joint.pos), quat=list(joint.quat), gravcomp=1.0)
    if joint.kind != "fixed":
        kw = {"range": list(joint.range), "limited": mujoco.mjtLimited.mjLIMITED_TRUE} if joint.range else {}
        body.add_joint(name=PREFIX + joint.name, type=_HINGE if joint.kind == "hinge" else _SLIDE,
                       axis=list(joint.axis), damping=5.0, armature=0.1, **kw)
    if box is None and joint.kind != "fixed":  # a moving body needs mass: a small point mass
        body.explicitinertial = True
        body.mass, body.inertia = 0.1, [1e-4, 1e-4, 1e-4]
    if box is not None:
        kw = {"contype": CT_ROBOT, "conaffinity": CA_ROBOT} if moving else {"contype": 0, "conaffinity": 0}
        body.add_geom(name=PREFIX + joint.link, type=_B, size=list(box.half), pos=list(box.centre),
                      rgba=[0.2, 0.2, 0.22, 1] if moving else [0.5, 0.5, 0.55, 1], mass=0.3, **kw)
    return body


def _add_described_robot(parent, desc: RobotDescription, mobile: bool, pose):
    """A real robot from its description (module doc); returns the base body."""
    base = _base_body(parent, mobile, pose)
    half_h = (desc.base_height - BASE_CLEARANCE) / 2
    _robot_geom(base, BASE_GEOM, type=_CYL, size=[desc.footprint_radius, half_h, 0],
                pos=[0, 0, BASE_CLEARANCE + half_h], rgba=[0.25, 0.3, 0.35, 1], mass=30.0)
    mat = np.array([[0, 0, -1], [-1, 0, 0], [0, 1, 0]], dtype=float)
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, mat.ravel())
    base.add_camera(name="robot/camera", pos=[0.0, 0, desc.camera_height], quat=q.tolist(), fovy=60.0)
    body = base.add_body(name=PREFIX + "mount", pos=list(desc.mount), gravcomp=1.0)
    bodies, moving = {}, False
    for joint in desc.chain:
        moving = moving or joint.kind != "fixed"
        body = bodies[joint.link] = _add_link(body, joint, desc.boxes.get(joint.link), moving)
    for root, chain in desc.fingers:
        b = bodies[root]
        for joint in chain:
            b = _add_link(b, joint, desc.boxes.get(joint.link), True)
    mujoco.mju_mat2Quat(q, np.asarray(desc.grip_rotation, dtype=float).ravel())
    body.add_site(name=GRIP_SITE, pos=[0, 0, 0], quat=q.tolist(), size=[0.01, 0, 0], rgba=[0, 1, 0, 0.6])
    return base


def add_robot_assets(spec: mujoco.MjSpec) -> None:
    """Visual defaults shared by every robot model (no meshes or textures needed)."""
    spec.visual.global_.offwidth = max(spec.visual.global_.offwidth, 640)
    spec.visual.global_.offheight = max(spec.visual.global_.offheight, 480)
