"""The robot in the run log: arm forward kinematics on /tf, objects moving on /scene, and the
rerun replay of both, checked against MuJoCo's own kinematics of the full house model."""

from __future__ import annotations

import math

import numpy as np
import pytest
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.SceneEntityDeletion_pb2 import SceneEntityDeletion
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from helpers.recording import make_actions, make_scene, rerun_cli, run_cli
from helpers.scenes import GENERIC, house, mission, nav
from mcap.reader import make_reader

from interllm.config import SimConfig
from interllm.core.actions import Action
from interllm.core.frames import GRIP_FRAME
from interllm.record import McapRecorder, read_run, replay
from interllm.sim.kinematics import RobotKinematics, quat_mul_xyzw
from interllm.sim.robot import ARM_JOINTS
from interllm.sim.world import World

pytest.importorskip("mujoco")


def _rot(q) -> np.ndarray:
    """(x, y, z, w) -> 3x3 rotation matrix."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _compose(chain_poses: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """World pose (p, R) of the last frame of a chain of relative (xyz, quat_xyzw) poses."""
    p, r = np.zeros(3), np.eye(3)
    for xyz, q in chain_poses:
        p = p + r @ np.asarray(xyz, dtype=float)
        r = r @ _rot(q)
    return p, r


def _base_pose(x, y, yaw):
    return np.array([x, y, 0.0]), np.array([0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])


@pytest.fixture(scope="module")
def kin():
    return RobotKinematics(SimConfig(**GENERIC))


def test_chain_matches_mujoco_on_the_full_house_model(kin):
    w = World(house(), SimConfig(**GENERIC))
    w.reset(mission())
    rng = np.random.default_rng(0)
    m, d = w.physics.model, w.physics.data
    for _ in range(20):
        base = (rng.uniform(1, 3), rng.uniform(1, 3), rng.uniform(-math.pi, math.pi))
        q = rng.uniform(-1.5, 1.5, size=6)
        w.physics.set_base(*base)
        w.physics.set_arm(q)
        t, quat = kin.link_poses(q)
        poses = {"base_link": [_base_pose(*base)]}
        for i, (parent, child) in enumerate(kin.chain):
            poses[child] = poses[parent] + [(t[i], quat[i])]
        for child in kin.frames:
            p, r = _compose(poses[child])
            if child == GRIP_FRAME:
                want_p, want_r = w.physics.grip_pose()
            else:
                bid = m.body(f"robot/{child}").id
                want_p, want_r = d.xpos[bid], d.xmat[bid].reshape(3, 3)
            np.testing.assert_allclose(p, want_p, atol=1e-9, err_msg=child)
            np.testing.assert_allclose(r, want_r, atol=1e-9, err_msg=child)


def test_link_poses_batch_equals_single_and_quaternions_are_unit(kin):
    q = np.random.default_rng(1).uniform(-2, 2, size=(7, 6))
    t, quat = kin.link_poses(q)
    assert t.shape == (7, len(kin.chain), 3) and quat.shape == (7, len(kin.chain), 4)
    np.testing.assert_allclose(np.linalg.norm(quat, axis=-1), 1.0, atol=1e-12)
    t3, q3 = kin.link_poses(q[3])
    np.testing.assert_array_equal(t3, t[3])
    np.testing.assert_array_equal(q3, quat[3])
    # hand roll (joint 6) turns the hand about its x axis and nothing else
    a, b = kin.link_poses(np.zeros(6)), kin.link_poses(np.r_[np.zeros(5), 0.7])
    hand = kin.frames.index("hand")
    np.testing.assert_allclose(b[1][hand], quat_mul_xyzw(a[1][hand], [math.sin(0.35), 0, 0, math.cos(0.35)]))
    assert np.array_equal(np.delete(a[1], hand, 0), np.delete(b[1], hand, 0))


@pytest.fixture(scope="module")
def carried(tmp_path_factory, kin):
    """A real run: drive to the table, pick the cup, drive to the counter, place it there."""
    w = World(house(), SimConfig(**GENERIC))
    w.reset(mission())
    path = tmp_path_factory.mktemp("robot") / "carry.mcap"
    results = []
    with McapRecorder(path, house(), {"seed": 0}, robot=kin) as rec:
        for a in (nav("table_1", "room_b"), Action("pickup", "table_1", obj="cup_1"),
                  nav("counter_1", "room_a"), Action("place", "counter_1", obj="cup_1")):
            r = w.execute(a)
            assert r.success, r.reason
            rec.action(r, {"step": len(results)})
            results.append(r)
    return path, results, w


def _messages(path, topic):
    with open(path, "rb") as f:
        return [m for _, ch, m in make_reader(f).iter_messages(topics=[topic])]


def test_trajectories_round_trip_exactly_from_joint_states(carried):
    path, results, _ = carried
    run = read_run(path)
    for got, want in zip(run.actions, results, strict=True):
        np.testing.assert_array_equal(got.trajectory.base, want.trajectory.base)
        np.testing.assert_array_equal(got.trajectory.joints, want.trajectory.joints)
        assert got.trajectory.joint_names == ARM_JOINTS
    assert run.counts["/joint_states"] == sum(len(r.trajectory.t) for r in results)


def test_tf_is_sparse_and_its_chain_puts_the_gripper_where_mujoco_does(carried, kin):
    path, results, _ = carried
    tfs = [(m.log_time, FrameTransforms.FromString(m.data)) for m in _messages(path, "/tf")]
    n_samples = sum(len(r.trajectory.t) for r in results)
    assert len(tfs) == n_samples  # every sample of this run moves something

    starts = np.cumsum([0] + [len(r.trajectory.t) for r in results])  # /tf is in file (= sample) order

    def frames_during(k):  # frames logged after action k's first sample
        return {tr.child_frame_id for _, m in tfs[starts[k] + 1:starts[k + 1]] for tr in m.transforms}

    assert frames_during(0) == {"base_link"}  # driving with the arm tucked: the base only
    assert frames_during(1) == set(kin.frames)  # reaching from a parked base: the arm only
    first = {tr.child_frame_id for tr in tfs[0][1].transforms}
    assert first == {"base_link", *kin.frames}  # every frame at an action's first sample
    # replay the log's transforms (last one per frame at or before t) and compare with MuJoCo
    run = read_run(path)
    check = World(house(), SimConfig(**GENERIC))
    check.reset(mission())
    pickup = results[1]
    for k in range(0, len(pickup.trajectory.t), 3):
        t = pickup.trajectory.t[k]
        chain = []
        for frame in ("base_link", *kin.frames):
            fs = run.frames[frame]
            j = int(np.searchsorted(fs.t, t + 1e-9, side="right")) - 1
            chain.append((fs.xyz[j], fs.quat[j]))
        p, r = _compose(chain)
        check.physics.set_base(*pickup.trajectory.base[k])
        check.physics.set_arm(pickup.trajectory.joints[k])
        want_p, want_r = check.physics.grip_pose()
        np.testing.assert_allclose(p, want_p, atol=1e-6)
        np.testing.assert_allclose(r, want_r, atol=1e-6)


def test_object_events_carry_the_object_and_put_it_down(carried, kin):
    path, results, w = carried
    run = read_run(path)
    assert [(m.object, m.frame) for m in run.object_moves] == [("cup_1", GRIP_FRAME), ("cup_1", "world")]
    grasp, release = run.object_moves
    pickup, place = results[1], results[3]
    assert (grasp.t, grasp.position) == (pytest.approx(pickup.object_events[0].t, abs=1e-9),
                                         pickup.object_events[0].position)  # exact through JSON
    assert pickup.t_start < grasp.t < pickup.t_start + pickup.time
    assert place.t_start < release.t < place.t_start + place.time
    assert release.position == tuple(w.scene.objects["cup_1"].position)
    assert grasp.size == pytest.approx(house().objects["cup_1"].size)
    # the held pose composed with the logged /tf chain at the grasp is where the cup stood
    chain = []
    for frame in ("base_link", *kin.frames):
        fs = run.frames[frame]
        j = int(np.searchsorted(fs.t, grasp.t + 1e-9, side="right")) - 1
        chain.append((fs.xyz[j], fs.quat[j]))
    chain.append((grasp.position, grasp.quaternion))
    p, _ = _compose(chain)
    np.testing.assert_allclose(p, house().objects["cup_1"].position, atol=1e-6)
    # /scene/objects: the whole object state at t=0, at the grasp and at the release
    states = [SceneUpdate.FromString(m.data) for m in _messages(path, "/scene/objects")]
    assert len(states) == 3 and all(len(s.entities) == len(house().objects) for s in states)
    # each state replaces the last one whole (viewers keep entities by id until deleted)
    assert all([(d.type, d.timestamp.ToNanoseconds()) for d in s.deletions] ==
               [(SceneEntityDeletion.Type.ALL, e.timestamp.ToNanoseconds())] for s in states for e in s.entities)
    cup = [{e.id: e for e in s.entities}["object/cup_1"] for s in states]
    assert [e.frame_id for e in cup] == ["world", GRIP_FRAME, "world"]
    assert cup[2].cubes[0].pose.position.x == release.position[0]
    # the initial /scene draws the robot's geoms in frames that /tf moves
    first = SceneUpdate.FromString(_messages(path, "/scene")[0].data)
    robot = [e for e in first.entities if any(kv.key == "kind" and kv.value == "robot" for kv in e.metadata)]
    assert len(robot) == len(kin.visuals()) == len(run.robot_visuals)
    assert {e.frame_id for e in robot} <= set(run.frames)
    assert all(e.frame_locked for e in robot)
    assert not any(e.id.startswith("object/") for e in first.entities)


def test_without_a_robot_model_a_held_object_is_left_out_of_the_drawing(carried, tmp_path):
    _, results, _ = carried
    with McapRecorder(tmp_path / "norobot.mcap", house(), {}) as rec:
        for r in results:
            rec.action(r, {})
    states = [SceneUpdate.FromString(m.data) for m in _messages(tmp_path / "norobot.mcap", "/scene/objects")]
    assert [sorted(e.id for e in s.entities) for s in states] == [["object/apple_1", "object/cup_1"],
                                                                   ["object/apple_1"],
                                                                   ["object/apple_1", "object/cup_1"]]
    assert all(s.deletions[0].type == SceneEntityDeletion.Type.ALL for s in states)  # the cup leaves the drawing
    run = read_run(tmp_path / "norobot.mcap")
    assert [m.frame for m in run.object_moves] == [GRIP_FRAME, "world"]  # the events are still exact
    out = replay(tmp_path / "norobot.mcap", save=str(tmp_path / "norobot.rrd"))  # no grip frame: no crash
    assert out[0].stat().st_size > 0


def test_an_event_for_an_unknown_object_writes_nothing_of_the_action(tmp_path):
    from interllm.core.results import ObjectEvent

    r, ctx = make_actions(1, 5)[0]
    r.object_events = [ObjectEvent(1.0, "ghost_1", "world", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))]
    with pytest.raises(ValueError, match="ghost_1"), McapRecorder(tmp_path / "g.mcap", make_scene(), {}) as rec:
        rec.action(r, ctx)
    run = read_run(tmp_path / "g.mcap")
    assert run.status == "error" and run.counts.get("/joint_states", 0) == 0 and not run.actions


def test_signed_zero_and_infinite_yaw_are_logged_as_given(tmp_path):
    from interllm.record.topics import JointStates

    r, ctx = make_actions(1, 4)[0]
    r.trajectory.base = np.array([[0.0, 1.0, 0.0], [-0.0, 1.0, 0.0], [-0.0, 1.0, float("inf")], [1.0, 1.0, 0.5]])
    with McapRecorder(tmp_path / "z.mcap", make_scene(), {}) as rec:
        rec.action(r, ctx)
    js = [JointStates.FromString(m.data) for m in _messages(tmp_path / "z.mcap", "/joint_states")]
    assert [list(m.base) for m in js] == r.trajectory.base.tolist()
    assert math.copysign(1.0, js[1].base[0]) == -1.0 and math.isinf(js[2].base[2])
    tfs = [FrameTransforms.FromString(m.data) for m in _messages(tmp_path / "z.mcap", "/tf")]
    assert len(tfs) == 3  # the sample with an infinite yaw has no transform


def _break_joints(r, ctx):  # 3 joints, the robot has 6
    return "3 arm joints"


def _break_times(r, ctx):
    r.trajectory.t[2] = float("nan")
    return "trajectory times must be finite"


def _break_base(r, ctx):
    r.trajectory.base = r.trajectory.base[:3]
    return "trajectory base must be 5x3"


def _break_context(r, ctx):
    ctx["note"] = object()
    return "not JSON serialisable"


@pytest.mark.parametrize("breaks", [_break_joints, _break_times, _break_base, _break_context])
def test_a_rejected_action_leaves_nothing_of_itself_in_the_log(tmp_path, kin, breaks):
    (good, gctx), (r, ctx) = make_actions(2, 5)[1], make_actions(1, 5)[0]  # r: a navigate with a presumed path
    good.trajectory.joints, good.trajectory.joint_names = np.zeros((5, 6)), ARM_JOINTS
    if breaks is not _break_joints:
        r.trajectory.joints, r.trajectory.joint_names = np.zeros((5, 6)), ARM_JOINTS
    message = breaks(r, ctx)
    with McapRecorder(tmp_path / "x.mcap", make_scene(), {}, robot=kin) as rec:
        rec.action(good, gctx)
        with pytest.raises((ValueError, TypeError), match=message):
            rec.action(r, ctx)
    run = read_run(tmp_path / "x.mcap")
    assert run.status == "ok" and len(run.actions) == 1  # the log goes on after the rejected action
    assert run.counts.get("/path/presumed", 0) == 0 and run.counts["/joint_states"] == 5


def test_nonfinite_joint_sample_has_no_link_frames_and_round_trips(tmp_path, kin):
    from interllm.record.topics import JointStates

    r, ctx = make_actions(1, 5)[0]
    r.trajectory.joints = np.tile(np.linspace(0, 1, 6), (5, 1)) * np.arange(1, 6)[:, None]
    r.trajectory.joint_names = ARM_JOINTS
    r.trajectory.joints[2, 1] = float("nan")
    with McapRecorder(tmp_path / "nan.mcap", make_scene(), {}, robot=kin) as rec:
        rec.action(r, ctx)
    tfs = [FrameTransforms.FromString(m.data) for m in _messages(tmp_path / "nan.mcap", "/tf")]
    assert [len(m.transforms) for m in tfs] == [1 + len(kin.chain), 1 + len(kin.chain), 1,
                                                1 + len(kin.chain), 1 + len(kin.chain)]
    js = [JointStates.FromString(m.data) for m in _messages(tmp_path / "nan.mcap", "/joint_states")]
    assert math.isnan(js[2].positions[1]) and list(js[0].base) == r.trajectory.base[0].tolist()
    got = read_run(tmp_path / "nan.mcap").actions[0].trajectory
    np.testing.assert_array_equal(got.joints, r.trajectory.joints)  # NaN compares equal here
    np.testing.assert_array_equal(got.base, r.trajectory.base)


@pytest.mark.skipif(rerun_cli() is None, reason="rerun CLI not installed")
def test_replay_nests_the_arm_and_carries_the_object(carried, tmp_path):
    import re

    path, results, _ = carried
    out = replay(path, save=str(tmp_path / "carry.rrd"))[0]
    assert run_cli("rrd", "verify", str(out)).returncode == 0
    p = run_cli("rrd", "print", str(out))
    ents = set(re.findall(r" - (/\S+) - data columns", p.stdout))
    arm = "/world/robot/shoulder/upper_arm/forearm/wrist_roll/wrist/hand"
    for e in (arm, f"{arm}/grip", f"{arm}/grip/held", f"{arm}/visual/robot_hand",
              "/world/robot/visual/robot_base", "/world/scene/objects"):
        assert e in ents, f"{e} not in {sorted(ents)}"


def test_trajectory_figure_from_run_logs(carried, tmp_path):
    from helpers.recording import write_run

    from interllm.record.figures import mission_trajectories_figure

    path, _, _ = carried
    out = mission_trajectories_figure({"inter_llm": path, "sayplan": read_run(path)}, tmp_path / "t.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    again = mission_trajectories_figure({"inter_llm": path, "sayplan": path}, tmp_path / "t2.png")
    assert again.read_bytes() == out.read_bytes()
    write_run(tmp_path / "other.mcap", 2, 5)  # a run in another scene
    with pytest.raises(ValueError, match="different scenes"):
        mission_trajectories_figure({"a": path, "b": tmp_path / "other.mcap"}, tmp_path / "x.png")
    with pytest.raises(ValueError, match="no runs"):
        mission_trajectories_figure({}, tmp_path / "y.png")


@pytest.mark.skipif(rerun_cli() is None, reason="rerun CLI not installed")
def test_real_run_log_passes_rerun_mcap_check(carried):
    path, _, _ = carried
    p = run_cli("mcap", "check", str(path))
    assert p.returncode == 0, p.stdout + p.stderr
    rows = [ln.split() for ln in p.stdout.splitlines() if ln.split()[:1] in (["ok"], ["warn"], ["error"])]
    assert {r[3] for r in rows} >= {"/tf", "/scene", "/scene/objects", "/objects/events", "/joint_states"}
    assert all(r[0] == "ok" for r in rows), p.stdout
