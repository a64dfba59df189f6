"""The robots ``sim.robot`` chooses from: real mobile manipulators' dimensions, with their sources.

A ``RobotDescription`` is data: the base's contact radius and height, and the serial chain from the
arm's mount on the base to the gripper's grasp centre (``urdf_chain.ChainJoint``: frames, axes,
limits), with a collision box per link. ``robot.py`` builds the MuJoCo bodies from it and mink
solves IK over whatever joints the chain has. Where a robot ships a URDF in a PyPI package, the
chain is read from that file at build time (never downloaded at run time).

- ``stretch``: Hello Robot Stretch 3 (SE3, DW3 wrist, SG3 gripper), read from
  ``stretch_urdf/SE3/stretch_description_SE3_eoa_wrist_dw3_tool_sg3.urdf`` of the PyPI package
  ``hello-robot-stretch-urdf==0.1.2`` (installed by ``make install``). Joints: lift (prismatic
  0-1.1 m), four telescoping arm segments (prismatic 0-0.13 m each: 0.52 m), wrist yaw
  (-1.75..4.0 rad), pitch (-1.57..0.56 rad), roll (+-3.14 rad). The arm reaches sideways (base -y).
  Collision boxes: the bounding boxes of the package's collision meshes. Published figures
  (docs.hello-robot.com, Stretch 3 hardware guide): footprint 34 x 33 cm, lift travel 1.1 m,
  arm travel 52 cm.
- ``manipulathor``: AI2-THOR's arm agent (``agentMode="arm"``), the paper's robot, from the
  simulator's source (allenai/ai2thor): body capsule radius 0.2 m, height 1.8 m
  (``PhysicsRemoteFPSAgentController`` ``InitializeBody``); the arm rig's root stands 0.329 m to
  the right of the body axis (``FPSController.prefab``, commit 0026af29, the
  ``robot_arm_rig_gripper`` instance's ``m_LocalPosition.x``; no code moves it but ``MoveArmBase``,
  which moves it vertically) and slides from 0.451 to 1.801 m above the floor (``MoveArmBase``;
  allenact ``manipulathor_plugin/manipulathor_constants.py`` ``ARM_MIN_HEIGHT`` / ``ARM_MAX_HEIGHT``);
  the shoulder is 0.3165 m in front of the root, the upper arm 0.3165 m and the forearm 0.3170 m
  long (``robot_arm_rig_gripper.prefab``, commit 28692f18: ``robot_arm_2_jnt`` .. ``robot_arm_4_jnt``
  local z; ``FK_IK_Solver`` reads its bone lengths from these joints and keeps root and shoulder
  fixed); the hand sphere sits 0.01 m + its radius beyond the wrist (``SetHandSphereRadius``,
  radius 0.04-0.5 m). Not published, so chosen here and said so: a hand-sphere radius of 0.06 m, and
  a pan, shoulder, elbow, wrist-pitch and wrist-roll hinge at the shoulder and wrist for AI2-THOR's
  two-bone IK (the wrist is moved in position and rotation, the elbow swivels).
- ``generic``: the v1 robot of this project (``robot.py``): not a real robot; kept so the results
  made with it can be reproduced.

Departures, for every robot: the base moves holonomically on a planar joint about the footprint's
centre (Stretch drives differentially about its wheel axle); the simulation is kinematic; navigation
checks the base's footprint only (ManipulaTHOR's arm root, 0.13 m outside its body capsule, and
Stretch's arm are not checked while driving).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cache
from importlib import resources
from pathlib import Path

from interllm.config_sim import ROBOTS
from interllm.sim.urdf_chain import ChainJoint, LinkBox, link_boxes, read_chain

STRETCH_PACKAGE = "stretch_urdf"  # import name of the PyPI package hello-robot-stretch-urdf
STRETCH_URDF = "SE3/stretch_description_SE3_eoa_wrist_dw3_tool_sg3.urdf"
@dataclass(frozen=True)
class RobotDescription:
    """A mobile manipulator, as data (module doc). Lengths [m], angles [rad].

    chain: from the arm's mount (whose frame is ``mount`` in the base frame, the base frame's
        origin at the footprint's centre on the floor) to the grasp centre, root first.
    boxes: collision box per chain link (``LinkBox``, in the link frame); links without one
        have no collision geometry.
    fingers: extra fixed chains (root link, joints) hanging off a chain link (the gripper's
        fingers), for collisions.
    tuck: the carry pose, one value per moving joint of ``chain`` (chain order).
    reach_low / reach_high: joint vectors of the lowest, most retracted top-down gripper and of the
        highest, most extended one (``reach`` reads the robot's reach from them by kinematics);
        reach_near: the closest one, horizontally (a telescoping arm cannot reach nearer; an arm
        mounted off the body axis, nearer than its shoulder).
    arm_heading: the direction the arm reaches, in the base frame (0: forward, -pi/2: to the right);
        base poses turn this side to the target.
    grip_rotation: rows of the grasp site's rotation in the chain's last link (site x = approach).
    """

    name: str
    source: str
    footprint_radius: float
    base_height: float
    chain: tuple[ChainJoint, ...]
    mount: tuple[float, float, float]
    boxes: dict[str, LinkBox] = field(default_factory=dict)
    fingers: tuple[tuple[str, tuple[ChainJoint, ...]], ...] = ()
    tuck: tuple[float, ...] = ()
    reach_low: tuple[float, ...] = ()
    reach_high: tuple[float, ...] = ()
    reach_near: tuple[float, ...] = ()  # the configuration that gives radius_min (empty: 0)
    tilts: bool = False  # the arm pitches at the shoulder: it reaches below/above its lift range, less far
    arm_heading: float = 0.0
    grip_rotation: tuple[tuple[float, float, float], ...] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    link_speed: float = 0.1  # [m/s] prismatic joints' speed (hinges: sim.joint_speed)
    camera_height: float = 1.2  # [m] the navigation camera above the floor

    @property
    def joints(self) -> tuple[ChainJoint, ...]:
        """The chain's moving joints, in order."""
        return tuple(j for j in self.chain if j.kind != "fixed")


def stretch_urdf_path() -> Path:
    """The Stretch 3 URDF of the installed ``hello-robot-stretch-urdf`` package; a clear error if
    it is not installed."""
    try:
        root = resources.files(STRETCH_PACKAGE)
    except ModuleNotFoundError as e:
        raise ModuleNotFoundError(
            "sim.robot=stretch needs the PyPI package hello-robot-stretch-urdf (the robot's URDF); "
            "`make install` installs it, or: pip install --no-deps hello-robot-stretch-urdf==0.1.2") from e
    return Path(str(root / STRETCH_URDF))


def stretch() -> RobotDescription:
    """Hello Robot Stretch 3 from its URDF (module doc)."""
    urdf = stretch_urdf_path()
    chain = tuple(read_chain(urdf, "base_link", "link_grasp_center"))
    fingers = tuple(("link_gripper_s3_body",
                     tuple(read_chain(urdf, "link_gripper_s3_body", f"link_gripper_fingertip_{s}")))
                    for s in ("left", "right"))
    links = {j.link for j in chain} | {j.link for _, ch in fingers for j in ch} | {"base_link"}
    boxes = link_boxes(urdf, links)
    base = boxes.pop("base_link")  # the base is the footprint cylinder; its box gives the footprint
    boxes.pop("link_mast", None)  # the mast stands on the base: navigation's business, like the base
    radius = math.hypot(base.half[0], base.half[1])
    # lift, arm l3..l0, wrist yaw, pitch, roll; pitch -1.57: the gripper points down, its grasp centre
    # just outside the retracted arm (at pitch 0 it points along the arm); the grasp centre's frame
    # is then already the site's (x down, y along the base's forward axis): grip_rotation identity
    down = -1.57
    tuck = (0.45, 0.0, 0.0, 0.0, 0.0, 0.0, down, 0.0)
    return RobotDescription(
        name="stretch", source=f"hello-robot-stretch-urdf 0.1.2, {STRETCH_URDF}", footprint_radius=radius,
        base_height=2 * base.half[2], chain=chain, mount=(-base.centre[0], -base.centre[1], 0.0), boxes=boxes,
        fingers=fingers, tuck=tuck, reach_low=(0.0,) * 6 + (down, 0.0), reach_near=(0.0,) * 6 + (down, 0.0),
        reach_high=(1.1, 0.13, 0.13, 0.13, 0.13, 0.0, down, 0.0), arm_heading=-math.pi / 2)


MANIPULATHOR_BODY_RADIUS = 0.2  # [m] capsule collider radius
MANIPULATHOR_ARM_HEIGHT = (0.450998873, 1.8009994)  # [m] arm root above the floor (MoveArmBase 0..1)
MANIPULATHOR_ARM_ROOT = (0.0, -0.329, 0.0)  # [m] arm root in the base frame (x forward, y left)
MANIPULATHOR_ROOT_TO_SHOULDER = 0.31654257  # [m] shoulder in front of the arm root
MANIPULATHOR_UPPER_ARM = 0.31653777  # [m] shoulder to elbow
MANIPULATHOR_FOREARM = 0.3169529  # [m] elbow to wrist
MANIPULATHOR_HAND = 0.01 + 0.06  # [m] wrist to the hand sphere's centre (radius 0.06 m, chosen)


def _box(link: str, length: float, half_width: float) -> LinkBox:
    return LinkBox(link, (length / 2, 0.0, 0.0), (length / 2, half_width, half_width))


def manipulathor() -> RobotDescription:
    """AI2-THOR's arm agent (module doc)."""
    ident = (1.0, 0.0, 0.0, 0.0)
    y, z, x = (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (1.0, 0.0, 0.0)
    shoulder = (MANIPULATHOR_ROOT_TO_SHOULDER, 0.0, 0.0)
    chain = (ChainJoint("arm_base", "arm_base", "slide", (0.0, 0.0, 0.0), ident, z, MANIPULATHOR_ARM_HEIGHT),
             ChainJoint("arm_pan", "shoulder", "hinge", shoulder, ident, z, (-2.9, 2.9)),
             ChainJoint("arm_shoulder", "upper_arm", "hinge", (0.0, 0.0, 0.0), ident, y, (-1.9, 1.9)),
             ChainJoint("arm_elbow", "forearm", "hinge", (MANIPULATHOR_UPPER_ARM, 0.0, 0.0), ident, y, (-2.6, 2.6)),
             ChainJoint("arm_wrist_pitch", "wrist", "hinge", (MANIPULATHOR_FOREARM, 0.0, 0.0), ident, y, (-2.1, 2.1)),
             ChainJoint("arm_wrist_roll", "hand", "hinge", (0.0, 0.0, 0.0), ident, x, (-math.pi, math.pi)),
             ChainJoint("grasp_center", "grasp_center", "fixed", (MANIPULATHOR_HAND, 0.0, 0.0), ident))
    boxes = {"arm_base": _box("arm_base", MANIPULATHOR_ROOT_TO_SHOULDER, 0.03),
             "upper_arm": _box("upper_arm", MANIPULATHOR_UPPER_ARM, 0.03),
             "forearm": _box("forearm", MANIPULATHOR_FOREARM, 0.025),
             "hand": _box("hand", MANIPULATHOR_HAND - 0.02, 0.02)}
    return RobotDescription(
        name="manipulathor", source="AI2-THOR arm agent (ai2thor ArmAgentController; allenact manipulathor_plugin)",
        footprint_radius=MANIPULATHOR_BODY_RADIUS, base_height=0.3, chain=chain, mount=MANIPULATHOR_ARM_ROOT,
        boxes=boxes, tuck=(0.9, 0.0, -1.5, 2.6, 1.0, 0.0),
        reach_low=(MANIPULATHOR_ARM_HEIGHT[0], 0.0, 0.0, 0.0, math.pi / 2, 0.0),
        # the arm hanging straight down: the grasp centre under the shoulder, the nearest (horizontally)
        # a target can be while in front of it (AI2-THOR refuses targets behind the shoulder)
        reach_near=(MANIPULATHOR_ARM_HEIGHT[1], 0.0, math.pi / 2, 0.0, 0.0, 0.0),
        reach_high=(MANIPULATHOR_ARM_HEIGHT[1], 0.0, 0.0, 0.0, math.pi / 2, 0.0), tilts=True, camera_height=1.576)


@cache
def describe(name: str) -> RobotDescription | None:
    """The description of robot ``name`` (``sim.robot``); None for ``generic`` (built by ``robot.py``)."""
    if name not in ROBOTS:
        raise ValueError(f"sim.robot: {name!r} is not a robot; choose one of {list(ROBOTS)}")
    if name == "generic":
        return None
    return stretch() if name == "stretch" else manipulathor()
