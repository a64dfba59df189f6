import math

import numpy as np
import pytest
from helpers.scenes import GENERIC, START, house, mission, nav

from interllm.config import SimConfig
from interllm.core.actions import Action, State
from interllm.core.results import ActionResult, man_cost, nav_cost
from interllm.planning.search import path_length
from interllm.sim.world import World

# The navigation numbers below are worked out for a base whose contact radius is the map's (less
# half a cell diagonal) on plain shortest paths; tests/test_sim_contacts.py covers the true
# footprint (sim.footprint_radius) and the clearance-weighted search.
MAP_FOOTPRINT = {**GENERIC, "footprint_radius": None, "clearance_cost": 0.0}


@pytest.fixture(scope="module")
def world_open() -> World:
    return World(house(), SimConfig(**MAP_FOOTPRINT))


def test_reset_state_and_pose(world_open):
    w = world_open
    st = w.reset(mission())
    assert st == State("counter_1", "room_a", None)
    assert w.robot_pose == pytest.approx(START)
    assert w.clock == 0.0
    assert w.belief.true.occupied.shape == w.belief.presumed.occupied.shape


def test_straight_corridor_distance_equals_path_length(world_open):
    w = world_open
    w.reset(mission())
    a = w.anchor("sofa_1")
    assert a[1] == pytest.approx(START[1])  # anchor north of the sofa, on the start's row
    planned = w.presumed_path(START[:2], "sofa_1")
    r = w.execute(nav("sofa_1", "room_b"))
    assert r.success and r.collisions == 0 and r.reason == ""
    assert r.distance == pytest.approx(a[0] - START[0])  # a straight line along the row
    assert r.distance == pytest.approx(path_length(r.presumed_path))
    assert np.allclose(r.presumed_path, planned)
    assert np.allclose(r.driven_path[-1], a)
    # straight east from yaw 0: no turns -> t = d / v
    cfg = w.cfg
    assert r.time == pytest.approx(r.distance / cfg.base_speed)
    assert r.cost == pytest.approx(nav_cost(0, r.time, r.distance, cfg.gamma_nav))
    assert w.state == State("sofa_1", "room_b", None)
    assert w.clock == pytest.approx(r.time) and r.t_start == 0.0
    tr = r.trajectory
    assert tr is not None and np.all(np.diff(tr.t) >= 0) and tr.t[-1] == pytest.approx(r.time)
    assert tr.base.shape[1] == 3 and tr.joints.shape[1] == 6


def test_half_closed_door_one_collision_and_replan_through_other_door():
    # door_a's leaf blocks y in [0.5, 1.0]; a persistent map keeps what the navigate learned
    w = World(house(open_a=0.5), SimConfig(persistent_map=True, **MAP_FOOTPRINT))
    w.reset(mission())
    r = w.execute(nav("sofa_1", "room_b"))
    assert r.success, r.reason
    assert r.collisions == 1
    # the presumed path went through door_a, the driven one continues through door_b
    cross_pre = r.presumed_path[np.argmin(np.abs(r.presumed_path[:, 0] - 4.0))]
    assert 0.5 < cross_pre[1] < 1.5
    d = r.driven_path
    crossings = [(d[i], d[i + 1]) for i in range(len(d) - 1) if (d[i][0] - 4.0) * (d[i + 1][0] - 4.0) < 0]
    assert len(crossings) == 1 and 2.5 < crossings[0][0][1] < 3.5
    assert r.distance == pytest.approx(path_length(d))
    assert r.distance > path_length(r.presumed_path) + 1.0
    cfg = w.cfg
    assert r.cost == pytest.approx(nav_cost(1, r.time, r.distance, cfg.gamma_nav))
    assert r.time >= r.distance / cfg.base_speed + cfg.recovery_time
    # the belief map learned the leaf; the truth map is untouched and never used
    leaf_cell = tuple(w.belief.presumed.world_to_cell(np.array([3.9, 0.75])))
    assert w.belief.presumed.occupied[leaf_cell]
    assert np.array_equal(w.belief.true.occupied, World(house(open_a=0.5), SimConfig(**MAP_FOOTPRINT)).belief.true.occupied)
    # the next plan through the area avoids door_a at once
    p = w.presumed_path(START[:2], "sofa_1")
    cross = p[np.argmin(np.abs(p[:, 0] - 4.0))]
    assert 2.5 < cross[1] < 3.5


def test_blocked_everywhere_fails_bounded_and_keeps_state():
    cfg = SimConfig(max_nav_replans=3, **MAP_FOOTPRINT)
    w = World(house(open_a=0.5, open_b=0.45), cfg)
    st0 = w.reset(mission())
    r = w.execute(nav("sofa_1", "room_b"))
    assert not r.success
    assert 1 <= r.collisions <= cfg.max_nav_replans + 1
    assert "navigate(sofa_1, room_b)" in r.reason and "door_" in r.reason
    assert w.state == st0
    assert r.time > 0 and w.clock == pytest.approx(r.time)


def test_bad_navigate_targets_fail_with_reason(world_open):
    w = world_open
    st0 = w.reset(mission())
    r = w.execute(nav("piano_9", "room_b"))
    assert not r.success and "unknown furniture" in r.reason and "sofa_1" in r.reason
    r = w.execute(nav("sofa_1", "room_a"))
    assert not r.success and "is in room room_b" in r.reason
    assert w.state == st0


