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

- ``/scene``          foxglove.SceneUpdate at t=0: walls, door leaves, furniture, objects as cubes
- ``/grid/<name>``    foxglove.Grid at t=0 per given grid (uint8 "occupancy": 0 free, 100 occupied)
- ``/tf``             foxglove.FrameTransforms per trajectory sample: world -> base_link from
                      Trajectory.base; arm links only when an ``fk`` callable is given (there is no
                      forward kinematics in this package: without ``fk``, arm joint angles are only
                      on ``/joint_states``)
- ``/joint_states``   JSON {"names", "positions", "action"} per trajectory sample
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

import json
import math
import os
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.Grid_pb2 import Grid
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.PackedElementField_pb2 import PackedElementField
from foxglove_schemas_protobuf.PosesInFrame_pb2 import PosesInFrame
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import CompressionType, Writer
from mcap_protobuf.schema import register_schema

from interllm.scene.graph import SceneGraph
from interllm.scene.grid import OccupancyGrid
from interllm.sim.results import ActionResult, Trajectory

WORLD_FRAME = "world"
BASE_FRAME = "base_link"
DOOR_HEIGHT = 2.0  # [m] drawn height of a door leaf
DOOR_LEAF_THICKNESS = 0.04  # [m]
OCCUPIED = 100  # grid cell value of an occupied cell (0 = free)

TF_TOPIC = "/tf"
SCENE_TOPIC = "/scene"
JOINT_TOPIC = "/joint_states"
PRESUMED_TOPIC = "/path/presumed"
DRIVEN_TOPIC = "/path/driven"
ACTIONS_TOPIC = "/actions"
LOG_TOPIC = "/log"
GRID_PREFIX = "/grid/"
RESERVED_TOPICS = (TF_TOPIC, SCENE_TOPIC, JOINT_TOPIC, PRESUMED_TOPIC, DRIVEN_TOPIC, ACTIONS_TOPIC,
                   LOG_TOPIC)

LOG_LEVELS = {"debug": Log.DEBUG, "info": Log.INFO, "warning": Log.WARNING, "warn": Log.WARNING,
              "error": Log.ERROR, "fatal": Log.FATAL}
LOG_LEVEL_NAMES = {Log.UNKNOWN: "unknown", Log.DEBUG: "debug", Log.INFO: "info",
                   Log.WARNING: "warning", Log.ERROR: "error", Log.FATAL: "fatal"}

COMPRESSIONS = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}

# A pose link produced by an optional forward-kinematics callable:
# (parent_frame, child_frame, (x, y, z) [m], (qx, qy, qz, qw)).
Link = tuple[str, str, Sequence[float], Sequence[float]]
FK = Callable[[np.ndarray, np.ndarray], Iterable[Link]]

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
    "required": ["names", "positions"],
    "properties": {"names": {"type": "array", "items": {"type": "string"}},
                   "positions": {"type": "array", "items": {"type": "number"},
                                 "description": "arm joint angles [rad]"},
                   "action": {"type": "integer", "description": "index of the action it belongs to"}},
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
    return json.dumps(obj, sort_keys=True, default=_json_default, ensure_ascii=False)


def _meta_str(v: Any) -> str:
    return v if isinstance(v, str) else dumps(v)


def yaw_quat(yaw: float) -> tuple[float, float, float, float]:
    """Rotation about z by yaw [rad] as (x, y, z, w)."""
    return 0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)


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


def _scene_update(scene: SceneGraph) -> SceneUpdate:
    msg = SceneUpdate()
    for b in scene_boxes(scene):
        e = msg.entities.add()
        e.frame_id = WORLD_FRAME
        e.id = f"{b['kind']}/{b['id']}"
        e.frame_locked = True
        for k, v in (("kind", b["kind"]), ("category", b.get("category", b["kind"]))):
            kv = e.metadata.add()
            kv.key, kv.value = k, v
        c = e.cubes.add()
        c.pose.position.x, c.pose.position.y, c.pose.position.z = (float(v) for v in b["center"])
        qx, qy, qz, qw = yaw_quat(b["yaw"])
        c.pose.orientation.x, c.pose.orientation.y = qx, qy
        c.pose.orientation.z, c.pose.orientation.w = qz, qw
        c.size.x, c.size.y, c.size.z = (float(v) for v in b["size"])
        _set_color(c.color, _COLORS[b["kind"]])
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
    for i in range(n):
        j0, j1 = (i, i + 1) if i + 1 < n else (max(i - 1, 0), i)
        yaw = math.atan2(path[j1, 1] - path[j0, 1], path[j1, 0] - path[j0, 0]) if n > 1 else 0.0
        p = msg.poses.add()
        p.position.x, p.position.y = float(path[i, 0]), float(path[i, 1])
        _, _, p.orientation.z, p.orientation.w = yaw_quat(yaw)
    return msg


