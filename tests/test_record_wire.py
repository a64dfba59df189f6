"""The array-built protobuf bytes of ``interllm.record.wire`` against the generated classes: joint
states are the same bytes, paths parse to the same message, timestamps are canonical."""

from __future__ import annotations

import numpy as np
import pytest
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.PosesInFrame_pb2 import PosesInFrame

import interllm  # noqa: F401  (first: pins the numerical environment)
from interllm.record import wire
from interllm.record.foxglove import path_poses
from interllm.record.topics import JointStates

# times around every varint length boundary of seconds and nanos, and zero parts (left out)
TIMES_NS = [0, 1, 127, 128, 999_999_999, 1_000_000_000, 1_000_000_001, 127_000_000_000, 128_500_000_000,
            16_384_123_456_789, 2**40 + 12345]


def test_timestamps_are_canonical():
    msg = FrameTransforms()
    ts = msg.transforms.add().timestamp
    for t in TIMES_NS:
        ts.FromNanoseconds(t)
        assert wire.timestamp(t) == ts.SerializeToString(), t
    with pytest.raises(ValueError, match=">= 0"):
        wire.timestamp(-1)


@pytest.mark.parametrize("action,n_joints", [(0, 6), (1, 6), (300, 6), (5, 0)])
def test_joint_states_are_the_canonical_bytes(action, n_joints):
    rng = np.random.default_rng(action)
    base, positions = rng.normal(size=(7, 3)), rng.normal(size=(7, n_joints))
    base[1, 0], base[2, 2], base[3, 1] = -0.0, float("inf"), 0.0
    if n_joints:
        positions[4, 2] = float("nan")
    names = [f"joint{k}" for k in range(n_joints)]
    got = wire.joint_states(action, names, base, positions)
    for data, b, q in zip(got, base.tolist(), positions.tolist(), strict=True):
        assert data == JointStates(action=action, base=b, names=names, positions=q).SerializeToString()


def test_path_poses_parse_to_the_generated_message():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 2.5], [-3.25, 2.5]])
    t_ns = 12_345_678_901
    got = PosesInFrame.FromString(path_poses(path, t_ns))
    want = PosesInFrame(frame_id="world")
    want.timestamp.FromNanoseconds(t_ns)
    yaw = [0.0, 0.0, np.pi / 2, np.pi, np.pi]  # towards the next pose (atan2(0, 0) = 0), the last as the one before
    for (x, y), a in zip(path.tolist(), yaw, strict=True):
        p = want.poses.add()
        p.position.x, p.position.y = x, y
        p.orientation.z, p.orientation.w = np.sin(a / 2), np.cos(a / 2)
    assert got == want
    assert len(PosesInFrame.FromString(path_poses(np.zeros((0, 2)), 0)).poses) == 0
    assert PosesInFrame.FromString(path_poses(np.array([[2.0, 3.0]]), 5)).poses[0].orientation.w == 1.0


def test_varint_rejects_negative_numbers():
    assert wire.varint(300) == b"\xac\x02"
    with pytest.raises(ValueError, match="non-negative"):
        wire.varint(-1)


def _generated_objects_update(objects, state, t_ns, frames) -> bytes:
    """/scene/objects as built field by field through the generated classes (the reference)."""
    from foxglove_schemas_protobuf.SceneEntityDeletion_pb2 import SceneEntityDeletion
    from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

    from interllm.record.foxglove import _object_entity

    msg = SceneUpdate()
    d = msg.deletions.add()
    d.timestamp.FromNanoseconds(t_ns)
    d.type = SceneEntityDeletion.Type.ALL
    for oid in sorted(state):
        if state[oid][0] in frames:
            e = msg.entities.add()
            e.timestamp.FromNanoseconds(t_ns)
            _object_entity(e, objects[oid], *state[oid])
    return msg.SerializeToString()


def test_objects_updates_are_the_bytes_of_the_generated_message_as_objects_move():
    from helpers.recording import make_scene

    from interllm.record.foxglove import ObjectsUpdates

    objects = make_scene().objects
    frames = {"world", "base_link"}  # no grip frame: a held object is left out
    state = {o.id: ("world", tuple(o.position), (0.0, 0.0, 0.0, 1.0)) for o in objects.values()}
    updates = ObjectsUpdates(objects, frames)
    first, second = sorted(objects)[:2]
    for t_ns, change in [(0, None), (1_500_000_000, (first, ("grip", (0.0, 0.0, 0.1), (0.0, 0.0, 0.0, 1.0)))),
                         (2_000_000_001, (first, ("world", (1.0, 2.0, 0.5), (0.0, 0.0, 0.6, 0.8)))),
                         (3_000_000_000, (second, ("world", (0.0, -1.0, 0.25), (0.0, 0.0, 0.0, 1.0))))]:
        if change is not None:
            state[change[0]] = change[1]
        assert updates.message(state, t_ns) == _generated_objects_update(objects, state, t_ns, frames), t_ns
