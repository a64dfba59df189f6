"""Read a run's MCAP back (``read_run``), complete or truncated.

A complete file (footer and summary present) is read with ``mcap.reader.make_reader`` in file
order. A file without a readable summary (a run killed mid-way, usually ``<run>.mcap.partial``)
is read with a streaming reader that stops at the last complete chunk; ``RunLog.complete`` is
then False and ``RunLog.stopped_at`` says where the readable part ends (byte offset, chunk count
and the last simulated time). A file its writer finished (the trailing magic is there) that fails a
checksum on the way is damaged, not truncated: :class:`RunLogCorruptError`.

Trajectory samples (``/joint_states``: base pose and arm joints, exact) are assigned to actions
in file order: the recorder writes an action's samples right before its ``/actions`` record.
``/tf`` is read into per-frame transform series (``RunLog.frames``), ``/objects/events`` into
object moves (``RunLog.object_moves``: grasps and releases) and the robot's shapes from the first
``/scene`` update (``RunLog.robot_visuals``).
"""

from __future__ import annotations

import io
import json
import os
from collections import defaultdict
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.Grid_pb2 import Grid
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.PosesInFrame_pb2 import PosesInFrame
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from mcap.reader import make_reader
from mcap.records import Attachment, Channel, Chunk, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader, breakup_chunk

from interllm.core.records import CommandRecord
from interllm.core.results import ActionResult, Trajectory
from interllm.errors import MissingInputError, UserError
from interllm.record.foxglove import OCCUPIED
from interllm.record.topics import (
    ACTIONS_TOPIC,
    COMMAND_RESULTS_TOPIC,
    DRIVEN_TOPIC,
    GRID_PREFIX,
    JOINT_TOPIC,
    LOG_LEVEL_NAMES,
    LOG_TOPIC,
    OBJECT_EVENTS_TOPIC,
    OBJECTS_TOPIC,
    PRESUMED_TOPIC,
    SCENE_TOPIC,
    TF_TOPIC,
    JointStates,
)
from interllm.scene.graph import SceneGraph
from interllm.scene.grid import OccupancyGrid

MAGIC = b"\x89MCAP0\r\n"  # an MCAP file starts and, once its writer finished it, ends with these bytes


class RunLogFormatError(UserError, ValueError):
    """A readable run log whose content this version cannot interpret (not a truncation)."""


class RunLogCorruptError(UserError, ValueError):
    """A run log its writer finished (it ends with the MCAP magic) that fails its checksums or cannot be
    decoded: a damaged copy, not a killed run's truncation."""


@dataclass
class FrameSeries:
    """Transforms of one frame in its parent over time, as logged on /tf."""

    parent: str
    t: np.ndarray  # [K] [s]
    xyz: np.ndarray  # [K, 3] [m]
    quat: np.ndarray  # [K, 4] (x, y, z, w)


@dataclass(frozen=True)
class ObjectMove:
    """An /objects/events record: an object grasped (frame "grip": its pose in the gripper frame)
    or released (frame "world": where it was put). size from the scene attachment."""

    t: float
    object: str
    frame: str
    position: tuple[float, float, float]
    quaternion: tuple[float, float, float, float]  # (x, y, z, w)
    size: tuple[float, float, float]


@dataclass(frozen=True)
class RobotVisual:
    """One robot primitive from the first /scene update, drawn locked to a /tf frame."""

    frame: str
    name: str
    shape: str  # "cube" | "cylinder" | "sphere"
    size: tuple[float, float, float]  # full extents [m] (cylinder: diameter, diameter, length)
    position: tuple[float, float, float]
    quaternion: tuple[float, float, float, float]  # (x, y, z, w)
    color: tuple[float, float, float, float]  # rgba 0..1


