"""One MCAP log per mission run, written as the run proceeds (``McapRecorder``).

File handling: the recorder writes to ``<path>.partial`` and renames it to ``<path>`` in
``close()``. A run that is killed leaves ``<path>.partial``: a valid MCAP prefix (header, the
"run" metadata, the scene attachment and every chunk completed so far) that
``record.reader.read_run`` and ``record.replay.replay`` read up to its last complete chunk. So
``<path>`` existing means the run finished (its "end" metadata says whether it raised).

Crash safety: chunks are zstd-compressed and at most ``chunk_size`` bytes (uncompressed); after
every action (and every log line at level warning or above) the chunk in progress is finished and
the stream flushed to the OS, so a SIGKILL loses at most the events logged since the last action.

Channels (all times are simulated mission time, ``log_time = publish_time = round(t * 1e9)`` ns,
clamped to be non-decreasing per channel):

- ``/scene``          foxglove.SceneUpdate at t=0: walls, door leaves, furniture as cubes and, with
                      a ``robot`` model, the robot's links as primitives locked to their frames
- ``/scene/objects``  foxglove.SceneUpdate with every object, at t=0 and after every grasp and
                      release (each message is the whole state, so a viewer that seeks shows the
                      right one): an object lying somewhere is a cube in the world; a held one is
                      a cube in the ``grip`` frame, so viewers carry it with the hand (without a
                      ``robot`` model there is no grip frame and a held object is left out)
- ``/objects/events`` JSON {"object", "frame", "position", "quaternion"} per grasp ("grip") and
                      release ("world"): the exact poses of ``ActionResult.object_events``
- ``/grid/<name>``    foxglove.Grid at t=0 per given grid (uint8 "occupancy": 0 free, 100 occupied)
- ``/tf``             foxglove.FrameTransforms at every trajectory sample where something moved:
                      world -> base_link when the base pose changed, and with a ``robot`` model
                      (``interllm.sim.kinematics.RobotKinematics``) the arm's link frames
                      (base_link -> shoulder -> ... -> hand -> grip) when the joints changed; both
                      at the first sample of every action. A frame keeps its last transform.
- ``/joint_states``   JSON {"action", "base": [x, y, yaw], "names", "positions"} per trajectory
                      sample: the exact trajectory (``read_run`` rebuilds Trajectory from it)
- ``/path/presumed``  foxglove.PosesInFrame at the action start (navigate actions)
- ``/path/driven``    foxglove.PosesInFrame at the action end (navigate actions)
- ``/actions``        JSON: ActionResult.to_record() + "context" + "index" + "n_samples" at the
                      action end; its JSON schema is ``ACTION_SCHEMA`` (full, strict)
- ``/log``            foxglove.Log
- any other topic given to ``event()`` (``/planner/candidates``, ``/llm/calls``, ...): a JSON
  channel with a permissive object schema, registered on first use.

JSON encoding: ``json.dumps(sort_keys=True)``; numpy scalars/arrays are converted; non-finite
floats are written as ``Infinity``/``NaN`` (Python's JSON dialect) so that they round-trip.

Metadata records: "run" (given at construction; values that are not strings are stored as
canonical JSON strings, e.g. "config", "packages"), and "end" on close ({"status": "ok" |
"error", "error": text, "n_actions", "sim_time"}). Attachment "scene.json": the SceneGraph JSON.
Determinism: no wall-clock anywhere; identical inputs give byte-identical files.
"""

from __future__ import annotations

import math
import os
import struct
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.Grid_pb2 import Grid
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.PackedElementField_pb2 import PackedElementField
from foxglove_schemas_protobuf.PosesInFrame_pb2 import PosesInFrame
from foxglove_schemas_protobuf.SceneEntityDeletion_pb2 import SceneEntityDeletion
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from mcap.opcode import Opcode
from mcap.records import MessageIndex
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import CompressionType, Writer
from mcap_protobuf.schema import register_schema

from interllm.core import jsonfmt
from interllm.core.frames import BASE_FRAME, GRIP_FRAME, WORLD_FRAME, yaw_quat_xyzw
from interllm.core.results import ActionResult, Trajectory
from interllm.scene.graph import SceneGraph
from interllm.scene.grid import OccupancyGrid

DOOR_HEIGHT = 2.0  # [m] drawn height of a door leaf
DOOR_LEAF_THICKNESS = 0.04  # [m]
OCCUPIED = 100  # grid cell value of an occupied cell (0 = free)