class McapRecorder:
    """Recorder writing one ``.mcap`` per mission run (see the module docstring for the layout).

    path: final file path (``.mcap``); the run is written to ``<path>.partial`` until ``close()``.
    scene: the mission's scene (``/scene`` and the "scene.json" attachment).
    metadata: the "run" metadata record (resolved config, git commit, seed, package versions, ...);
        non-string values are stored as canonical JSON strings.
    grids: occupancy grids by name (``/grid/<name>``), e.g. {"presumed": ..., "true": ...}.
    joint_names: arm joint names for ``/joint_states`` when a Trajectory carries none.
    chunk_size: uncompressed chunk size limit [bytes]; compression: "zstd" | "lz4" | "none".
    fk: optional forward kinematics ``fk(base_xyyaw[3], joints[n]) -> [(parent, child, xyz, quat)]``
        adding arm link frames to each ``/tf`` sample.
    """

    def __init__(self, path: str | os.PathLike, scene: SceneGraph, metadata: dict[str, Any] | None = None,
                 grids: dict[str, OccupancyGrid] | None = None, joint_names: Sequence[str] = (), *,
                 chunk_size: int = 256 * 1024, compression: str = "zstd", fk: FK | None = None) -> None:
        if compression not in COMPRESSIONS:
            raise ValueError(f"compression {compression!r} is not valid; choose one of {list(COMPRESSIONS)}")
        if chunk_size < 1024:
            raise ValueError(f"chunk_size must be >= 1024 bytes, got {chunk_size}")
        self.path = Path(path)
        self.partial_path = self.path.with_name(self.path.name + ".partial")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.joint_names = tuple(joint_names)
        self.fk = fk
        self._file = open(self.partial_path, "wb")
        self._w = Writer(self._file, chunk_size=chunk_size, compression=COMPRESSIONS[compression])
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
        self._write_proto(SCENE_TOPIC, _scene_update(scene), 0)
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
        idx = self._n_actions
        if result.presumed_path is not None and len(result.presumed_path):
            self._write_proto(PRESUMED_TOPIC, _poses_message(result.presumed_path, to_ns(t0)), to_ns(t0))
        n = self._write_trajectory(result.trajectory, t0, idx)
        if result.driven_path is not None and len(result.driven_path):
            self._write_proto(DRIVEN_TOPIC, _poses_message(result.driven_path, to_ns(t1)), to_ns(t1))
        rec = {**result.to_record(), "context": dict(context or {}), "index": idx, "n_samples": n}
        self._write_json(ACTIONS_TOPIC, ACTION_SCHEMA, rec, to_ns(t1))
        self._n_actions += 1
        self._clock = max(self._clock, t1)
        self._w.flush()

    def _write_trajectory(self, traj: Trajectory | None, t0: float, idx: int) -> int:
        if traj is None or len(traj.t) == 0:
            return 0
        t = np.asarray(traj.t, dtype=float)
        if t[0] + 1e-9 < t0:
            t = t + t0
        base = np.asarray(traj.base, dtype=float).reshape(len(t), 3)
        joints = np.asarray(traj.joints, dtype=float).reshape(len(t), -1)
        names = list(traj.joint_names or self.joint_names)
        if joints.shape[1] and len(names) != joints.shape[1]:
            names = names[:joints.shape[1]] + [f"joint_{k}" for k in range(len(names), joints.shape[1])]
        jch = self._channel_json(JOINT_TOPIC, JOINT_STATES_SCHEMA) if joints.shape[1] else 0
        prefix = f'{{"action": {idx}, "names": {dumps(names)}, "positions": ['
        finite = np.isfinite(joints).all(axis=1)
        for i in range(len(t)):
            t_ns = to_ns(float(t[i]))
            x, y, yaw = base[i]
            msg = FrameTransforms()
            tr = msg.transforms.add()
            tr.timestamp.FromNanoseconds(t_ns)
            tr.parent_frame_id, tr.child_frame_id = WORLD_FRAME, BASE_FRAME
            tr.translation.x, tr.translation.y = float(x), float(y)
            _, _, tr.rotation.z, tr.rotation.w = yaw_quat(float(yaw))
            if self.fk is not None:
                for parent, child, xyz, quat in self.fk(base[i], joints[i]):
                    lt = msg.transforms.add()
                    lt.timestamp.FromNanoseconds(t_ns)
                    lt.parent_frame_id, lt.child_frame_id = parent, child
                    lt.translation.x, lt.translation.y, lt.translation.z = (float(v) for v in xyz)
                    (lt.rotation.x, lt.rotation.y, lt.rotation.z,
                     lt.rotation.w) = (float(v) for v in quat)
            self._write_proto(TF_TOPIC, msg, t_ns)
            if joints.shape[1]:
                row = joints[i].tolist()
                if finite[i]:  # same bytes as dumps(), ~5x faster
                    data = f'{prefix}{", ".join(map(repr, row))}]}}'.encode()
                else:
                    data = dumps({"names": names, "positions": row, "action": idx}).encode("utf-8")
                self._add(jch, t_ns, data)
        return len(t)

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
