"""The N_l trials of a manipulation and their outcome (paper §IV-B eq. 2).

A trial from one base pose: pose the fixed base of the local IK model there, solve the
pre-grasp pose ``PRE_GRASP_HEIGHT`` above the target, then the grasp pose (both top-down), and
check that the final arm touches no obstacle and the grip site is inside the target box (within
``INSIDE_MARGIN``). Its time [s] is the drive to the pose / base_speed + the arm motion
(tuck -> pre-grasp -> grasp, ``arm_ik.arm_motion_time``) + grasp_time when it succeeded; a failed
trial counts the drive and the motion it made. ``trials_result``: sr = successes / trials,
t = mean trial time, c_man = γ_man·(1 − sr) + t.
"""

from __future__ import annotations

from typing import Optional

import numpy as np

from interllm.config import SimConfig
from interllm.core.actions import Action
from interllm.core.frames import yaw_quat_wxyz
from interllm.core.results import ActionResult, ManipulationTrial, man_cost
from interllm.sim.arm_ik import LocalIK, arm_motion_time, arm_touches, solve_ik, topdown_rotation
from interllm.sim.base_poses import PRE_GRASP_HEIGHT, BasePose

INSIDE_MARGIN = 0.02  # [m] the gripper site may be this far outside the object's box


def run_trials(cfg: SimConfig, ik: LocalIK, poses: list[BasePose], target: np.ndarray, inside_box,
               avoid: list[int]):
    """One trial per base pose; returns (trials, per-trial (q_pre, q_grasp) or None)."""
    trials: list[ManipulationTrial] = []
    sols: list[Optional[tuple[np.ndarray, np.ndarray]]] = []
    for bp in poses:
        trial, sol = run_trial(cfg, ik, bp, target, inside_box, avoid)
        trials.append(trial)
        sols.append(sol)
    return trials, sols


def run_trial(cfg: SimConfig, ik: LocalIK, bp: BasePose, target: np.ndarray, inside_box, avoid: list[int]):
    """One trial from base pose ``bp``: drive there, pre-grasp and grasp IK, contact and grip checks.
    Returns (ManipulationTrial, (q_pre, q_grasp) or None); time [s] = drive + arm motion (+ grasp)."""
    pose = (round(bp.x, 6), round(bp.y, 6), round(bp.yaw, 6))
    drive_s = bp.drive / cfg.base_speed
    if not bp.free:
        return ManipulationTrial(pose, False, 0.0, "no_free_pose", 0.0), None
    ik.model.body_pos[ik.base_body] = (bp.x, bp.y, 0.0)
    ik.model.body_quat[ik.base_body] = yaw_quat_wxyz(bp.yaw)
    reach_yaw = None if ik.parts.reach is None else bp.yaw + ik.parts.heading
    rot = topdown_rotation((bp.x, bp.y), target[:2], reach_yaw)
    near = [g for g in avoid if g not in ik.support_geoms]  # what slows the arm: not the surface every grasp ends on
    tuck = ik.parts.tuck
    s1 = solve_ik(ik, tuck, target + np.array([0.0, 0.0, PRE_GRASP_HEIGHT]), rot, cfg, avoid)
    t_arm = arm_motion_time(cfg, ik, tuck, s1.q, near)
    if not s1.converged:
        return ManipulationTrial(pose, False, drive_s + t_arm, s1.reason, round(s1.pos_err, 6)), None
    s2 = solve_ik(ik, s1.q, target, rot, cfg, avoid)
    t_fail = drive_s + t_arm + arm_motion_time(cfg, ik, s1.q, s2.q, near)
    if not s2.converged:
        return ManipulationTrial(pose, False, t_fail, s2.reason, round(s2.pos_err, 6)), None
    obstacles = set(avoid)
    if arm_touches(ik, s1.q, obstacles) or arm_touches(ik, s2.q, obstacles):
        return ManipulationTrial(pose, False, t_fail, "collision", round(s2.pos_err, 6)), None
    ik.configuration.update(s2.q)
    site = ik.configuration.data.site_xpos[ik.grip_site]
    lo, hi = inside_box
    if not (np.all(site >= lo - INSIDE_MARGIN) and np.all(site <= hi + INSIDE_MARGIN)):
        return ManipulationTrial(pose, False, t_fail, "not_in_gripper", round(s2.pos_err, 6)), None
    return ManipulationTrial(pose, True, t_fail + cfg.grasp_time, "", round(s2.pos_err, 6)), (s1.q, s2.q)


def precondition_failure(cfg: SimConfig, action: Action, reason: str) -> ActionResult:
    """The result of a manipulation that could not be tried: no trial, success rate 0."""
    return ActionResult(action=action, success=False, cost=man_cost(0.0, 0.0, cfg.gamma_man), time=0.0,
                        success_rate=0.0, reason=f"{action}: {reason}")


def trials_result(cfg: SimConfig, action: Action, trials, reason_fail: str) -> tuple[ActionResult, int]:
    """The action's result from its trials, and the index of the first successful trial (-1: none)."""
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
