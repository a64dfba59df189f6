"""MuJoCo world built from a SceneGraph with ``mujoco.MjSpec``.

Names (geoms; bodies and joints where they exist):
- ``floor``
- ``wall/<id>``: one box per wall segment, ``thickness`` x ``height``
- ``door/<id>``: the door leaf, a thin box along ``Door.leaf_segment()``, only for doors that are
  not fully open (the presumed map does not know about these)
- ``furniture/<id>``: body + one solid box from the floor to the top surface (the footprint)
- ``object/<id>``: body with a free joint and a box geom of the object's size, resting on its
  furniture (box bottom = surface height)
- ``robot/...``: the mobile manipulator of ``robot.py`` (only with ``robot=True``)

``build_world_spec(scene, robot=False).to_xml()`` is the scene-only ``scene.xml`` the scenes
stage saves; it loads with ``mujoco.MjModel.from_xml_string`` and opens in
``python -m mujoco.viewer``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Optional

import mujoco

from interllm.config import SimConfig
from interllm.core.frames import yaw_quat_wxyz
from interllm.scene.graph import Furniture, SceneGraph, SceneObject
from interllm.sim.robot import (
    CA_OBJECT,
    CA_STATIC,
    CT_OBJECT,
    CT_STATIC,
    add_robot,
    add_robot_assets,
)

_BOX = mujoco.mjtGeom.mjGEOM_BOX
DOOR_LEAF_THICKNESS = 0.04  # [m]
DOOR_LEAF_HEIGHT = 2.0  # [m]
OBJECT_DENSITY = 300.0  # [kg/m^3]

_FURNITURE_RGBA = (0.55, 0.4, 0.25, 1.0)
_WALL_RGBA = (0.85, 0.85, 0.8, 1.0)
_DOOR_RGBA = (0.45, 0.25, 0.1, 1.0)
_OBJECT_RGBA = (0.2, 0.5, 0.85, 1.0)


ARENA_BYTES = 32 * 1024 * 1024  # [bytes] MjData arena of the house model (mjData.narena) ...
ARENA_BYTES_PER_BODY = 32 * 1024  # [bytes] ... plus this per body


def _static(body, name: str, size, pos, quat=(1.0, 0.0, 0.0, 0.0), rgba=(0.7, 0.7, 0.7, 1.0)):
    return body.add_geom(name=name, type=_BOX, size=list(size), pos=list(pos), quat=list(quat),
                         rgba=list(rgba), contype=CT_STATIC, conaffinity=CA_STATIC)


def add_segment_box(body, name: str, a, b, thickness: float, height: float, rgba) -> None:
    """A box standing on the floor along the segment a-b (x, y) [m], extended by thickness/2 at
    both ends so that wall corners close."""
    (ax, ay), (bx, by) = a, b
    length = math.hypot(bx - ax, by - ay)
    yaw = math.atan2(by - ay, bx - ax)
    _static(body, name, (length / 2 + thickness / 2, thickness / 2, height / 2),
            ((ax + bx) / 2, (ay + by) / 2, height / 2), yaw_quat_wxyz(yaw), rgba)


def add_furniture(body, f: Furniture) -> None:
    """A furniture's body: one box geom ``furniture/<id>`` of its footprint, or one per part of a
    furniture that is no box (``furniture/<id>``, ``furniture/<id>/part1``, ...), each its full height."""
    fb = body.add_body(name=f"furniture/{f.id}", pos=[f.center[0], f.center[1], 0.0])
    if not f.parts:
        _static(fb, f"furniture/{f.id}", (f.size[0] / 2, f.size[1] / 2, f.size[2] / 2), (0, 0, f.size[2] / 2),
                rgba=_FURNITURE_RGBA)
        return
    for k, (x0, y0, x1, y1) in enumerate(f.parts):
        _static(fb, f"furniture/{f.id}" + (f"/part{k}" if k else ""), ((x1 - x0) / 2, (y1 - y0) / 2, f.size[2] / 2),
                ((x0 + x1) / 2 - f.center[0], (y0 + y1) / 2 - f.center[1], f.size[2] / 2), rgba=_FURNITURE_RGBA)


def add_object(body, o: SceneObject, free: bool = True) -> None:
    """An object box at its scene position; ``free=False`` makes it static (IK models)."""
    ob = body.add_body(name=f"object/{o.id}", pos=list(o.position))
    if free:
        ob.add_freejoint(name=f"object/{o.id}")
    sx, sy, sz = (max(v, 0.005) / 2 for v in o.size)
    ob.add_geom(name=f"object/{o.id}", type=_BOX, size=[sx, sy, sz], rgba=list(_OBJECT_RGBA),
                contype=CT_OBJECT, conaffinity=CA_OBJECT, density=OBJECT_DENSITY,
                friction=[1.0, 0.01, 0.001])


def new_spec(name: str) -> mujoco.MjSpec:
    spec = mujoco.MjSpec()
    spec.modelname = name
    spec.option.timestep = 0.002
    spec.compiler.degree = False
    spec.worldbody.add_light(name="sun", pos=[0, 0, 10], dir=[0.3, 0.2, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
                             diffuse=[0.8, 0.8, 0.8])
    add_robot_assets(spec)
    return spec


def build_world_spec(scene: SceneGraph, robot: bool = True, sim_cfg: Optional[SimConfig] = None) -> mujoco.MjSpec:
    """The whole house as an MjSpec (compile with ``spec.compile()``).

    robot: include the mobile manipulator (base joints first: qpos[0:3] = x, y, yaw).
    sim_cfg: robot dimensions (``robot_radius``); defaults to ``SimConfig()``.
    """
    if not scene.rooms:
        raise ValueError(f"scene {scene.id!r} has no rooms; a world needs at least one room")
    spec = new_spec(f"interllm_{scene.id}")
    wb = spec.worldbody
    x0, y0, x1, y1 = scene.bounds
    wb.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE,
                size=[(x1 - x0) / 2 + 1.0, (y1 - y0) / 2 + 1.0, 0.1], pos=[(x0 + x1) / 2, (y0 + y1) / 2, 0],
                rgba=[0.75, 0.72, 0.65, 1], contype=CT_STATIC, conaffinity=CA_STATIC)
    for w in sorted(scene.walls.values(), key=lambda w: w.id):
        add_segment_box(wb, f"wall/{w.id}", w.start, w.end, w.thickness, w.height, _WALL_RGBA)
    for d in sorted(scene.doors.values(), key=lambda d: d.id):
        seg = d.leaf_segment()
        if seg is None:
            continue
        add_segment_box(wb, f"door/{d.id}", seg[0], seg[1], DOOR_LEAF_THICKNESS, DOOR_LEAF_HEIGHT, _DOOR_RGBA)
    for f in sorted(scene.furniture.values(), key=lambda f: f.id):
        add_furniture(wb, f)
    if robot:  # before the objects, so that qpos[0:3] is the base pose
        add_robot(wb, sim_cfg, mobile=True)
    for o in sorted(scene.objects.values(), key=lambda o: o.id):
        add_object(wb, o, free=True)
    # MuJoCo sizes its arena by a heuristic that grows with the square of the bodies (6.4 GB for the
    # huge house, and more than it can allocate for 300 rooms); the experiment only places bodies and
    # asks for the base's contacts, so a size linear in the bodies is plenty
    spec.memory = ARENA_BYTES + ARENA_BYTES_PER_BODY * len(spec.bodies)
    return spec


def _box_near(box, footprint, margin: float) -> bool:
    """Whether an axis-aligned box (x0, y0, x1, y1) [m] comes within ``margin`` of a footprint."""
    x0, y0, x1, y1 = footprint
    return box[0] <= x1 + margin and box[2] >= x0 - margin and box[1] <= y1 + margin and box[3] >= y0 - margin


def _segment_box(a, b, thickness: float) -> tuple[float, float, float, float]:
    h = thickness / 2
    return (min(a[0], b[0]) - h, min(a[1], b[1]) - h, max(a[0], b[0]) + h, max(a[1], b[1]) + h)


def local_furniture(scene: SceneGraph, furniture_id: str, neighbourhood: float) -> list[str]:
    """The furniture of a manipulation's IK model: the target and, with ``neighbourhood`` > 0 [m],
    every furniture whose footprint comes that close to it (sorted ids, the target first)."""
    f = scene.furniture[furniture_id]
    near = [g.id for g in sorted(scene.furniture.values(), key=lambda g: g.id)
            if g.id != furniture_id and neighbourhood > 0 and _box_near(g.footprint, f.footprint, neighbourhood)]
    return [furniture_id] + near


def build_local_spec(scene: SceneGraph, furniture_id: str, sim_cfg: Optional[SimConfig] = None,
                     exclude_objects: Iterable[str] = (), neighbourhood: float = 0.0) -> mujoco.MjSpec:
    """A small model for manipulation IK: a fixed-base robot (six arm joints only), one
    furniture and the objects on it (static). With ``neighbourhood`` > 0 [m] also everything the
    arm could touch from a base pose near the furniture: the walls and door leaves (as they
    really are) and the other furniture, with their objects, within that distance of its
    footprint. The base pose is set at run time through ``model.body_pos`` / ``model.body_quat``
    of body ``robot/base``."""
    if furniture_id not in scene.furniture:
        raise KeyError(f"unknown furniture {furniture_id!r}; valid: {sorted(scene.furniture)[:20]}")
    spec = new_spec(f"local_{furniture_id}")
    wb = spec.worldbody
    fp = scene.furniture[furniture_id].footprint
    if neighbourhood > 0:
        for w in sorted(scene.walls.values(), key=lambda w: w.id):
            if _box_near(_segment_box(w.start, w.end, w.thickness), fp, neighbourhood):
                add_segment_box(wb, f"wall/{w.id}", w.start, w.end, w.thickness, w.height, _WALL_RGBA)
        for d in sorted(scene.doors.values(), key=lambda d: d.id):
            seg = d.leaf_segment()
            if seg is not None and _box_near(_segment_box(seg[0], seg[1], DOOR_LEAF_THICKNESS), fp, neighbourhood):
                add_segment_box(wb, f"door/{d.id}", seg[0], seg[1], DOOR_LEAF_THICKNESS, DOOR_LEAF_HEIGHT, _DOOR_RGBA)
    skip = set(exclude_objects)
    for fid in local_furniture(scene, furniture_id, neighbourhood):
        add_furniture(wb, scene.furniture[fid])
        for o in sorted(scene.objects_on(fid), key=lambda o: o.id):
            if o.id not in skip:
                add_object(wb, o, free=False)
    add_robot(wb, sim_cfg, mobile=False)
    return spec