@dataclass
class RunLog:
    """Everything one run's MCAP holds. Times t are simulated mission time [s]."""

    path: Path
    metadata: dict[str, dict[str, str]]  # metadata records by name ("run", "end"), raw strings
    run: dict[str, Any]  # the "run" record with JSON values decoded (config, packages, seed, ...)
    scene: SceneGraph | None  # from the "scene.json" attachment
    grids: dict[str, OccupancyGrid]  # from /grid/<name>
    actions: list[ActionResult]  # from /actions (ActionResult.from_record) + their trajectories
    contexts: list[dict[str, Any]]  # context given with each action
    events: dict[str, list[tuple[float, dict]]]  # JSON event topic -> [(t, payload)]
    logs: list[tuple[float, str, str]]  # /log: (t, level, message)
    base: np.ndarray  # [N, 4] t [s], x [m], y [m], yaw [rad] of every trajectory sample
    joint_names: tuple[str, ...]
    joints: np.ndarray  # [N, n_joints] /joint_states positions [rad]
    joint_t: np.ndarray  # [N] their times [s]
    presumed_paths: list[tuple[float, np.ndarray]]  # /path/presumed (t, [K, 2])
    driven_paths: list[tuple[float, np.ndarray]]  # /path/driven (t, [K, 2])
    counts: dict[str, int]  # messages per topic that were read
    complete: bool  # footer and summary present (the writer closed the file)
    stopped_at: str | None = None  # where a truncated file stops being readable
    summary_counts: dict[str, int] = field(default_factory=dict)  # counts from the MCAP summary
    frames: dict[str, FrameSeries] = field(default_factory=dict)  # /tf by child frame
    object_moves: list[ObjectMove] = field(default_factory=list)  # /objects/events
    robot_visuals: list[RobotVisual] = field(default_factory=list)  # robot links on the first /scene

    @property
    def status(self) -> str:
        """"ok" / "error" from the "end" record; "truncated" when the run never closed the file."""
        return self.metadata.get("end", {}).get("status", "truncated")

    def command_records(self) -> list[tuple[float, CommandRecord]]:
        """(end time [s], record) of every command the run finished, from its /results/command events
        and the /actions records they count (a truncated run: the commands it finished)."""
        out, start = [], 0
        for i, (t, payload) in enumerate(self.events.get(COMMAND_RESULTS_TOPIC, [])):
            n = int(payload.get("n_actions", -1))
            if n < 0 or start + n > len(self.actions):
                raise RunLogFormatError(f"{self.path}: {COMMAND_RESULTS_TOPIC} record {i} counts {n} actions, "
                                        f"but only {len(self.actions) - start} /actions records follow the "
                                        f"earlier commands'")
            out.append((t, CommandRecord.from_dict(payload, f"{self.path}: {COMMAND_RESULTS_TOPIC}[{i}]",
                                                   actions=self.actions[start:start + n])))
            start += n
        return out

    @property
    def sim_time(self) -> float:
        """Last simulated time seen in the log [s]."""
        ts = [0.0] + [a.t_start + a.time for a in self.actions] + [t for t, _, _ in self.logs]
        ts += [t for v in self.events.values() for t, _ in v]
        if len(self.base):
            ts.append(float(self.base[-1, 0]))
        return max(ts)


def _robot_visuals(msg: SceneUpdate) -> list[RobotVisual]:
    out = []
    for e in msg.entities:
        if {m.key: m.value for m in e.metadata}.get("kind") != "robot":
            continue
        for shape, prims in (("cube", e.cubes), ("cylinder", e.cylinders), ("sphere", e.spheres)):
            for p in prims:
                q, c = p.pose.orientation, p.color
                out.append(RobotVisual(e.frame_id, e.id, shape, (p.size.x, p.size.y, p.size.z),
                                       (p.pose.position.x, p.pose.position.y, p.pose.position.z),
                                       (q.x, q.y, q.z, q.w), (c.r, c.g, c.b, c.a)))
    return out