def test_deep_object_fails_from_every_pose_front_succeeds():
    w = World(house(), SimConfig(**GENERIC))
    w.reset(mission())
    assert w.execute(nav("table_1", "room_b")).success
    deep = w.execute(Action("pickup", "table_1", obj="apple_1"))
    cfg = w.cfg
    assert not deep.success and deep.success_rate == 0.0
    assert len(deep.trials) == cfg.n_l and not any(t.success for t in deep.trials)
    assert "from all 5 sampled base poses" in deep.reason
    assert deep.time == pytest.approx(np.mean([t.time for t in deep.trials]))
    assert deep.cost == pytest.approx(man_cost(0.0, deep.time, cfg.gamma_man))
    assert w.state.holding is None
    front = w.execute(Action("pickup", "table_1", obj="cup_1"))
    assert front.success, front.reason
    assert front.success_rate >= 0.6
    n_ok = sum(t.success for t in front.trials)
    assert front.success_rate == pytest.approx(n_ok / len(front.trials))
    assert front.cost == pytest.approx(man_cost(front.success_rate, front.time, cfg.gamma_man))
    assert all(t.time >= cfg.grasp_time for t in front.trials if t.success)
    # sampled poses: free on the belief map, next to the table, facing the target
    for t in front.trials:
        x, y, yaw = t.base_pose
        assert w.belief.presumed.is_free(w.belief.presumed.world_to_cell(np.array([x, y])))
        assert yaw == pytest.approx(math.atan2(1.9 - y, 6.3 - x), abs=1e-5)
    assert w.state == State("table_1", "room_b", "cup_1")
    assert w.clock == pytest.approx(sum(r.time for r in w.log))


def test_carry_moves_with_gripper_and_place_rests_on_surface():
    w = World(house(), SimConfig(**GENERIC))
    w.reset(mission())
    w.execute(nav("table_1", "room_b"))
    assert w.execute(Action("pickup", "table_1", obj="cup_1")).success

    def rel():
        p_s, r_s = w.physics.grip_pose()
        p_o, _ = w.physics.object_pose("cup_1")
        return r_s.T @ (p_o - p_s)

    off0 = rel()
    assert np.linalg.norm(off0) < 0.05  # grasped at its centre (within tolerance)
    p_before, _ = w.physics.object_pose("cup_1")
    r = w.execute(nav("counter_1", "room_a"))
    assert r.success
    p_after, _ = w.physics.object_pose("cup_1")
    assert np.linalg.norm(p_after[:2] - p_before[:2]) > 3.0  # it travelled with the robot
    assert np.allclose(rel(), off0, atol=1e-9)
    pl = w.execute(Action("place", "counter_1", obj="cup_1"))
    assert pl.success, pl.reason
    o = w.scene.objects["cup_1"]
    f = w.scene.furniture["counter_1"]
    assert o.furniture == "counter_1"
    assert o.position[2] == pytest.approx(f.surface_height + o.size[2] / 2)
    x0, y0, x1, y1 = f.footprint
    assert x0 <= o.position[0] - o.size[0] / 2 and o.position[0] + o.size[0] / 2 <= x1
    assert y0 <= o.position[1] - o.size[1] / 2 and o.position[1] + o.size[1] / 2 <= y1
    assert np.allclose(w.physics.object_pose("cup_1")[0], o.position)
    assert w.state == State("counter_1", "room_a", None)
    # the hand moves away, the object stays
    w.physics.set_arm(np.zeros(6))
    assert np.allclose(w.physics.object_pose("cup_1")[0], o.position)


def test_manipulation_preconditions():
    w = World(house(), SimConfig(**GENERIC))
    w.reset(mission())
    r = w.execute(Action("pickup", "table_1", obj="cup_1"))  # robot is at counter_1
    assert not r.success and "not at table_1" in r.reason and r.trials == []
    r = w.execute(Action("place", "counter_1", obj="cup_1"))
    assert not r.success and "not holding cup_1" in r.reason
    assert w.state == State("counter_1", "room_a", None)


def _run(seed: int) -> list[dict]:
    w = World(house(open_a=0.5), SimConfig(**GENERIC, seed=seed))
    w.reset(mission())
    plan = [nav("sofa_1", "room_b"), nav("table_1", "room_b"), Action("pickup", "table_1", obj="cup_1"),
            nav("counter_1", "room_a"), Action("place", "counter_1", obj="cup_1")]
    return [w.execute(a).to_record() for a in plan]


def test_two_runs_identical_and_records_round_trip():
    a, b = _run(0), _run(0)
    assert a == b
    assert all(x["success"] for x in a)
    r = ActionResult.from_record(a[2])
    assert r.to_record() == a[2]
    assert a[0]["collisions"] == 1
    assert [x["t_start"] for x in a] == pytest.approx(np.cumsum([0] + [x["time"] for x in a[:-1]]).tolist())


def test_the_map_version_names_the_map_paths_are_searched_on(world_open):
    """0 on the initial map; a change gives a number no earlier map had, so a planner that keeps
    path costs per version never reuses one from another map."""
    w = world_open
    assert w.map_version == 0
    seen = {0}
    for _ in range(2):
        w.belief.block_cells((2.0, 1.0), 0.3)
        assert w.map_version not in seen
        seen.add(w.map_version)
        assert w.belief.block_cells((2.0, 1.0), 0.3) == 0 and w.map_version in seen  # nothing changed
        w.belief.reset()
        assert w.map_version == 0
