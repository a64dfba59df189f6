"""Typed results of executing high-level actions in the simulator (paper §IV-B).

c_nav = γ_nav·cc + t + d ;  c_man = γ_man·(1 − sr) + t   (t simulated seconds, d metres).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Optional

import numpy as np

from interllm.core.actions import Action


@dataclass
class Trajectory:
    """What the robot did, sampled over simulated time, for the logger and replay."""

    t: np.ndarray  # [N] simulated time [s], non-decreasing
    base: np.ndarray  # [N, 3] x [m], y [m], yaw [rad]
    joints: np.ndarray  # [N, n_arm_joints] arm joint angles [rad]
    joint_names: tuple[str, ...] = ()

    @staticmethod
    def empty(n_joints: int = 0, joint_names: tuple[str, ...] = ()) -> Trajectory:
        return Trajectory(np.zeros(0), np.zeros((0, 3)), np.zeros((0, n_joints)), joint_names)


@dataclass
class ManipulationTrial:
    """One sampled base pose for a pickup/place: the paper's trial cost c̃(s^l_i)."""

    base_pose: tuple[float, float, float]  # x, y, yaw
    success: bool
    time: float  # [s] simulated
    reason: str = ""  # why it failed ("ik_no_convergence", "collision", "unreachable", ...)
    ik_error: float = 0.0  # [m] final position error


@dataclass(frozen=True)
class ObjectEvent:
    """An object changing hands during an action, for the logger and replay (not a metric).

    frame "grip": the object is held; position/quaternion are its pose in the gripper site frame.
    frame "world": the object was released; position/quaternion are its pose in the world.
    quaternion is (x, y, z, w).
    """

    t: float  # [s] simulated mission time of the grasp / release
    object: str
    frame: str  # GRIP_FRAME | WORLD_FRAME (interllm.core.frames)
    position: tuple[float, float, float]
    quaternion: tuple[float, float, float, float]


@dataclass
class ActionResult:
    action: Action
    success: bool
    cost: float  # c_nav or c_man as defined above
    time: float  # [s] simulated time the action took (t_nav or t_man)
    t_start: float = 0.0  # [s] simulated mission clock when the action started
    collisions: int = 0  # cc_nav (navigate only)
    distance: float = 0.0  # [m] d_nav (navigate only)
    success_rate: float = 1.0  # sr_man = successes / trials (manipulation only)
    trials: list[ManipulationTrial] = field(default_factory=list)
    presumed_path: Optional[np.ndarray] = None  # [N, 2] planned before execution (navigate)
    driven_path: Optional[np.ndarray] = None  # [N, 2] actually driven (navigate)
    reason: str = ""  # failure text an LLM can act on
    trajectory: Optional[Trajectory] = None
    object_events: list[ObjectEvent] = field(default_factory=list)  # grasps / releases (logging only)

    def to_record(self, paths: bool = True) -> dict:
        """JSON-serialisable record (mission records, the run log's /actions); paths as lists of
        [x, y] rounded to 1 um, left out with ``paths=False`` (the run log has them on /path/*)."""
        d = {
            "action": self.action.to_dict(),
            "kind": self.action.kind,
            "success": bool(self.success),
            "cost": float(self.cost),
            "time": float(self.time),
            "t_start": float(self.t_start),
            "collisions": int(self.collisions),
            "distance": float(self.distance),
            "success_rate": float(self.success_rate),
            "trials": [{f.name: getattr(t, f.name) for f in fields(t)} for t in self.trials],  # flat: no deep copy
            "reason": self.reason,
        }
        for k in ("presumed_path", "driven_path") if paths else ():
            v = getattr(self, k)
            d[k] = None if v is None else np.round(np.asarray(v, dtype=float), 6).tolist()
        return d

    @classmethod
    def from_record(cls, d: dict) -> ActionResult:
        """The inverse of ``to_record`` (without the trajectory and object events, which the run
        log holds); every key is required."""
        return cls(
            action=Action.from_dict(d["action"]), success=d["success"], cost=d["cost"],
            time=d["time"], t_start=d["t_start"], collisions=d["collisions"],
            distance=d["distance"], success_rate=d["success_rate"],
            trials=[ManipulationTrial(**{**t, "base_pose": tuple(t["base_pose"])}) for t in d["trials"]],
            presumed_path=None if d["presumed_path"] is None else np.asarray(d["presumed_path"]),
            driven_path=None if d["driven_path"] is None else np.asarray(d["driven_path"]),
            reason=d["reason"])


def nav_cost(collisions: int, time: float, distance: float, gamma_nav: float) -> float:
    """c_nav = γ_nav·cc + t + d."""
    return gamma_nav * collisions + time + distance


def man_cost(success_rate: float, time: float, gamma_man: float) -> float:
    """c_man = γ_man·(1 − sr) + t."""
    return gamma_man * (1.0 - success_rate) + time
