"""One MCAP log per mission run, written as the run proceeds (``McapRecorder``).

File handling: the recorder writes to ``<path>.partial`` and renames it to ``<path>`` in
``close()``. A run that is killed leaves ``<path>.partial``: a valid MCAP prefix (header, the
"run" metadata, the scene attachment and every chunk completed so far) that
``record.reader.read_run`` and ``record.replay.replay`` read up to its last complete chunk. So
``<path>`` existing means the run finished (its "end" metadata says whether it raised).

Crash safety: chunks are zstd-compressed and at most ``chunk_size`` bytes (uncompressed); after
every action (and every log line at level warning or above) the chunk in progress is finished and
the stream flushed to the OS, so a SIGKILL loses at most the events logged since the last action.

Metadata records: "run" (given at construction; values that are not strings are stored as
canonical JSON strings, e.g. "config", "packages"), and "end" on close ({"status": "ok" |
"error", "error": text, "n_actions", "sim_time"}). Attachment "scene.json": the SceneGraph JSON
(``SceneGraph.to_dict`` in ``jsonfmt.compact``).
Determinism: no wall-clock anywhere; identical inputs give byte-identical files.

The topics and their schemas are in ``interllm.record.topics``, the Foxglove conversion in
``interllm.record.foxglove``.
"""

from __future__ import annotations

import functools
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.PosesInFrame_pb2 import PosesInFrame
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap_protobuf.schema import build_file_descriptor_set

from interllm.core import jsonfmt
from interllm.core.frames import BASE_FRAME, GRIP_FRAME, WORLD_FRAME
from interllm.core.results import ActionResult, Trajectory
from interllm.io import check_inside, ensure_dir
from interllm.record import wire
from interllm.record.foxglove import ObjectsUpdates, grid_message, path_poses, scene_update
from interllm.record.sdk_writer import COMPRESSIONS, FoxgloveSdkWriter
from interllm.record.topics import (
    ACTION_SCHEMA,
    ACTIONS_TOPIC,
    DRIVEN_TOPIC,
    EVENT_SCHEMA,
    GRID_PREFIX,
    JOINT_TOPIC,
    LOG_LEVELS,
    LOG_TOPIC,
    OBJECT_EVENT_SCHEMA,
    OBJECT_EVENTS_TOPIC,
    OBJECTS_TOPIC,
    PRESUMED_TOPIC,
    RESERVED_TOPICS,
    SCENE_TOPIC,
    TF_TOPIC,
    JointStates,
    dumps,
    metadata_str,
    to_ns,
)
from interllm.scene.graph import SceneGraph
from interllm.scene.grid import OccupancyGrid


@functools.cache
def _protobuf_schema(message_type: type) -> bytes:
    """The MCAP schema data of a protobuf message type (its FileDescriptorSet, with the files it
    imports), built once per process."""
    return build_file_descriptor_set(message_type).SerializeToString()


