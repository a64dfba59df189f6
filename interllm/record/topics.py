"""The run log's contract: its topics, their JSON schemas and the JSON encoding of its messages.

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
- ``/joint_states``   interllm.JointStates (protobuf, ``JointStates`` below: action, base [x, y,
                      yaw], names, positions) per trajectory sample: the exact trajectory, every
                      double bit for bit (``read_run`` rebuilds Trajectory from it)
- ``/path/presumed``  foxglove.PosesInFrame at the action start (navigate actions): the exact
                      ``ActionResult.presumed_path``
- ``/path/driven``    foxglove.PosesInFrame at the action end (navigate actions), right before
                      its /actions record: the exact ``ActionResult.driven_path``
- ``/actions``        JSON: ActionResult.to_record(paths=False) + "context" + "index" + "n_samples" at the
                      action end; its JSON schema is ``ACTION_SCHEMA`` (full, strict)
- ``/results/command`` JSON at each command's end: its ``CommandRecord.to_dict()`` without the
                      actions, plus "n_actions": the command's actions are the next n_actions
                      /actions records (``read_run`` -> ``RunLog.command_records``)
- ``/log``            foxglove.Log
- any other topic given to ``event()`` (``/planner/candidates``, ``/llm/calls``, ...): a JSON
  channel with a permissive object schema, registered on first use.

JSON encoding: ``json.dumps(sort_keys=True)``; numpy scalars/arrays are converted; non-finite
floats are written as ``Infinity``/``NaN`` (Python's JSON dialect) so that they round-trip.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.Log_pb2 import Log
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

from interllm.core import jsonfmt
from interllm.core.frames import GRIP_FRAME, WORLD_FRAME

TF_TOPIC = "/tf"
SCENE_TOPIC = "/scene"
OBJECTS_TOPIC = "/scene/objects"
OBJECT_EVENTS_TOPIC = "/objects/events"
JOINT_TOPIC = "/joint_states"
PRESUMED_TOPIC = "/path/presumed"
DRIVEN_TOPIC = "/path/driven"
ACTIONS_TOPIC = "/actions"
COMMAND_RESULTS_TOPIC = "/results/command"
LOG_TOPIC = "/log"
GRID_PREFIX = "/grid/"
RESERVED_TOPICS = (TF_TOPIC, SCENE_TOPIC, OBJECTS_TOPIC, OBJECT_EVENTS_TOPIC, JOINT_TOPIC, PRESUMED_TOPIC, DRIVEN_TOPIC, ACTIONS_TOPIC,
                   LOG_TOPIC)

LOG_LEVELS = {"debug": Log.DEBUG, "info": Log.INFO, "warning": Log.WARNING, "warn": Log.WARNING,
              "error": Log.ERROR, "fatal": Log.FATAL}
LOG_LEVEL_NAMES = {Log.UNKNOWN: "unknown", Log.DEBUG: "debug", Log.INFO: "info",
                   Log.WARNING: "warning", Log.ERROR: "error", Log.FATAL: "fatal"}

_NUM = {"type": "number"}
ACTION_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "interllm.ActionResult",
    "description": "ActionResult.to_record(paths=False) of one executed action, with its planner context "
                   "(its paths are the /path/presumed and /path/driven messages before it).",
    "type": "object",
    "additionalProperties": False,
    "required": ["index", "n_samples", "context", "action", "kind", "success", "cost", "time",
                 "t_start", "collisions", "distance", "success_rate", "trials", "reason"],
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
    },
}


def _joint_states_type() -> type:
    """The ``interllm.JointStates`` protobuf message class, from a descriptor built here (the
    schema the run log carries, so viewers decode it without this package)::

        syntax = "proto3"; package interllm;
        message JointStates {
          uint32 action = 1;            // index of the action it belongs to
          repeated double base = 2;     // base pose x [m], y [m], yaw [rad]
          repeated string names = 3;    // arm joint names
          repeated double positions = 4;  // arm joint angles [rad], in the order of names
        }
    """
    fdp = descriptor_pb2.FileDescriptorProto(name="interllm/JointStates.proto", package="interllm", syntax="proto3")
    msg = fdp.message_type.add(name="JointStates")
    f = descriptor_pb2.FieldDescriptorProto
    for number, (name, kind, label) in enumerate((("action", f.TYPE_UINT32, f.LABEL_OPTIONAL),
                                                  ("base", f.TYPE_DOUBLE, f.LABEL_REPEATED),
                                                  ("names", f.TYPE_STRING, f.LABEL_REPEATED),
                                                  ("positions", f.TYPE_DOUBLE, f.LABEL_REPEATED)), start=1):
        msg.field.add(name=name, number=number, type=kind, label=label, json_name=name)
    pool = descriptor_pool.DescriptorPool()
    pool.Add(fdp)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName("interllm.JointStates"))


JointStates = _joint_states_type()
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


def json_default(o: Any) -> Any:
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
    return jsonfmt.message(obj, default=json_default)


def metadata_str(v: Any) -> str:
    return v if isinstance(v, str) else dumps(v)