TF_TOPIC = "/tf"
SCENE_TOPIC = "/scene"
OBJECTS_TOPIC = "/scene/objects"
OBJECT_EVENTS_TOPIC = "/objects/events"
JOINT_TOPIC = "/joint_states"
PRESUMED_TOPIC = "/path/presumed"
DRIVEN_TOPIC = "/path/driven"
ACTIONS_TOPIC = "/actions"
LOG_TOPIC = "/log"
GRID_PREFIX = "/grid/"
RESERVED_TOPICS = (TF_TOPIC, SCENE_TOPIC, OBJECTS_TOPIC, OBJECT_EVENTS_TOPIC, JOINT_TOPIC, PRESUMED_TOPIC, DRIVEN_TOPIC, ACTIONS_TOPIC,
                   LOG_TOPIC)

LOG_LEVELS = {"debug": Log.DEBUG, "info": Log.INFO, "warning": Log.WARNING, "warn": Log.WARNING,
              "error": Log.ERROR, "fatal": Log.FATAL}
LOG_LEVEL_NAMES = {Log.UNKNOWN: "unknown", Log.DEBUG: "debug", Log.INFO: "info",
                   Log.WARNING: "warning", Log.ERROR: "error", Log.FATAL: "fatal"}

COMPRESSIONS = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}

_NUM = {"type": "number"}
_PATH = {"oneOf": [{"type": "null"},
                   {"type": "array", "items": {"type": "array", "items": _NUM, "minItems": 2,
                                               "maxItems": 2}}]}
ACTION_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "interllm.ActionResult",
    "description": "ActionResult.to_record() of one executed action, with its planner context.",
    "type": "object",
    "additionalProperties": False,
    "required": ["index", "n_samples", "context", "action", "kind", "success", "cost", "time",
                 "t_start", "collisions", "distance", "success_rate", "trials", "reason",
                 "presumed_path", "driven_path"],
    "properties": {
        "index": {"type": "integer", "minimum": 0, "description": "0-based action number in the run"},
        "n_samples": {"type": "integer", "minimum": 0,
                      "description": "trajectory samples written to /tf and /joint_states before it"},
        "context": {"type": "object", "description": "planner/command ids given by the caller"},
        "action": {
            "type": "object",
            "required": ["action", "furniture"],
            "additionalProperties": False,
            "properties": {"action": {"enum": ["navigate", "pickup", "place"]},
                           "furniture": {"type": "string"},
                           "room": {"type": ["string", "null"]},
                           "object": {"type": ["string", "null"]}},
        },
        "kind": {"enum": ["navigate", "pickup", "place"]},
        "success": {"type": "boolean"},
        "cost": {**_NUM, "description": "c_nav = γ_nav·cc + t + d or c_man = γ_man·(1 − sr) + t"},
        "time": {**_NUM, "description": "[s] simulated"},
        "t_start": {**_NUM, "description": "[s] simulated mission clock at the action start"},
        "collisions": {"type": "integer", "minimum": 0},
        "distance": {**_NUM, "description": "[m]"},
        "success_rate": {**_NUM, "minimum": 0, "maximum": 1},
        "trials": {"type": "array", "items": {
            "type": "object",
            "required": ["base_pose", "success", "time", "reason", "ik_error"],
            "additionalProperties": False,
            "properties": {"base_pose": {"type": "array", "items": _NUM, "minItems": 3, "maxItems": 3},
                           "success": {"type": "boolean"}, "time": _NUM, "reason": {"type": "string"},
                           "ik_error": _NUM}}},
        "reason": {"type": "string"},
        "presumed_path": _PATH,
        "driven_path": _PATH,
    },
}
JOINT_STATES_SCHEMA: dict[str, Any] = {
    "title": "interllm.JointStates",
    "type": "object",
    "required": ["action", "base", "names", "positions"],
    "properties": {"base": {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3,
                            "description": "base pose x [m], y [m], yaw [rad]"},
                   "names": {"type": "array", "items": {"type": "string"}},
                   "positions": {"type": "array", "items": {"type": "number"},
                                 "description": "arm joint angles [rad]"},
                   "action": {"type": "integer", "description": "index of the action it belongs to"}},
}
OBJECT_EVENT_SCHEMA: dict[str, Any] = {
    "title": "interllm.ObjectEvent",
    "type": "object",
    "additionalProperties": False,
    "required": ["object", "frame", "position", "quaternion"],
    "properties": {"object": {"type": "string"},
                   "frame": {"enum": [GRIP_FRAME, WORLD_FRAME], "description": "grip: grasped; world: released"},
                   "position": {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3,
                                "description": "[m] in the frame"},
                   "quaternion": {"type": "array", "items": {"type": "number"}, "minItems": 4, "maxItems": 4,
                                  "description": "(x, y, z, w) in the frame"}},
}
EVENT_SCHEMA: dict[str, Any] = {"title": "interllm.Event", "type": "object",
                                "description": "A planner event (free-form JSON object)."}