class McapRecorder:
    """Recorder writing one ``.mcap`` per mission run (see the module docstring for the layout).

    path: final file path (``.mcap``); the run is written to ``<path>.partial`` until ``close()``.
    scene: the mission's scene (``/scene`` and the "scene.json" attachment).
    metadata: the "run" metadata record (resolved config, git commit, seed, package versions, ...);
        non-string values are stored as canonical JSON strings.
    grids: occupancy grids by name (``/grid/<name>``), e.g. {"presumed": ..., "true": ...}.
    joint_names: arm joint names for ``/joint_states`` when a Trajectory carries none.
    chunk_size: uncompressed chunk size limit [bytes]; compression: "zstd" | "lz4" | "none". The file
        is written through Foxglove's SDK (``record/sdk_writer.py``).
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
        ensure_dir(check_inside(self.path).parent)
        check_inside(self.partial_path)
        self.joint_names = tuple(joint_names or (robot.joint_names if robot is not None else ()))
        self.robot = robot
        self._scene_id = scene.id
        self._objects = dict(scene.objects)
        self._object_state = {o.id: (WORLD_FRAME, tuple(o.position), (0.0, 0.0, 0.0, 1.0))
                              for o in scene.objects.values()}
        self._frames = {WORLD_FRAME, BASE_FRAME, *(c for _, c in robot.chain)} if robot is not None \
            else {WORLD_FRAME, BASE_FRAME}
        self._w = FoxgloveSdkWriter(self.partial_path, chunk_size, compression)
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._last_ns: dict[int, int] = {}
        self._n_actions = 0
        self._tf_templates: dict[tuple[bool, bool], tuple[FrameTransforms, list[tuple[Any, Any, Any]]]] = {}
        self._link_memo: dict[bytes, tuple[list, list]] = {}
        self._clock = 0.0
        self._closed = False

        self._w.add_metadata("run", {str(k): metadata_str(v) for k, v in sorted((metadata or {}).items())})
        self._w.add_attachment(create_time=0, log_time=0, name="scene.json", media_type="application/json",
                               data=jsonfmt.compact(scene.to_dict()).encode("utf-8"))
        self._write_proto(SCENE_TOPIC, scene_update(scene, robot.visuals() if robot is not None else ()), 0)
        self._objects_updates = ObjectsUpdates(self._objects, self._frames)
        self._write_objects(0)
        for name, grid in sorted((grids or {}).items()):
            self._write_proto(GRID_PREFIX + name, grid_message(grid), 0)
        self._w.flush()

    # ---- channels ----------------------------------------------------------------------
    def _channel_proto(self, topic: str, message_type: type) -> int:
        ch = self._channels.get(topic)
        if ch is None:
            name = message_type.DESCRIPTOR.full_name
            sid = self._schemas.get(name)
            if sid is None:
                sid = self._schemas[name] = self._w.register_schema(name, SchemaEncoding.Protobuf,
                                                                    _protobuf_schema(message_type))
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
        self._w.add_message(ch, t_ns, data)

    def _write_proto(self, topic: str, msg: Any, t_ns: int) -> None:
        self._add(self._channel_proto(topic, type(msg)), t_ns, msg.SerializeToString())

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
        rec = {**result.to_record(paths=False), "context": dict(context or {}), "index": idx, "n_samples": n}
        rec_data = dumps(rec).encode("utf-8")
        if result.presumed_path is not None:  # also an empty one: read_run restores the path from it
            self._add(self._channel_proto(PRESUMED_TOPIC, PosesInFrame), t0_ns, path_poses(result.presumed_path, t0_ns))
        if traj is not None:
            self._write_trajectory(*traj, idx)
        self._write_object_events(result.object_events)
        if result.driven_path is not None:
            self._add(self._channel_proto(DRIVEN_TOPIC, PosesInFrame), t1_ns, path_poses(result.driven_path, t1_ns))
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
        Frame transforms hold until the next one for the same frame, as in Foxglove and rerun.
        This is the recorder's hot path: the joint states of all samples are built in one call
        (``wire.joint_states``), the transforms by refilling templates (``_transforms``)."""
        n = len(t)
        jch = self._channel_proto(JOINT_TOPIC, JointStates)
        tch = self._channel_proto(TF_TOPIC, FrameTransforms)
        # trajectory times are non-decreasing: clamp once against both channels' last times
        start = max(self._last_ns.get(jch, 0), self._last_ns.get(tch, 0))
        t_ns = np.maximum.accumulate(np.maximum(np.round(t * 1e9).astype(np.int64), start))
        base_moved, arm_moved = np.ones(n, dtype=bool), np.ones(n, dtype=bool)
        # bitwise: -0.0 after 0.0 is a change, NaN after NaN is not
        base_moved[1:] = (base[1:].view(np.int64) != base[:-1].view(np.int64)).any(axis=1)
        arm_moved[1:] = (joints[1:].view(np.int64) != joints[:-1].view(np.int64)).any(axis=1)
        states = wire.joint_states(idx, names, base, joints)
        transforms = self._transforms(t_ns, base, joints, base_moved, arm_moved)
        t_l = t_ns.tolist()
        rows: list[tuple[int, int, bytes]] = []
        for ns, state, tf in zip(t_l, states, transforms, strict=True):
            rows.append((jch, ns, state))
            if tf is not None:
                rows.append((tch, ns, tf))
        self._w.add_messages(rows)
        self._last_ns[jch] = self._last_ns[tch] = t_l[-1]

    def _transforms(self, t_ns: np.ndarray, base: np.ndarray, joints: np.ndarray, base_moved: np.ndarray,
                    arm_moved: np.ndarray) -> list[bytes | None]:
        """Per sample, the serialized /tf FrameTransforms (None where nothing moved): world ->
        base_link where the (finite) base pose moved, then the arm's link frames where the (finite)
        joints moved. Each refills a template message (``_tf_template``) that protobuf's C code
        serializes."""
        move_b = (base_moved & np.isfinite(base).all(axis=1)).tolist()  # a non-finite base pose has no transform
        links: dict[int, tuple[list, list]] = {}
        if self.robot is not None and joints.shape[1]:
            rows = np.flatnonzero(arm_moved & np.isfinite(joints).all(axis=1))
            if len(rows):
                links = dict(zip(rows.tolist(), self._link_poses(joints[rows]), strict=True))
        out: list[bytes | None] = [None] * len(t_ns)
        sec, nanos = (t_ns // 1_000_000_000).tolist(), (t_ns % 1_000_000_000).tolist()
        base_l = base.tolist()
        sin, cos = math.sin, math.cos  # yaw -> (0, 0, sin(yaw / 2), cos(yaw / 2)), as core.frames.yaw_quat_xyzw
        msg, ((stamp, xyz, quat),) = self._tf_template(True, False)
        serialize = msg.SerializeToString
        for i in (i for i, moved in enumerate(move_b) if moved and i not in links):  # driving: the hot loop
            b = base_l[i]
            stamp.seconds, stamp.nanos = sec[i], nanos[i]
            xyz.x, xyz.y = b[0], b[1]
            quat.z, quat.w = sin(b[2] / 2.0), cos(b[2] / 2.0)
            out[i] = serialize()
        for i, (link_xyz, link_quat) in links.items():  # the arm moved: base (if it moved too) and link frames
            msg, fields = self._tf_template(move_b[i], True)
            if move_b[i]:
                b = base_l[i]
                stamp, xyz, quat = fields[0]
                stamp.seconds, stamp.nanos = sec[i], nanos[i]
                xyz.x, xyz.y = b[0], b[1]
                quat.z, quat.w = sin(b[2] / 2.0), cos(b[2] / 2.0)
            for (stamp, xyz, quat), t, q in zip(fields[move_b[i]:], link_xyz, link_quat, strict=True):
                stamp.seconds, stamp.nanos = sec[i], nanos[i]
                xyz.x, xyz.y, xyz.z = t
                quat.x, quat.y, quat.z, quat.w = q
            out[i] = msg.SerializeToString()
        return out

    def _link_poses(self, joints: np.ndarray) -> list[tuple[list, list]]:
        """Per row of ``joints`` [N, J] [rad], the link frames' (translations [L][3] [m], quaternions
        [L][4]). A single row (an action's first sample, where the arm usually rests as the last
        action left it) is memoised."""
        key = joints.tobytes() if len(joints) == 1 else None
        if key is not None and key in self._link_memo:
            return [self._link_memo[key]]
        lt, lq = self.robot.link_poses(joints)
        out = list(zip(lt.tolist(), lq.tolist(), strict=True))
        if key is not None:
            if len(self._link_memo) >= 64:
                self._link_memo.clear()
            self._link_memo[key] = out[0]
        return out

    def _tf_template(self, with_base: bool, with_arm: bool) -> tuple[FrameTransforms, list[tuple[Any, Any, Any]]]:
        """A FrameTransforms with world -> base_link (``with_base``) and the arm's link frames
        (``with_arm``), and per transform its (timestamp, translation, rotation) sub-messages, held
        so that refilling them skips the attribute lookups. Made once per recorder; a field set to
        zero is left out of the serialization, as in a new message."""
        key = (with_base, with_arm)
        if key not in self._tf_templates:
            msg = FrameTransforms()
            pairs = ([(WORLD_FRAME, BASE_FRAME)] if with_base else []) + (list(self.robot.chain) if with_arm else [])
            fields = []
            for parent, child in pairs:
                tr = msg.transforms.add()
                tr.parent_frame_id, tr.child_frame_id = parent, child
                fields.append((tr.timestamp, tr.translation, tr.rotation))
            self._tf_templates[key] = (msg, fields)
        return self._tf_templates[key]

    def _write_objects(self, t_ns: int) -> None:
        """/scene/objects: every object's current state at ``t_ns`` [ns]."""
        self._add(self._channel_proto(OBJECTS_TOPIC, SceneUpdate), t_ns,
                  self._objects_updates.message(self._object_state, t_ns))

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
            self._write_objects(t_ns)

    # ---- lifecycle ---------------------------------------------------------------------
    def close(self, status: str = "ok", error: str = "") -> Path:
        """Finish the file (summary, index, footer) and rename ``.partial`` to the final path."""
        if self._closed:
            return self.path
        self._w.add_metadata("end", {"status": status, "error": error, "n_actions": str(self._n_actions),
                                     "sim_time": repr(float(self._clock))})
        self._w.finish()
        fd = os.open(self.partial_path, os.O_RDONLY)  # the SDK wrote and closed the file: make it durable
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
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
