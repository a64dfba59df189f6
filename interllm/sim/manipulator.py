"""Execute ``pickup(object, furniture)`` and ``place(object, furniture)`` with mink IK
(paper §IV-B eq. 2: the empirical manipulation cost is the mean of N_l trial costs).

For an action at a furniture:
1. sample ``sim.n_l`` base poses by ``sim.pose_protocol`` (``sim/base_poses.py``): ``window``
   (a 15 cm window next to the target, drawn with replacement) or ``reach`` (the paper's: distinct
   free cells within the arm's reach of the target that the robot can drive to, visited in a tour
   whose driving time each trial includes);
2. per pose, solve IK with mink on a small dedicated model (``sim/arm_ik.py``: fixed-base robot
   with its six arm joints, the furniture and the objects on it — in the ``reach`` protocol also
   the walls, door leaves and neighbouring furniture with their objects within
   ``IK_NEIGHBOURHOOD``; built once per layout and cached):
   a pre-grasp pose 0.10 m above the target, then the grasp pose, both top-down (gripper
   approach axis pointing down), with joint limits (``mink.ConfigurationLimit``) and
   collision avoidance between the arm and the furniture / other objects
   (``mink.CollisionAvoidanceLimit``);
3. a trial succeeds when both solves converge (position error <= ``sim.ik_tol`` [m], orientation
   error <= ``ROT_TOL`` [rad]) within ``sim.ik_max_iters`` iterations, the final arm has no
   contact with the furniture or another object, and the target is inside the gripper
   (``sim/trials.py``);
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
from; ``World.state.holding`` is the truth. Where the gripper goes: ``sim/grasp_goals.py``.

``Manipulator`` owns the cache of the small IK models (one per furniture layout).
"""

from __future__ import annotations

from typing import Optional

import numpy as np

from interllm.config import SimConfig
from interllm.core.actions import Action, State
from interllm.core.frames import GRIP_FRAME, WORLD_FRAME, wxyz_to_xyzw
from interllm.core.results import ActionResult, ObjectEvent
from interllm.scene.graph import SceneGraph
from interllm.sim.arm_ik import LocalIK, build_local_ik, ik_neighbourhood, layout_key
from interllm.sim.base_poses import sample_base_poses
from interllm.sim.belief import BeliefMap
from interllm.sim.grasp_goals import Goal, pickup_goal, place_goal, why_the_state_forbids
from interllm.sim.physics import MujocoWorld
from interllm.sim.trials import precondition_failure, run_trials, trials_result


def _execute_motion(physics: MujocoWorld, pose, q_pre, q_grasp, t0: float, duration: float, at_grasp) -> list:
    """Play tuck -> pre -> grasp -> (at_grasp) -> pre -> tuck in the world; returns samples
    spread over [t0, t0 + duration]."""
    physics.set_base(*pose)
    tuck = physics.parts.tuck
    legs = [(tuck, q_pre), (q_pre, q_grasp), (q_grasp, q_pre), (q_pre, tuck)]
    lens = [float(np.linalg.norm(b - a)) for a, b in legs]
    total = sum(lens) or 1.0
    samples = []
    t = t0
    physics.set_arm(tuck)
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
        return layout_key(scene, furniture_id, exclude, ik_neighbourhood(self.cfg))

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

    def _trials(self, belief: BeliefMap, scene: SceneGraph, action: Action, goal: Goal, robot_xy) -> tuple:
        """Steps 1-3 and 5 of the module doc from ``robot_xy`` [m]: (result, poses, per-trial IK
        solutions, index of the first successful trial or -1). Touches neither the world nor the scene."""
        cfg = self.cfg
        poses = sample_base_poses(cfg, belief.presumed, belief.true, scene.furniture[action.furniture], goal.target,
                                  robot_xy=(float(robot_xy[0]), float(robot_xy[1])), action=action, n=cfg.n_l)
        if not poses:
            res = precondition_failure(cfg, action, f"no free base pose next to {action.furniture} on the robot's map")
            return res, [], [], -1
        ik = self.local_ik(scene, action.furniture, exclude=goal.ik_exclude)
        trials, sols = run_trials(cfg, ik, poses, goal.target, goal.inside, ik.obstacles(but=(action.obj,)))
        res, k = trials_result(cfg, action, trials, goal.what_failed)
        return res, poses, sols, k

    def _trials_then_motion(self, physics: MujocoWorld, belief: BeliefMap, scene: SceneGraph, clock: float,
                            action: Action, goal: Goal, at_grasp) -> ActionResult:
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
        goal = pickup_goal(scene, action) if action.kind == "pickup" else place_goal(scene, action, robot_xy)
        if isinstance(goal, str):
            return None
        return self._trials(belief, scene, action, goal, robot_xy)[0]

    def pickup(self, physics: MujocoWorld, belief: BeliefMap, scene: SceneGraph, state: State, clock: float,
               action: Action) -> ActionResult:
        """Pick up ``action.obj`` from ``action.furniture`` (see the module doc), starting at ``clock`` [s]."""
        if action.kind != "pickup":
            raise ValueError(f"Manipulator.pickup got a {action.kind!r} action: {action}")
        why = why_the_state_forbids(state, action, holding=None)
        goal = pickup_goal(scene, action) if not why else why
        if isinstance(goal, str):
            return precondition_failure(self.cfg, action, goal)

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
        why = why_the_state_forbids(state, action, holding=action.obj)
        goal = place_goal(scene, action, (x, y)) if not why else why
        if isinstance(goal, str):
            return precondition_failure(self.cfg, action, goal)
        spot = goal.spot

        def release(res: ActionResult, t: float):
            physics.release()
            pos = (float(spot[0]), float(spot[1]), float(spot[2]))
            scene.move_object(action.obj, action.furniture, pos)
            physics.set_object_pose(action.obj, pos)
            res.object_events.append(ObjectEvent(t, action.obj, WORLD_FRAME, pos, (0.0, 0.0, 0.0, 1.0)))

        return self._trials_then_motion(physics, belief, scene, clock, action, goal, release)
