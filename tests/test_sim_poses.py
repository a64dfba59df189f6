"""Manipulation as the paper samples it (``sim.pose_protocol=reach``): N_l distinct free base
poses within the arm's reach that the robot can drive to, each a full trial with everything
within reach in the IK model. Tiny scenes built here; expectations worked out from the arm's
dimensions (``sim/robot.py``)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers.scenes import FRONT, GENERIC, kitchen

from interllm.config import SimConfig
from interllm.core.actions import Action
from interllm.scene.graph import Door, Furniture, Mission, Room, SceneGraph, SceneObject, Wall
from interllm.sim import arm_ik, trials
from interllm.sim.base_poses import PRE_GRASP_HEIGHT, BasePose, arm_reach, pose_radius, reach_poses
from interllm.sim.grasp_goals import GRASP_MIN_HEIGHT
from interllm.sim.robot import FOREARM, SHOULDER_FORWARD, SHOULDER_HEIGHT, TUCK, UPPER_ARM, WRIST_TO_GRIP
from interllm.sim.world import World


def reach_world(n_l: int = 20) -> World:
    w = World(kitchen(), SimConfig(**GENERIC, pose_protocol="reach", n_l=n_l, pose_margin=0.25))  # poses on both sides of reach
    w.reset(Mission("m", "kitchen", (2.0, 1.5, 0.0), "counter_1", ()))
    return w


def horizontal_reach(target_z: float) -> float:
    """[m] farthest base-to-target distance from which the wrist, held WRIST_TO_GRIP plus the
    pre-grasp height above a top-down target, is within the arm's two links of the shoulder."""
    dz = target_z + PRE_GRASP_HEIGHT + WRIST_TO_GRIP - SHOULDER_HEIGHT
    return math.sqrt((UPPER_ARM + FOREARM) ** 2 - dz ** 2) + SHOULDER_FORWARD


def test_the_pose_region_is_the_arms_reach_at_the_targets_height_plus_the_margin():
    cfg = SimConfig(**GENERIC, pose_protocol="reach", pose_margin=0.05)
    assert arm_reach(0.95) == pytest.approx(horizontal_reach(0.95))
    assert arm_reach(1.5) < arm_reach(0.95) < arm_reach(0.5)  # high shelves and low tables reach less far
    assert pose_radius(cfg, 0.95) == pytest.approx(horizontal_reach(0.95) + 0.05)
    assert pose_radius(SimConfig(**GENERIC, pose_margin=1.0), 0.95) == SimConfig(**GENERIC).pose_reach  # capped


def test_reach_poses_are_distinct_free_within_reach_and_driven_to():
    w = reach_world()
    act = Action("pickup", "counter_1", obj="mug_front")
    radius = 0.8  # the cap, sim.pose_reach: more cells than the arm reaches, for this geometric test
    poses = reach_poses(w.belief.presumed, w.belief.true, FRONT, (2.0, 1.5), action=act, n=20, cfg=w.cfg,
                        radius=radius)
    assert len(poses) == 20 and all(p.free for p in poses)
    assert len({(p.x, p.y) for p in poses}) == 20  # without replacement
    for p in poses:
        rc = w.belief.true.world_to_cell(np.array([p.x, p.y]))
        assert w.belief.true.is_free(rc) and w.belief.presumed.is_free(rc)
        assert math.hypot(p.x - FRONT[0], p.y - FRONT[1]) <= radius + 1e-9
        assert p.yaw == pytest.approx(math.atan2(FRONT[1] - p.y, FRONT[0] - p.x))
    # a tour: each leg is at least the straight line from the previous stop
    prev = (2.0, 1.5)
    for p in poses:
        assert p.drive >= math.hypot(p.x - prev[0], p.y - prev[1]) - 0.05
        prev = (p.x, p.y)
    assert poses == reach_poses(w.belief.presumed, w.belief.true, FRONT, (2.0, 1.5), action=act, n=20, cfg=w.cfg,
                                radius=radius)


