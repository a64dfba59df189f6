"""Scene, objects, grids and paths as Foxglove messages (the run log's /scene, /scene/objects,
/grid/<name> and /path/* channels); ``scene_boxes`` is shared with the rerun replay."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.Grid_pb2 import Grid
from foxglove_schemas_protobuf.PackedElementField_pb2 import PackedElementField
from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity
from foxglove_schemas_protobuf.SceneEntityDeletion_pb2 import SceneEntityDeletion
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

from interllm.core.frames import WORLD_FRAME, yaw_quat_xyzw
from interllm.record import wire
from interllm.scene.graph import SceneGraph
from interllm.scene.grid import OccupancyGrid

DOOR_HEIGHT = 2.0  # [m] drawn height of a door leaf
DOOR_LEAF_THICKNESS = 0.04  # [m]
OCCUPIED = 100  # grid cell value of an occupied cell (0 = free)


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


class ObjectsUpdates:
    """The /scene/objects SceneUpdates of one run: every object at its current (frame, position,
    quaternion); objects in a frame not in ``frames`` are left out (a held object without a robot
    model). Each update first deletes every entity of the topic, so that viewers (which keep
    entities by id) show exactly this state.

    A grasp or release moves one object, so each object's entity is serialized once per state
    and kept; an update is its deletion, then per object the entity's timestamp (field 1, the
    only part that changes) and the kept bytes: the same bytes as building the whole SceneUpdate
    through the generated classes (``tests/test_record_wire.py``)."""

    def __init__(self, objects: dict[str, Any], frames: set[str]) -> None:
        self._objects = objects
        self._frames = frames
        self._bodies: dict[str, tuple[tuple, bytes]] = {}  # object id -> (state, entity without timestamp)

    def message(self, state: dict[str, tuple[str, Sequence[float], Sequence[float]]], t_ns: int) -> bytes:
        """The serialized SceneUpdate of ``state`` (object id -> (frame, xyz, quat)) at ``t_ns`` [ns]."""
        head = SceneUpdate()
        d = head.deletions.add()
        d.timestamp.FromNanoseconds(t_ns)
        d.type = SceneEntityDeletion.Type.ALL
        stamp = wire.length_delimited(1, wire.timestamp(t_ns))  # SceneEntity.timestamp (1), present also when zero
        parts = [head.SerializeToString()]
        for oid in sorted(state):
            if state[oid][0] not in self._frames:
                continue
            entity = stamp + self._body(oid, state[oid])
            parts.append(wire.length_delimited(2, entity))  # SceneUpdate.entities (2)
        return b"".join(parts)

    def _body(self, oid: str, state: tuple) -> bytes:
        kept = self._bodies.get(oid)
        if kept is None or kept[0] != state:
            e = SceneEntity()
            _object_entity(e, self._objects[oid], *state)
            kept = self._bodies[oid] = (state, e.SerializeToString())
        return kept[1]


def scene_update(scene: SceneGraph, robot_visuals: Sequence[Any] = ()) -> SceneUpdate:
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


def path_poses(path: np.ndarray, t_ns: int) -> bytes:
    """A 2-D path [N, 2] [m] as a serialized foxglove.PosesInFrame: poses at z=0 heading along the
    path (each pose towards the next one, the last keeps the last heading; a single pose has yaw 0)."""
    path = np.asarray(path, dtype=float).reshape(-1, 2)
    n = len(path)
    yaw = np.zeros(n)
    if n > 1:
        d = np.diff(path, axis=0)
        yaw[:-1] = np.arctan2(d[:, 1], d[:, 0])
        yaw[-1] = yaw[-2]
    return wire.planar_poses_in_frame(t_ns, WORLD_FRAME, path, yaw)