def to_ns(t: float) -> int:
    """Simulated time t [s] -> log time [ns] (t must be finite and >= 0)."""
    if not math.isfinite(t) or t < 0:
        raise ValueError(f"simulated time must be finite and >= 0 s, got {t!r}")
    return int(round(t * 1e9))


def _json_default(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, (set, frozenset)):
        return sorted(o)
    if isinstance(o, Path):
        return str(o)
    if isinstance(o, tuple):
        return list(o)
    raise TypeError(f"object of type {type(o).__name__} is not JSON serialisable; convert it to "
                    "dict/list/str/number before logging")


def dumps(obj: Any) -> str:
    """The run log's JSON encoding (``jsonfmt.message`` with numpy and dataclass conversion)."""
    return jsonfmt.message(obj, default=_json_default)


def _meta_str(v: Any) -> str:
    return v if isinstance(v, str) else dumps(v)


def _set_color(c: Color, rgba: Sequence[float]) -> None:
    c.r, c.g, c.b, c.a = (float(v) for v in rgba)


_COLORS = {"wall": (0.75, 0.75, 0.72, 1.0), "door": (0.55, 0.35, 0.18, 1.0),
           "furniture": (0.45, 0.55, 0.75, 0.9), "object": (0.95, 0.6, 0.15, 1.0)}


def scene_boxes(scene: SceneGraph) -> list[dict[str, Any]]:
    """Every wall, door leaf, furniture and object as an oriented box.

    Returns dicts with id, kind ("wall"|"door"|"furniture"|"object"), center (x, y, z) [m],
    size (sx, sy, sz) [m] and yaw [rad] (rotation about z), sorted by kind then id. Shared by
    the MCAP ``/scene`` channel and the rerun replay.
    """
    out: list[dict[str, Any]] = []
    for w in sorted(scene.walls.values(), key=lambda w: w.id):
        (ax, ay), (bx, by) = w.start, w.end
        length = math.hypot(bx - ax, by - ay)
        out.append({"id": w.id, "kind": "wall", "center": ((ax + bx) / 2, (ay + by) / 2, w.height / 2),
                    "size": (length + w.thickness, w.thickness, w.height),
                    "yaw": math.atan2(by - ay, bx - ax)})
    for d in sorted(scene.doors.values(), key=lambda d: d.id):
        seg = d.leaf_segment()
        if seg is None:
            continue
        (ax, ay), (bx, by) = seg
        out.append({"id": d.id, "kind": "door", "center": ((ax + bx) / 2, (ay + by) / 2, DOOR_HEIGHT / 2),
                    "size": (math.hypot(bx - ax, by - ay), DOOR_LEAF_THICKNESS, DOOR_HEIGHT),
                    "yaw": math.atan2(by - ay, bx - ax)})
    for f in sorted(scene.furniture.values(), key=lambda f: f.id):
        out.append({"id": f.id, "kind": "furniture", "center": (f.center[0], f.center[1], f.size[2] / 2),
                    "size": tuple(f.size), "yaw": 0.0, "category": f.category})
    for o in sorted(scene.objects.values(), key=lambda o: o.id):
        out.append({"id": o.id, "kind": "object", "center": tuple(o.position), "size": tuple(o.size),
                    "yaw": 0.0, "category": o.category})
    return out


def _set_pose(pose: Any, xyz: Sequence[float], quat: Sequence[float]) -> None:
    pose.position.x, pose.position.y, pose.position.z = (float(v) for v in xyz)
    (pose.orientation.x, pose.orientation.y, pose.orientation.z,
     pose.orientation.w) = (float(v) for v in quat)


def _metadata(e: Any, **kv: str) -> None:
    for k, v in kv.items():
        m = e.metadata.add()
        m.key, m.value = k, str(v)


def _object_entity(e: Any, o: Any, frame: str, xyz: Sequence[float], quat: Sequence[float]) -> None:
    """Fill a SceneEntity with object ``o`` as a cube at (xyz, quat) in ``frame``."""
    e.frame_id, e.id, e.frame_locked = frame, f"object/{o.id}", True
    _metadata(e, kind="object", category=o.category)
    c = e.cubes.add()
    _set_pose(c.pose, xyz, quat)
    c.size.x, c.size.y, c.size.z = (float(v) for v in o.size)
    _set_color(c.color, _COLORS["object"])


def _objects_update(objects: dict[str, Any], state: dict[str, tuple[str, Sequence[float], Sequence[float]]],
                    t_ns: int, frames: set[str]) -> SceneUpdate:
    """Every object at its current (frame, position, quaternion); objects in a frame not in
    ``frames`` are left out (a held object without a robot model). Each update first deletes every
    entity of the topic, so that viewers (which keep entities by id) show exactly this state."""
    msg = SceneUpdate()
    d = msg.deletions.add()
    d.timestamp.FromNanoseconds(t_ns)
    d.type = SceneEntityDeletion.Type.ALL
    for oid in sorted(state):
        frame, xyz, quat = state[oid]
        if frame not in frames:
            continue
        e = msg.entities.add()
        e.timestamp.FromNanoseconds(t_ns)
        _object_entity(e, objects[oid], frame, xyz, quat)
    return msg