def test_a_pose_in_a_pocket_is_never_drawn():
    """Free cells within reach but walled off from the robot on its map are not poses."""
    w = reach_world()
    g = w.belief.presumed
    # a 0.3 x 0.3 m free patch at x in [1.45, 1.75], y in [1.45, 1.75] fenced by a 1-cell ring
    fence = np.zeros(g.shape, dtype=bool)
    lo, hi = g.world_to_cell(np.array([1.40, 1.40])), g.world_to_cell(np.array([1.80, 1.80]))
    fence[lo[0]:hi[0] + 1, lo[1]:hi[1] + 1] = True
    fence[lo[0] + 1:hi[0], lo[1] + 1:hi[1]] = False
    g.occupied |= fence
    patch = [(r, c) for r in range(lo[0] + 1, hi[0]) for c in range(lo[1] + 1, hi[1])]
    pts = g.cell_to_world(np.array(patch))
    assert all(g.is_free(rc) for rc in patch)
    assert (np.hypot(pts[:, 0] - FRONT[0], pts[:, 1] - FRONT[1]) <= 0.8).any()
    act = Action("pickup", "counter_1", obj="mug_front")
    poses = reach_poses(g, w.belief.true, FRONT, (2.0, 1.5), action=act, n=50, cfg=w.cfg, radius=0.8)
    drawn = {tuple(int(v) for v in g.world_to_cell(np.array([p.x, p.y]))) for p in poses if p.free}
    assert len(drawn) == 50 and not drawn & set(patch)


def test_an_object_at_the_back_of_a_deep_counter_succeeds_from_exactly_the_poses_that_reach_it():
    w = reach_world()
    reach = horizontal_reach(0.95)  # 0.54 m for this counter
    front = w.execute(Action("pickup", "counter_1", obj="mug_front"))
    assert 0.0 < front.success_rate < 1.0, [t.reason for t in front.trials]
    assert front.success_rate == sum(t.success for t in front.trials) / w.cfg.n_l
    for t in front.trials:
        d = math.hypot(t.base_pose[0] - FRONT[0], t.base_pose[1] - FRONT[1])
        if d <= reach - 0.02:
            assert t.success, (d, t)
        if d >= reach + 0.03:
            assert not t.success, (d, t)
    # executed from the first successful pose of the tour: the robot stands there now
    first = next(t for t in front.trials if t.success)
    assert w.robot_pose[:2] == pytest.approx(first.base_pose[:2])
    # the back of the counter is 0.95 m from the nearest free cell: no pose within reach at all
    w2 = reach_world()
    back = w2.execute(Action("pickup", "counter_1", obj="mug_back"))
    assert not back.success and back.success_rate == 0.0
    assert {t.reason for t in back.trials} == {"no_free_pose"} and len(back.trials) == w2.cfg.n_l


def test_trial_time_includes_the_drive_to_the_pose():
    w = reach_world()
    act = Action("pickup", "counter_1", obj="mug_front")
    poses = reach_poses(w.belief.presumed, w.belief.true, FRONT, w.robot_pose[:2], action=act, n=w.cfg.n_l,
                        cfg=w.cfg, radius=pose_radius(w.cfg, 0.95))
    res = w.execute(act)
    assert [t.base_pose for t in res.trials] == [tuple(round(v, 6) for v in p.pose) for p in poses]
    for p, t in zip(poses, res.trials, strict=True):
        assert t.time >= p.drive / w.cfg.base_speed + (w.cfg.grasp_time if t.success else 0.0)
    assert res.time == pytest.approx(np.mean([t.time for t in res.trials]))


def two_rooms() -> SceneGraph:
    """Rooms a | b split by the wall x = 4 (door at y in [3.0, 3.8]); a side table in b against
    the wall with a cup 0.2 m from it."""
    sg = SceneGraph(id="two", seed=0)
    sg.rooms["a"] = Room("a", "kitchen", ((0, 0), (4, 0), (4, 4), (0, 4)))
    sg.rooms["b"] = Room("b", "living_room", ((4, 0), (8, 0), (8, 4), (4, 4)))
    segs = [((0, 0), (8, 0)), ((0, 4), (8, 4)), ((0, 0), (0, 4)), ((8, 0), (8, 4)), ((4, 0), (4, 3.0)),
            ((4, 3.8), (4, 4))]
    for i, (a, b) in enumerate(segs):
        sg.walls[f"wall_{i}"] = Wall(f"wall_{i}", a, b, 0.1, 2.5)
    sg.doors["door_1"] = Door("door_1", ("a", "b"), (4, 3.4), "y", 0.8)
    sg.furniture["table_1"] = Furniture("table_1", "side_table", "b", (4.4, 1.5), (0.6, 0.6, 0.75))
    sg.objects["cup_1"] = SceneObject("cup_1", "cup", "table_1", (4.2, 1.5, 0.8), (0.08, 0.08, 0.1))
    return sg