def _grid_from_message(msg: Grid) -> OccupancyGrid:
    cols = msg.column_count
    data = np.frombuffer(msg.data, dtype=np.uint8)
    rows = len(data) // max(msg.row_stride, 1)
    arr = data.reshape(rows, msg.row_stride)[:, :cols * msg.cell_stride:msg.cell_stride]
    return OccupancyGrid(occupied=arr >= OCCUPIED // 2, resolution=float(msg.cell_size.x),
                         origin=(float(msg.pose.position.x), float(msg.pose.position.y)))


def _path_from_message(msg: PosesInFrame) -> np.ndarray:
    return np.array([[p.position.x, p.position.y] for p in msg.poses], dtype=float).reshape(-1, 2)


class _Builder:
    """Accumulates decoded messages (in file order) into a RunLog."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.metadata: dict[str, dict[str, str]] = {}
        self.scene: SceneGraph | None = None
        self.grids: dict[str, OccupancyGrid] = {}
        self.actions: list[ActionResult] = []
        self.contexts: list[dict] = []
        self.events: dict[str, list[tuple[float, dict]]] = defaultdict(list)
        self.logs: list[tuple[float, str, str]] = []
        self.base: list[tuple[float, float, float, float]] = []
        self.joint_t: list[float] = []
        self.joints: list[list[float]] = []
        self.joint_names: tuple[str, ...] = ()
        self.presumed: list[tuple[float, np.ndarray]] = []
        self.driven: list[tuple[float, np.ndarray]] = []
        self.counts: dict[str, int] = defaultdict(int)
        self._pending: list[tuple[float, list[float], list[float]]] = []  # (t, base, joints)
        self._pending_presumed: np.ndarray | None = None  # the /path messages of the action in progress
        self._pending_driven: np.ndarray | None = None
        self.tf: dict[str, tuple[str, list]] = {}  # child -> (parent, [(t, x, y, z, qx, qy, qz, qw)])
        self.moves: list[ObjectMove] = []
        self._n_scene = 0
        self.robot_visuals: list[RobotVisual] = []
        self.last_t = 0.0

    def metadata_record(self, m: Metadata) -> None:
        self.metadata[m.name] = dict(m.metadata)

    def attachment(self, a: Attachment) -> None:
        if a.name == "scene.json":
            self.scene = SceneGraph.from_json(bytes(a.data).decode("utf-8"))

    def message(self, topic: str, msg: Message) -> None:
        t = msg.log_time / 1e9
        self.last_t = max(self.last_t, t)
        self.counts[topic] += 1
        data = bytes(msg.data)
        if topic == TF_TOPIC:
            for tr in FrameTransforms.FromString(data).transforms:
                series = self.tf.setdefault(tr.child_frame_id, (tr.parent_frame_id, []))[1]
                series.append((t, tr.translation.x, tr.translation.y, tr.translation.z, tr.rotation.x,
                               tr.rotation.y, tr.rotation.z, tr.rotation.w))
        elif topic == JOINT_TOPIC:
            if data[:1] == b"{":  # JSON, which JointStates (protobuf) never starts with
                raise RunLogFormatError(f"/joint_states at t={t:.3f} s is JSON: the log was written by an older "
                                        f"interllm (joint states are protobuf interllm.JointStates now); rerun the "
                                        f"missions stage (dvc repro --force missions) to rewrite the run logs")
            js = JointStates.FromString(data)
            base, positions = list(js.base), list(js.positions)
            self.joint_names = tuple(js.names)
            self.joint_t.append(t)
            self.joints.append(positions)
            self.base.append((t, *base))
            self._pending.append((t, base, positions))
        elif topic == ACTIONS_TOPIC:
            d = json.loads(data)
            # the action's paths: the /path messages since the last action (logs before they moved
            # out of /actions carry them in the record)
            d.setdefault("presumed_path", self._pending_presumed)
            d.setdefault("driven_path", self._pending_driven)
            self._pending_presumed = self._pending_driven = None
            res = ActionResult.from_record(d)
            if self._pending:
                n = len(self._pending)
                res.trajectory = Trajectory(
                    t=np.asarray([p[0] for p in self._pending], dtype=float),
                    base=np.asarray([p[1] for p in self._pending], dtype=float).reshape(n, 3),
                    joints=np.asarray([p[2] for p in self._pending], dtype=float).reshape(n, -1),
                    joint_names=self.joint_names)
            self._pending = []
            self.actions.append(res)
            self.contexts.append(d.get("context", {}))
        elif topic == LOG_TOPIC:
            m = Log.FromString(data)
            self.logs.append((t, LOG_LEVEL_NAMES.get(m.level, "unknown"), m.message))
        elif topic == PRESUMED_TOPIC:
            self._pending_presumed = _path_from_message(PosesInFrame.FromString(data))
            self.presumed.append((t, self._pending_presumed))
        elif topic == DRIVEN_TOPIC:
            self._pending_driven = _path_from_message(PosesInFrame.FromString(data))
            self.driven.append((t, self._pending_driven))
        elif topic.startswith(GRID_PREFIX):
            self.grids[topic[len(GRID_PREFIX):]] = _grid_from_message(Grid.FromString(data))
        elif topic == SCENE_TOPIC:
            self._n_scene += 1
            if self._n_scene == 1:  # the initial scene: exact in "scene.json"; robot shapes only here
                self.robot_visuals = _robot_visuals(SceneUpdate.FromString(data))
        elif topic == OBJECTS_TOPIC:
            pass  # what viewers draw; the exact events are on /objects/events
        elif topic == OBJECT_EVENTS_TOPIC:
            d = json.loads(data)
            o = self.scene.objects.get(d["object"]) if self.scene is not None else None
            self.moves.append(ObjectMove(t, d["object"], d["frame"], tuple(d["position"]), tuple(d["quaternion"]),
                                         tuple(o.size) if o is not None else (0.0, 0.0, 0.0)))
        else:
            self.events[topic].append((t, json.loads(data)))

    def build(self, complete: bool, stopped_at: str | None, summary_counts: dict[str, int]) -> RunLog:
        run: dict[str, Any] = {}
        for k, v in self.metadata.get("run", {}).items():
            try:
                run[k] = json.loads(v)
            except (json.JSONDecodeError, ValueError):
                run[k] = v
        return RunLog(
            path=self.path, metadata=self.metadata, run=run, scene=self.scene, grids=self.grids,
            actions=self.actions, contexts=self.contexts, events=dict(self.events), logs=self.logs,
            base=np.asarray(self.base, dtype=float).reshape(-1, 4), joint_names=self.joint_names,
            joints=(np.asarray(self.joints, dtype=float).reshape(len(self.joints), -1) if self.joints
                    else np.zeros((0, len(self.joint_names)))),
            joint_t=np.asarray(self.joint_t, dtype=float), presumed_paths=self.presumed,
            driven_paths=self.driven, counts=dict(self.counts), complete=complete,
            stopped_at=stopped_at, summary_counts=summary_counts,
            frames={k: FrameSeries(parent, np.asarray([r[0] for r in rows], dtype=float),
                                   np.asarray([r[1:4] for r in rows], dtype=float).reshape(-1, 3),
                                   np.asarray([r[4:8] for r in rows], dtype=float).reshape(-1, 4))
                    for k, (parent, rows) in sorted(self.tf.items())},
            object_moves=self.moves, robot_visuals=self.robot_visuals)


def _read_complete(path: Path, b: _Builder) -> dict[str, int]:
    """Indexed read; raises if the file has no valid footer/summary."""
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        if summary is None or summary.statistics is None:
            raise ValueError("no summary section")
        f.seek(-8, os.SEEK_END)
        if f.read(8) != MAGIC:
            raise ValueError("no trailing magic")
        for m in reader.iter_metadata():
            b.metadata_record(m)
        for a in reader.iter_attachments():
            b.attachment(a)
        for _schema, channel, msg in reader.iter_messages(log_time_order=False):
            b.message(channel.topic, msg)
        return {summary.channels[cid].topic: n
                for cid, n in summary.statistics.channel_message_counts.items()}


def _stream_records(data: bytes) -> Iterator[tuple[Any, int]]:
    bio = io.BytesIO(data)
    for rec in StreamReader(bio, emit_chunks=True, validate_crcs=False).records:
        yield rec, bio.tell()


def _read_stream(path: Path, b: _Builder) -> tuple[bool, str | None]:
    """Sequential read that stops at the first incomplete or corrupt record."""
    data = path.read_bytes()
    channels: dict[int, Channel] = {}
    n_chunks, good_offset, footer = 0, 0, False
    error = ""
    try:
        for rec, end in _stream_records(data):
            if isinstance(rec, Chunk):
                msgs = breakup_chunk(rec, validate_crc=True)  # whole chunk or nothing
                n_chunks += 1
                for r in msgs:
                    if isinstance(r, Channel):
                        channels[r.id] = r
                    elif isinstance(r, Message):
                        b.message(channels[r.channel_id].topic, r)
            elif isinstance(rec, Channel):
                channels[rec.id] = rec
            elif isinstance(rec, Message):
                b.message(channels[rec.channel_id].topic, rec)
            elif isinstance(rec, Metadata):
                b.metadata_record(rec)
            elif isinstance(rec, Attachment):
                b.attachment(rec)
            elif isinstance(rec, Footer):
                footer = True
            elif isinstance(rec, Schema):
                pass
            good_offset = end
    except RunLogFormatError:
        raise
    except Exception as e:  # noqa: BLE001 - any decoding failure ends the readable prefix
        error = f"{type(e).__name__}: {e}" if str(e) else type(e).__name__
    if footer and not error:
        return True, None
    if error and data.endswith(MAGIC):  # finished by its writer: damaged since, not cut short
        raise RunLogCorruptError(
            f"{path} is damaged at byte {good_offset} of {len(data)} ({error}): its writer finished it, so "
            f"this is not a killed run's truncation but a changed copy (a disk or transfer fault); restore "
            f"it from the DVC cache (`dvc checkout missions`) or rerun the missions stage (`dvc repro "
            f"--force missions`)")
    return False, (f"file ends after byte {good_offset} of {len(data)} ({n_chunks} complete chunks, "
                   f"{len(b.actions)} actions, last simulated t = {b.last_t:.3f} s); "
                   f"the rest is incomplete ({error or 'no footer'})")


def read_run(path: str | os.PathLike) -> RunLog:
    """Read one run's MCAP (``.mcap`` or a killed run's ``.mcap.partial``) into a RunLog."""
    path = Path(path)
    if not path.exists():
        partial = path.with_name(path.name + ".partial")
        hint = f"; a killed run left {partial}" if partial.exists() else ""
        raise MissingInputError(f"no MCAP run log at {path}{hint}")
    if not path.is_file():  # a FIFO, a device or a socket would block or never end
        raise RunLogFormatError(f"{path} is not a regular file (a folder, FIFO, device or socket); pass a .mcap "
                                f"file written by McapRecorder, or a folder of them")
    with open(path, "rb") as f:
        if f.read(8) != MAGIC:
            raise ValueError(f"{path} is not an MCAP file (bad magic); pass a .mcap written by McapRecorder")
    b = _Builder(path)
    try:
        counts = _read_complete(path, b)
        return b.build(True, None, counts)
    except RunLogFormatError as e:
        raise RunLogFormatError(f"{path}: {e}") from None
    except Exception:  # noqa: BLE001 - fall back to the streaming read below
        b = _Builder(path)
    try:
        complete, stopped_at = _read_stream(path, b)
    except RunLogFormatError as e:
        raise RunLogFormatError(f"{path}: {e}") from None
    return b.build(complete, stopped_at, {})
