"""Protobuf wire-format bytes of the run log's array-shaped messages, many per numpy call.

Per trajectory sample the recorder writes an ``interllm.JointStates``. The samples of an action
share one layout (same action index, joint names and number of doubles), so they are written here
as the rows of one uint8 array rather than through the generated class one by one: constant bytes
(keys, lengths, names) are broadcast and the doubles copied in as their little-endian bytes; each
row is one message. A path's poses (``foxglove.PosesInFrame``) are one record array the same way.

- ``joint_states``: canonical, byte-identical to ``SerializeToString()``.
- ``planar_poses_in_frame``: the doubles of a planar pose (x, y, rotation z and w) are written
  also when zero, which proto3's canonical form leaves out; a proto3 parser reads both as the
  same message. The timestamp is canonical.

``tests/test_record_wire.py`` checks both against the generated classes. ``/tf`` messages are not
built here: their timestamps vary in encoded length from sample to sample, so the samples of an
action do not share one layout (the recorder refills generated messages for them).

Wire format (https://protobuf.dev/programming-guides/encoding/): a field is a varint key
``(field_number << 3) | wire_type`` and its value; wire type 0 is a varint, 1 a little-endian
64-bit value, 2 a varint length and that many bytes (strings, sub-messages, packed arrays).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

_VARINT, _FIXED64, _BYTES = 0, 1, 2
_NS_PER_S = 1_000_000_000


def varint(value: int) -> bytes:
    """The base-128 varint of a non-negative integer (least significant group first)."""
    if value < 0:
        raise ValueError(f"varint takes a non-negative integer, got {value}")
    out = bytearray()
    while value >= 0x80:
        out.append((value & 0x7F) | 0x80)
        value >>= 7
    out.append(value)
    return bytes(out)


def _key(field_number: int, wire_type: int) -> bytes:
    return varint((field_number << 3) | wire_type)


def length_delimited(field_number: int, body: bytes) -> bytes:
    """Field ``field_number`` holding ``body`` (a string, a serialized sub-message or packed array)."""
    return _key(field_number, _BYTES) + varint(len(body)) + body


def _doubles_le(values: np.ndarray) -> np.ndarray:
    """The little-endian bytes of float64 ``values`` [..., k]: [..., 8 k] uint8."""
    v = np.ascontiguousarray(values, dtype="<f8")
    return v.view(np.uint8).reshape(*v.shape[:-1], 8 * v.shape[-1])


def _rows(n: int, blocks: Sequence[bytes | np.ndarray]) -> np.ndarray:
    """n messages of one layout, side by side: constant bytes (broadcast to every row) or uint8
    arrays [n, w] per block: [n, total width] uint8."""
    widths = [len(b) if isinstance(b, bytes) else b.shape[1] for b in blocks]
    out = np.empty((n, sum(widths)), dtype=np.uint8)
    at = 0
    for block, w in zip(blocks, widths, strict=True):
        if w:
            out[:, at:at + w] = np.frombuffer(block, dtype=np.uint8) if isinstance(block, bytes) else block
        at += w
    return out


def _cut(rows: np.ndarray) -> list[bytes]:
    """The bytes of each row of a uint8 array [N, W]."""
    raw, width = np.ascontiguousarray(rows).tobytes(), rows.shape[1]
    return [raw[i:i + width] for i in range(0, len(raw), width)]


def timestamp(t_ns: int) -> bytes:
    """The canonical ``google.protobuf.Timestamp`` body of one time [ns] (>= 0)."""
    if t_ns < 0:
        raise ValueError("timestamps must be >= 0 ns")
    sec, nanos = divmod(int(t_ns), _NS_PER_S)
    return (_key(1, _VARINT) + varint(sec) if sec else b"") + (_key(2, _VARINT) + varint(nanos) if nanos else b"")


def _planar_pose_dtype() -> tuple[np.dtype, np.ndarray]:
    """The packed record of one planar ``foxglove.Pose`` inside PosesInFrame.poses (field 3), and
    a template with its keys and lengths: position (1) with x (1), y (2); orientation (2) with z
    (3), w (4). A planar pose's z, x and y rotation are zero and left out, as proto3 does."""
    layout = [("poses", 3, _BYTES, 40), ("position", 1, _BYTES, 18), ("x", 1, _FIXED64, None),
              ("y", 2, _FIXED64, None), ("orientation", 2, _BYTES, 18), ("qz", 3, _FIXED64, None),
              ("qw", 4, _FIXED64, None)]
    fields: list[tuple[str, str]] = []
    for name, _, _, length in layout:
        fields.append((f"{name}_key", "u1"))
        fields.append((f"{name}_len", "u1") if length is not None else (name, "<f8"))
    dtype = np.dtype(fields)
    template = np.zeros((), dtype=dtype)
    for name, number, wire_type, length in layout:
        template[f"{name}_key"] = (number << 3) | wire_type
        if length is not None:
            template[f"{name}_len"] = length
    return dtype, template  # 42 bytes: key + length + 2 sub-messages of key + length + 2 x (key + double)


_PLANAR_POSE, _PLANAR_POSE_TEMPLATE = _planar_pose_dtype()


def planar_poses_in_frame(t_ns: int, frame_id: str, xy: np.ndarray, yaw: np.ndarray) -> bytes:
    """One ``foxglove.PosesInFrame``: timestamp ``t_ns`` [ns], ``frame_id``, and a pose at z = 0
    per row of ``xy`` [N, 2] [m] turned by ``yaw`` [N] [rad] about +z."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    poses = np.full(len(xy), _PLANAR_POSE_TEMPLATE, dtype=_PLANAR_POSE)
    poses["x"], poses["y"] = xy[:, 0], xy[:, 1]
    poses["qz"], poses["qw"] = np.sin(yaw / 2.0), np.cos(yaw / 2.0)
    return length_delimited(1, timestamp(t_ns)) + length_delimited(2, frame_id.encode()) + poses.tobytes()


def joint_states(action: int, names: Sequence[str], base: np.ndarray, positions: np.ndarray) -> list[bytes]:
    """``interllm.JointStates`` messages (``record.topics.JointStates``), one per row of ``base``
    [N, 3] (x [m], y [m], yaw [rad]) and ``positions`` [N, J] [rad], all of action ``action`` with
    joint ``names``; canonical proto3 (packed doubles; a zero ``action`` and empty ``positions``
    left out)."""
    base = np.asarray(base, dtype=float).reshape(-1, 3)
    n = len(base)
    positions = np.asarray(positions, dtype=float).reshape(n, -1)
    blocks: list[bytes | np.ndarray] = [_key(1, _VARINT) + varint(action) if action else b"",
                                        _key(2, _BYTES) + varint(24), _doubles_le(base),
                                        b"".join(length_delimited(3, s.encode()) for s in names)]
    if positions.shape[1]:
        blocks += [_key(4, _BYTES) + varint(8 * positions.shape[1]), _doubles_le(positions)]
    return _cut(_rows(n, blocks))