def _scene_update(scene: SceneGraph, robot_visuals: Sequence[Any] = ()) -> SceneUpdate:
    msg = SceneUpdate()
    for b in scene_boxes(scene):
        if b["kind"] == "object":
            continue  # on /scene/objects
        e = msg.entities.add()
        e.frame_id, e.id, e.frame_locked = WORLD_FRAME, f"{b['kind']}/{b['id']}", True
        _metadata(e, kind=b["kind"], category=b.get("category", b["kind"]))
        c = e.cubes.add()
        _set_pose(c.pose, b["center"], yaw_quat_xyzw(b["yaw"]))
        c.size.x, c.size.y, c.size.z = (float(v) for v in b["size"])
        _set_color(c.color, _COLORS[b["kind"]])
    for v in robot_visuals:  # locked to the link frames that /tf moves
        e = msg.entities.add()
        e.frame_id, e.id, e.frame_locked = v.frame, v.name, True
        _metadata(e, kind="robot", shape=v.kind)
        if v.kind == "box":
            p = e.cubes.add()
            p.size.x, p.size.y, p.size.z = (2 * float(x) for x in v.size)
        elif v.kind == "sphere":
            p = e.spheres.add()
            p.size.x = p.size.y = p.size.z = 2 * float(v.size[0])
        else:  # cylinder; a capsule is drawn as its cylinder (radius, half length along z)
            p = e.cylinders.add()
            p.size.x = p.size.y = 2 * float(v.size[0])
            p.size.z = 2 * float(v.size[1])
            p.bottom_scale = p.top_scale = 1.0
        _set_pose(p.pose, v.pos, v.quat)
        _set_color(p.color, v.rgba)
    return msg


def grid_message(grid: OccupancyGrid) -> Grid:
    """OccupancyGrid -> foxglove.Grid (row-major, row i along +y, 0 free / 100 occupied)."""
    rows, cols = grid.shape
    msg = Grid()
    msg.frame_id = WORLD_FRAME
    msg.pose.position.x, msg.pose.position.y = float(grid.origin[0]), float(grid.origin[1])
    msg.pose.orientation.w = 1.0
    msg.column_count = int(cols)
    msg.cell_size.x = msg.cell_size.y = float(grid.resolution)
    msg.row_stride = int(cols)
    msg.cell_stride = 1
    f = msg.fields.add()
    f.name, f.offset, f.type = "occupancy", 0, PackedElementField.UINT8
    msg.data = (np.asarray(grid.occupied, dtype=bool).astype(np.uint8) * OCCUPIED).tobytes()
    return msg


def _poses_message(path: np.ndarray, t_ns: int) -> PosesInFrame:
    """A 2-D path [N, 2] [m] as poses at z=0 heading along the path."""
    msg = PosesInFrame()
    msg.timestamp.FromNanoseconds(t_ns)
    msg.frame_id = WORLD_FRAME
    path = np.asarray(path, dtype=float).reshape(-1, 2)
    n = len(path)
    if n == 0:
        return msg
    # heading of segment i -> i+1 (the last pose keeps the last segment's heading)
    d = np.diff(path, axis=0) if n > 1 else np.zeros((1, 2))
    yaw = np.arctan2(d[:, 1], d[:, 0])
    yaw = np.append(yaw, yaw[-1])[:n] if n > 1 else np.zeros(1)
    for (x, y), qz, qw in zip(path.tolist(), np.sin(yaw / 2).tolist(), np.cos(yaw / 2).tolist(), strict=True):
        p = msg.poses.add()
        p.position.x, p.position.y = x, y
        p.orientation.z, p.orientation.w = qz, qw
    return msg


_MESSAGE_HEADER = struct.Struct("<BQHIQQ")  # opcode, record length, channel, sequence, log, publish time


