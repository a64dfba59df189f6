"""The simulator's configuration (``sim.*``): the robot, its map, navigation and manipulation.

Units are in the field comments: metres [m], seconds [s], radians [rad]. ``sim.robot`` names a
robot description of ``interllm/sim/robots.py`` (its dimensions, with their sources, are there);
the Hydra group ``conf/sim/robot/<name>.yaml`` sets it together with the radii that go with it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from interllm.config_types import check as _check
from interllm.config_types import choice as _choice

POSE_PROTOCOLS = ("window", "reach")  # sim.pose_protocol: a small window by the furniture, the paper's reach (interllm/sim/base_poses.py)
# sim.robot: the robot descriptions of interllm/sim/robots.py (a test keeps the two lists equal)
ROBOTS = ("generic", "manipulathor", "stretch")


@dataclass
class SimConfig:
    # the mobile manipulator (interllm/sim/robots.py: dimensions and their sources); set it with the
    # Hydra group sim/robot=<name>, which also sets the two radii below to the robot's footprint
    robot: str = "manipulathor"
    # [m] the radius the robot's map is inflated by (what the planner assumes): 0.05 m less than the
    # robot's true footprint, so the map is a little optimistic and a tight passage can cost a collision
    robot_radius: float = 0.15
    # [m] the base's true contact radius in MuJoCo (ManipulaTHOR's body capsule); null: robot_radius
    # less half a grid cell's diagonal, so a cell the map calls free never touches a wall or furniture
    footprint_radius: Optional[float] = 0.2
    # path search cost per metre grows by this factor next to obstacles (0: plain shortest paths);
    # the extra falls linearly from clearance_cost at the inflated obstacle to 0 at clearance_band [m]
    clearance_cost: float = 2.0
    clearance_band: float = 0.2
    base_speed: float = 0.5  # [m/s]
    turn_speed: float = 1.5  # [rad/s]
    step: float = 0.05  # [m] one move-forward control
    turn: float = 0.785398  # [rad] one turn control (45°)
    recovery_time: float = 3.0  # [s] backing off after a collision
    backoff: float = 0.15  # [m]
    max_nav_replans: int = 6  # bounded replans after collisions per navigate action
    # false (the paper's protocol): each navigate starts from the prior map; what a
    # planner learns of navigation is what its known costs record. true (ablation): cells where the
    # robot collided stay blocked on its map for the rest of the mission, for every planner
    persistent_map: bool = False
    n_l: int = 5  # sampled base poses per manipulation (paper's N_l)
    pose_protocol: str = "reach"  # how the N_l base poses are drawn: one of POSE_PROTOCOLS (sim/base_poses.py)
    # [m] reach protocol: base centres at most this far (horizontal) from the target; a cap above the
    # default robot's reach (ManipulaTHOR: 1.01 m from the body axis to the grasp centre, its shoulder
    # 0.46 m off it); conf/sim/robot/{generic,stretch}.yaml keep 0.8, above their reach too
    pose_reach: float = 1.2
    pose_margin: float = 0.025  # [m] reach protocol: candidates this far beyond the arm's reach at the target height
    ik_max_iters: int = 150
    ik_tol: float = 0.015  # [m] position tolerance of IK convergence
    ik_dt: float = 0.05  # [s] IK integration step
    joint_speed: float = 1.0  # [rad/s] arm joint velocity limit (trial time)
    # [m] the arm slows down within this distance of an obstacle (speed and separation monitoring),
    # so clutter, shelves and walls show in the manipulation time; 0: constant joint_speed
    arm_slow_distance: float = 0.15
    arm_min_speed: float = 0.2  # share of joint_speed the arm keeps at contact distance
    grasp_time: float = 2.0  # [s] closing / opening the gripper
    gamma_nav: float = 10.0  # collision-count normalising factor γ_nav
    gamma_man: float = 100.0  # failure-rate normalising factor γ_man
    seed: int = 0

    def validate(self) -> None:
        _choice(self.robot, "sim.robot", ROBOTS)
        _check(0.05 <= self.robot_radius <= 1.0, "sim.robot_radius", "must be in [0.05, 1] m")
        _check(self.footprint_radius is None or 0.05 <= self.footprint_radius <= 1.0, "sim.footprint_radius",
               f"must be null or in [0.05, 1] m, got {self.footprint_radius}")
        _check(0.0 <= self.clearance_cost <= 100.0, "sim.clearance_cost", f"must be in [0, 100], got {self.clearance_cost}")
        _check(0.0 < self.clearance_band <= 2.0, "sim.clearance_band", f"must be in (0, 2] m, got {self.clearance_band}")
        _check(self.base_speed > 0, "sim.base_speed", "must be > 0")
        _check(self.turn_speed > 0, "sim.turn_speed", "must be > 0")
        _check(0.005 <= self.step <= 0.5, "sim.step", "must be in [0.005, 0.5] m")
        _check(1 <= self.n_l <= 50, "sim.n_l", f"must be in [1, 50], got {self.n_l}")
        _choice(self.pose_protocol, "sim.pose_protocol", POSE_PROTOCOLS)
        _check(self.robot_radius < self.pose_reach <= 2.0, "sim.pose_reach",
               f"must be in (sim.robot_radius, 2] m, got {self.pose_reach}")
        _check(0.0 <= self.pose_margin <= 1.0, "sim.pose_margin", f"must be in [0, 1] m, got {self.pose_margin}")
        _check(0 <= self.max_nav_replans <= 50, "sim.max_nav_replans", "must be in [0, 50]")
        _check(self.ik_max_iters >= 1, "sim.ik_max_iters", "must be >= 1")
        _check(self.joint_speed > 0, "sim.joint_speed", f"must be > 0 rad/s, got {self.joint_speed}")
        _check(0.0 <= self.arm_slow_distance <= 0.5, "sim.arm_slow_distance",
               f"must be in [0, 0.5] m (0: constant speed), got {self.arm_slow_distance}")
        _check(0.0 < self.arm_min_speed <= 1.0, "sim.arm_min_speed", f"must be in (0, 1], got {self.arm_min_speed}")
        _check(self.gamma_nav >= 0 and self.gamma_man >= 0, "sim.gamma_nav",
               "gamma_nav and gamma_man must be >= 0")