def test_an_arm_through_a_wall_is_a_failed_trial():
    """From room a, 0.5 m from the cup, the arm reaches it only through the wall: the trial
    succeeds in an IK model without walls and fails in the reach protocol's, which has them."""
    sg = two_rooms()
    o = sg.objects["cup_1"]
    half = np.asarray(o.size) / 2
    inside = (np.asarray(o.position) - half, np.asarray(o.position) + half + [0, 0, GRASP_MIN_HEIGHT])
    target = np.asarray(o.position, dtype=float)
    pose = BasePose(3.7, 1.5, 0.0)
    outcomes = {}
    for protocol in ("window", "reach"):
        cfg = SimConfig(**GENERIC, pose_protocol=protocol)
        ik = arm_ik.build_local_ik(sg, "table_1", cfg)
        trial, _ = trials.run_trial(cfg, ik, pose, target, inside, ik.obstacles(but=("cup_1",)))
        outcomes[protocol] = (trial.success, len(ik.structure_geoms))
    assert outcomes["window"] == (True, 0)  # the window protocol's model: no walls, the arm passes through
    assert outcomes["reach"][0] is False and outcomes["reach"][1] >= 1


def _cup_trial(cfg: SimConfig, neighbour: bool):
    """One pickup trial of cup_1 on a free-standing table from 0.5 m in front of it, with or
    without a 0.3 m tall box 3 cm beside the cup."""
    sg = SceneGraph(id="table", seed=0)
    sg.rooms["r"] = Room("r", "living_room", ((0, 0), (4, 0), (4, 4), (0, 4)))
    sg.furniture["table_1"] = Furniture("table_1", "side_table", "r", (2.0, 2.0), (0.6, 0.6, 0.75))
    sg.objects["cup_1"] = SceneObject("cup_1", "cup", "table_1", (2.0, 1.9, 0.8), (0.08, 0.08, 0.1))
    if neighbour:  # its near face 3 cm from the cup's side
        sg.objects["box_1"] = SceneObject("box_1", "box", "table_1", (2.17, 1.9, 0.9), (0.12, 0.12, 0.3))
    o = sg.objects["cup_1"]
    half = np.asarray(o.size) / 2
    inside = (np.asarray(o.position) - half, np.asarray(o.position) + half + [0, 0, GRASP_MIN_HEIGHT])
    ik = arm_ik.build_local_ik(sg, "table_1", cfg)
    trial, sol = trials.run_trial(cfg, ik, BasePose(2.0, 1.4, math.pi / 2), np.asarray(o.position, dtype=float),
                                  inside, ik.obstacles(but=("cup_1",)))
    return trial, sol, ik


def test_the_arm_slows_down_near_obstacles_so_clutter_costs_time():
    constant = SimConfig(**GENERIC, arm_slow_distance=0.0)
    slowing = SimConfig(**GENERIC)  # arm_slow_distance 0.15 m, arm_min_speed 0.2
    # without slowing, the arm time is the joint-space path length over joint_speed, exactly
    trial, (q_pre, q_grasp), ik = _cup_trial(constant, neighbour=False)
    assert trial.success
    length = float(np.linalg.norm(q_pre - TUCK) + np.linalg.norm(q_grasp - q_pre))
    assert trial.time == pytest.approx(length / constant.joint_speed + constant.grasp_time)
    # the cup alone on the table: nothing but the table near the arm, and the table does not slow it
    open_trial, _, _ = _cup_trial(slowing, neighbour=False)
    assert open_trial.time == pytest.approx(trial.time)
    # at the grasp the fingers are 2 cm above the table top: the table is within arm_slow_distance
    table = list(ik.support_geoms)
    assert arm_ik.arm_clearance(ik, q_grasp, table, slowing.arm_slow_distance) == pytest.approx(0.045, abs=0.01)
    assert arm_ik.arm_clearance(ik, TUCK, table, 0.1) == 0.1  # tucked: 0.14 m above the table edge
    # were it an obstacle, the descent would be slower than in free space, but never slower than
    # at the minimum speed throughout
    leg = float(np.linalg.norm(q_grasp - q_pre))
    t_leg = arm_ik.arm_motion_time(slowing, ik, q_pre, q_grasp, table)
    assert leg / slowing.joint_speed < t_leg <= leg / (slowing.joint_speed * slowing.arm_min_speed) + 1e-9
    # the same cup with a tall box 3 cm beside it: still a success, and slower by more than 0.3 s
    cluttered, _, _ = _cup_trial(slowing, neighbour=True)
    assert cluttered.success
    assert cluttered.time > open_trial.time + 0.3, (open_trial.time, cluttered.time)