class _BatchWriter(Writer):
    """``mcap.writer.Writer`` plus ``add_messages``: many messages in one call, packed with one
    struct call each instead of the per-field writes of ``add_message`` (3-4x less time per
    message, the recorder's hot path). The file is byte-identical to calling ``add_message`` for
    each (tests/test_record_mcap.py checks this); if the mcap package's internals ever change
    shape, it falls back to ``add_message``."""

    def add_messages(self, rows: Sequence[tuple[int, int, bytes, int]]) -> None:
        """rows: (channel_id, log_time = publish_time [ns], data, sequence), in file order."""
        try:
            stats = self._Writer__statistics  # type: ignore[attr-defined]
            cb = self._Writer__chunk_builder  # type: ignore[attr-defined]
            limit = self._Writer__chunk_size  # type: ignore[attr-defined]
            finalize = self._Writer__maybe_finalize_chunk  # type: ignore[attr-defined]
            buf = cb.record_writer._buffer
        except AttributeError:
            cb = None
        if cb is None:
            for ch, t, data, seq in rows:
                self.add_message(channel_id=ch, log_time=t, data=data, publish_time=t, sequence=seq)
            return
        pack, opcode = _MESSAGE_HEADER.pack, int(Opcode.MESSAGE)
        counts, indices = stats.channel_message_counts, cb.message_indices
        for ch, t, data, seq in rows:
            if stats.message_count == 0:
                stats.message_start_time = t
            elif t < stats.message_start_time:
                stats.message_start_time = t
            if t > stats.message_end_time:
                stats.message_end_time = t
            counts[ch] += 1
            stats.message_count += 1
            if cb.num_messages == 0:
                cb.message_start_time = t
            elif t < cb.message_start_time:
                cb.message_start_time = t
            if t > cb.message_end_time:
                cb.message_end_time = t
            idx = indices.get(ch)
            if not idx:
                idx = indices[ch] = MessageIndex(channel_id=ch, records=[])
            offset = buf.tell()
            idx.records.append((t, offset))
            cb.num_messages += 1
            buf.write(pack(opcode, 22 + len(data), ch, seq, t, t))
            buf.write(data)
            if offset + 31 + len(data) > limit:
                finalize()  # compresses and writes the chunk; the builder starts a new buffer
                buf = cb.record_writer._buffer


class McapRecorder:
    """Recorder writing one ``.mcap`` per mission run (see the module docstring for the layout).

    path: final file path (``.mcap``); the run is written to ``<path>.partial`` until ``close()``.
    scene: the mission's scene (``/scene`` and the "scene.json" attachment).
    metadata: the "run" metadata record (resolved config, git commit, seed, package versions, ...);
        non-string values are stored as canonical JSON strings.
    grids: occupancy grids by name (``/grid/<name>``), e.g. {"presumed": ..., "true": ...}.
    joint_names: arm joint names for ``/joint_states`` when a Trajectory carries none.
    chunk_size: uncompressed chunk size limit [bytes]; compression: "zstd" | "lz4" | "none".
    robot: optional robot model (``interllm.sim.kinematics.RobotKinematics`` or anything with
        ``joint_names``, ``chain`` [(parent, child)], ``link_poses(joints[N, n]) -> (xyz[N, L, 3],
        quat_xyzw[N, L, 4])`` and ``visuals()``): arm link frames on ``/tf`` and the robot's shape on
        ``/scene``. Without it ``/tf`` has world -> base_link only.
    """

    def __init__(self, path: str | os.PathLike, scene: SceneGraph, metadata: dict[str, Any] | None = None,
                 grids: dict[str, OccupancyGrid] | None = None, joint_names: Sequence[str] = (), *,
                 chunk_size: int = 256 * 1024, compression: str = "zstd", robot: Any = None) -> None:
        if compression not in COMPRESSIONS:
            raise ValueError(f"compression {compression!r} is not valid; choose one of {list(COMPRESSIONS)}")
        if chunk_size < 1024:
            raise ValueError(f"chunk_size must be >= 1024 bytes, got {chunk_size}")
        self.path = Path(path)
        self.partial_path = self.path.with_name(self.path.name + ".partial")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.joint_names = tuple(joint_names or (robot.joint_names if robot is not None else ()))
        self.robot = robot
        self._scene_id = scene.id
        self._objects = dict(scene.objects)
        self._object_state = {o.id: (WORLD_FRAME, tuple(o.position), (0.0, 0.0, 0.0, 1.0))
                              for o in scene.objects.values()}
        self._frames = {WORLD_FRAME, BASE_FRAME, *(c for _, c in robot.chain)} if robot is not None \
            else {WORLD_FRAME, BASE_FRAME}
        self._tf_base = FrameTransforms()  # reused for the base-only /tf messages
        self._tf_base_tr = self._tf_base.transforms.add()
        self._tf_base_tr.parent_frame_id, self._tf_base_tr.child_frame_id = WORLD_FRAME, BASE_FRAME
        self._file = open(self.partial_path, "wb")
        self._w = _BatchWriter(self._file, chunk_size=chunk_size, compression=COMPRESSIONS[compression])
        self._w.start(profile="", library="interllm.record")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._last_ns: dict[int, int] = {}
        self._seq: dict[int, int] = {}
        self._n_actions = 0
        self._clock = 0.0
        self._closed = False

        self._w.add_metadata("run", {str(k): _meta_str(v) for k, v in sorted((metadata or {}).items())})
        self._w.add_attachment(create_time=0, log_time=0, name="scene.json", media_type="application/json",
                               data=scene.to_json().encode("utf-8"))
        self._write_proto(SCENE_TOPIC, _scene_update(scene, robot.visuals() if robot is not None else ()), 0)
        self._write_proto(OBJECTS_TOPIC, _objects_update(self._objects, self._object_state, 0, self._frames), 0)
        for name, grid in sorted((grids or {}).items()):
            self._write_proto(GRID_PREFIX + name, grid_message(grid), 0)
        self._w.flush()

    # ---- channels ----------------------------------------------------------------------
    def _channel_proto(self, topic: str, msg: Any) -> int:
        ch = self._channels.get(topic)
        if ch is None:
            name = type(msg).DESCRIPTOR.full_name
            sid = self._schemas.get(name)
            if sid is None:
                sid = self._schemas[name] = register_schema(self._w, type(msg))
            ch = self._channels[topic] = self._w.register_channel(topic, MessageEncoding.Protobuf, sid)
        return ch

    def _channel_json(self, topic: str, schema: dict[str, Any]) -> int:
        ch = self._channels.get(topic)
        if ch is None:
            name = schema["title"]
            sid = self._schemas.get(name)
            if sid is None:
                sid = self._schemas[name] = self._w.register_schema(
                    name, SchemaEncoding.JSONSchema, dumps(schema).encode("utf-8"))
            ch = self._channels[topic] = self._w.register_channel(topic, MessageEncoding.JSON, sid)
        return ch

    def _add(self, ch: int, t_ns: int, data: bytes) -> None:
        t_ns = max(t_ns, self._last_ns.get(ch, 0))  # non-decreasing per channel
        self._last_ns[ch] = t_ns
        seq = self._seq.get(ch, 0)
        self._seq[ch] = seq + 1
        self._w.add_message(channel_id=ch, log_time=t_ns, data=data, publish_time=t_ns, sequence=seq)

    def _write_proto(self, topic: str, msg: Any, t_ns: int) -> None:
        self._add(self._channel_proto(topic, msg), t_ns, msg.SerializeToString())

    def _write_json(self, topic: str, schema: dict[str, Any], obj: Any, t_ns: int) -> None:
        data = dumps(obj).encode("utf-8")  # fails before a channel is registered
        self._add(self._channel_json(topic, schema), t_ns, data)

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError(f"McapRecorder for {self.path} is closed; create a new one per run")

    # ---- Recorder protocol -------------------------------------------------------------
    def event(self, topic: str, t: float, payload: dict[str, Any]) -> None:
        """A planner event on a JSON channel; topic like "/planner/candidates"; t [s] simulated."""
        self._check_open()
        if not isinstance(topic, str) or not topic.startswith("/"):
            raise ValueError(f"event topic must be a string starting with '/', got {topic!r}")
        if topic in RESERVED_TOPICS or topic.startswith(GRID_PREFIX):
            raise ValueError(f"event topic {topic!r} is reserved by the recorder "
                             f"({list(RESERVED_TOPICS)} and {GRID_PREFIX}*); use e.g. /planner/{topic[1:]}")
        if not isinstance(payload, dict):
            raise TypeError(f"event payload for {topic} must be a dict, got {type(payload).__name__}")
        self._write_json(topic, EVENT_SCHEMA, payload, to_ns(t))
        self._clock = max(self._clock, t)

    def log(self, t: float, level: str, message: str) -> None:
        """A log line on /log (foxglove.Log); level: debug|info|warning|error|fatal; t [s]."""
        self._check_open()
        lv = LOG_LEVELS.get(str(level).lower())
        if lv is None:
            raise ValueError(f"log level {level!r} is not valid; choose one of {sorted(LOG_LEVELS)}")
        t_ns = to_ns(t)
        msg = Log(level=lv, message=str(message), name="interllm")
        msg.timestamp.FromNanoseconds(t_ns)
        self._write_proto(LOG_TOPIC, msg, t_ns)
        self._clock = max(self._clock, t)
        if lv >= Log.WARNING:
            self._w.flush()

    def action(self, result: ActionResult, context: dict[str, Any]) -> None:
        """Log one executed action: its paths, trajectory samples and result record.

        Trajectory times are taken on the mission clock; a trajectory whose first sample lies
        before ``result.t_start`` is taken as relative to the action start and shifted by it.
        """
        self._check_open()
        t0 = float(result.t_start)
        t1 = t0 + max(float(result.time), 0.0)
        t0_ns, t1_ns = to_ns(t0), to_ns(t1)
        idx = self._n_actions
        # everything is checked before anything of this action is written: a rejected action
        # leaves no trace in the log (no presumed path without its /actions record)
        for ev in result.object_events:
            if ev.object not in self._objects:
                raise ValueError(f"action {idx} ({result.action}): object event for {ev.object!r}, which is not "
                                 f"in scene {self._scene_id!r}")
            if ev.frame not in (GRIP_FRAME, WORLD_FRAME):
                raise ValueError(f"action {idx}: object event frame must be {GRIP_FRAME!r} or {WORLD_FRAME!r}, "
                                 f"got {ev.frame!r}")
            to_ns(ev.t)
        traj = self._check_trajectory(result.trajectory, t0, idx)
        n = 0 if traj is None else len(traj[0])
        rec = {**result.to_record(), "context": dict(context or {}), "index": idx, "n_samples": n}
        rec_data = dumps(rec).encode("utf-8")
        if result.presumed_path is not None and len(result.presumed_path):
            self._write_proto(PRESUMED_TOPIC, _poses_message(result.presumed_path, t0_ns), t0_ns)
        if traj is not None:
            self._write_trajectory(*traj, idx)
        self._write_object_events(result.object_events)
        if result.driven_path is not None and len(result.driven_path):
            self._write_proto(DRIVEN_TOPIC, _poses_message(result.driven_path, t1_ns), t1_ns)
        self._add(self._channel_json(ACTIONS_TOPIC, ACTION_SCHEMA), t1_ns, rec_data)
        self._n_actions += 1
        self._clock = max(self._clock, t1)
        self._w.flush()

    def _check_trajectory(self, traj: Trajectory | None, t0: float,
                          idx: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]] | None:
        """(times on the mission clock, base, joints, joint names) of a trajectory, checked; None
        for no samples."""
        if traj is None or len(traj.t) == 0:
            return None
        t = np.asarray(traj.t, dtype=float)
        if t[0] + 1e-9 < t0:
            t = t + t0
        n = len(t)
        if not np.isfinite(t).all() or (t < 0).any():
            raise ValueError(f"action {idx}: trajectory times must be finite and >= 0 s")
        try:
            base = np.ascontiguousarray(np.asarray(traj.base, dtype=float).reshape(n, 3))
            joints = np.ascontiguousarray(np.asarray(traj.joints, dtype=float).reshape(n, -1))
        except ValueError as e:
            raise ValueError(f"action {idx}: trajectory base must be {n}x3 and joints {n}xJ for its {n} "
                             f"times ({e})") from e
        if self.robot is not None and joints.shape[1] and joints.shape[1] != len(self.robot.joint_names):
            raise ValueError(f"action {idx}: trajectory has {joints.shape[1]} arm joints, the robot model "
                             f"{len(self.robot.joint_names)} ({list(self.robot.joint_names)})")
        names = list(traj.joint_names or self.joint_names)
        if len(names) != joints.shape[1]:
            names = names[:joints.shape[1]] + [f"joint_{k}" for k in range(len(names), joints.shape[1])]
        return t, base, joints, names

    def _write_trajectory(self, t: np.ndarray, base: np.ndarray, joints: np.ndarray, names: list[str],
                          idx: int) -> None:
        """One /joint_states message per sample (base pose + arm joints: the exact trajectory) and
        a /tf message for every sample where something moved: world->base_link when the base pose
        changed, the arm's link frames when the joints changed (both at an action's first sample).
        Frame transforms hold until the next one for the same frame, as in Foxglove and rerun."""
        n = len(t)
        t_ns = np.round(t * 1e9).astype(np.int64).tolist()
        base_moved = np.ones(n, dtype=bool)
        arm_moved = np.ones(n, dtype=bool)
        # bitwise: -0.0 after 0.0 is a change of text, NaN after NaN is not
        base_moved[1:] = (base[1:].view(np.int64) != base[:-1].view(np.int64)).any(axis=1)
        arm_moved[1:] = (joints[1:].view(np.int64) != joints[:-1].view(np.int64)).any(axis=1)
        base_ok = np.isfinite(base).all(axis=1).tolist()
        links = None
        if self.robot is not None and joints.shape[1]:
            rows = np.flatnonzero(arm_moved & np.isfinite(joints).all(axis=1))
            lt, lq = self.robot.link_poses(joints[rows])
            links = dict(zip(rows.tolist(), zip(lt.tolist(), lq.tolist(), strict=True), strict=True))
        jch = self._channel_json(JOINT_TOPIC, JOINT_STATES_SCHEMA)
        tch = self._channel_proto(TF_TOPIC, self._tf_base)
        # trajectory times are non-decreasing: clamp once against each channel's last time and
        # write with the mcap writer directly (this loop is the recorder's hot path)
        t_ns = np.maximum.accumulate(np.maximum(t_ns, max(self._last_ns.get(jch, 0),
                                                          self._last_ns.get(tch, 0)))).tolist()
        rows: list[tuple[int, int, bytes, int]] = []
        add = rows.append
        jseq, tseq = self._seq.get(jch, 0), self._seq.get(tch, 0)
        prefix = f'{{"action": {idx}, "base": ['
        mid = f'], "names": {dumps(names)}, "positions": ['
        base_l, joints_l = base.tolist(), joints.tolist()
        finite = (np.isfinite(joints).all(axis=1) & np.isfinite(base).all(axis=1)).tolist()
        moved_b, moved_a = base_moved.tolist(), arm_moved.tolist()
        bstr = jstr = ""
        for i in range(n):
            ns = t_ns[i]
            b = base_l[i]
            if finite[i]:  # the same bytes as dumps(), ~5x faster; a part that did not move is reused
                if moved_b[i] or not bstr:
                    bstr = ", ".join(map(repr, b))
                if moved_a[i] or not jstr:
                    jstr = ", ".join(map(repr, joints_l[i]))
                data = f'{prefix}{bstr}{mid}{jstr}]}}'.encode()
            else:
                bstr = jstr = ""
                data = dumps({"action": idx, "base": b, "names": names, "positions": joints_l[i]}).encode("utf-8")
            add((jch, ns, data, jseq))
            jseq += 1
            link = links.get(i) if links is not None else None
            move_b = moved_b[i] and base_ok[i]  # a non-finite base pose has no transform
            if move_b and link is None:  # the common case (driving): reuse one message
                tr = self._tf_base_tr
                tr.timestamp.seconds, tr.timestamp.nanos = divmod(ns, 1_000_000_000)
                tr.translation.x, tr.translation.y = b[0], b[1]
                tr.rotation.z, tr.rotation.w = math.sin(b[2] / 2.0), math.cos(b[2] / 2.0)
                add((tch, ns, self._tf_base.SerializeToString(), tseq))
                tseq += 1
            elif move_b or link is not None:
                msg = FrameTransforms()
                if move_b:
                    tr = msg.transforms.add()
                    tr.timestamp.FromNanoseconds(ns)
                    tr.parent_frame_id, tr.child_frame_id = WORLD_FRAME, BASE_FRAME
                    tr.translation.x, tr.translation.y = b[0], b[1]
                    _, _, tr.rotation.z, tr.rotation.w = yaw_quat_xyzw(b[2])
                if link is not None:
                    for (parent, child), xyz, quat in zip(self.robot.chain, *link, strict=True):
                        lt = msg.transforms.add()
                        lt.timestamp.FromNanoseconds(ns)
                        lt.parent_frame_id, lt.child_frame_id = parent, child
                        lt.translation.x, lt.translation.y, lt.translation.z = xyz
                        lt.rotation.x, lt.rotation.y, lt.rotation.z, lt.rotation.w = quat
                add((tch, ns, msg.SerializeToString(), tseq))
                tseq += 1
        self._w.add_messages(rows)
        self._seq[jch], self._seq[tch] = jseq, tseq
        self._last_ns[jch] = self._last_ns[tch] = t_ns[-1]

    def _write_object_events(self, events) -> None:
        """Per grasp / release: the exact event on /objects/events and the whole object state on
        /scene/objects."""
        for ev in events:
            t_ns = to_ns(ev.t)
            pos = tuple(float(v) for v in ev.position)
            quat = tuple(float(v) for v in ev.quaternion)
            self._write_json(OBJECT_EVENTS_TOPIC, OBJECT_EVENT_SCHEMA,
                             {"object": ev.object, "frame": ev.frame, "position": pos, "quaternion": quat}, t_ns)
            self._object_state[ev.object] = (ev.frame, pos, quat)
            self._write_proto(OBJECTS_TOPIC, _objects_update(self._objects, self._object_state, t_ns, self._frames),
                              t_ns)

    # ---- lifecycle ---------------------------------------------------------------------
    def close(self, status: str = "ok", error: str = "") -> Path:
        """Finish the file (summary, index, footer) and rename ``.partial`` to the final path."""
        if self._closed:
            return self.path
        self._w.add_metadata("end", {"status": status, "error": error, "n_actions": str(self._n_actions),
                                     "sim_time": repr(float(self._clock))})
        self._w.finish()
        self._file.flush()
        os.fsync(self._file.fileno())
        self._file.close()
        os.replace(self.partial_path, self.path)
        self._closed = True
        return self.path

    def __enter__(self) -> McapRecorder:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.close(status="error", error=f"{exc_type.__name__}: {exc}")
