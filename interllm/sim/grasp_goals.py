"""Where the gripper goes for a pickup or place, and whether the robot may try it.

A pickup grasps the object where it stands; a place releases the held object at the free spot of
the furniture's top surface nearest the robot (``place_spot``). Either way the gripper's target is
the object's centre, at least ``GRASP_MIN_HEIGHT`` above the surface, and the grip site must end
inside the object's box (``Goal``). ``why_the_state_forbids`` checks the robot's high-level state.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from interllm.core.actions import Action, State
from interllm.scene.graph import SceneGraph

GRASP_MIN_HEIGHT = 0.02  # [m] grasp point (gripper site) at least this high above the surface
PLACE_GAP = 0.02  # [m] clearance to other objects when placing


def place_spot(scene: SceneGraph, furniture_id: str, obj_size, near_xy, held: Optional[str]) -> Optional[np.ndarray]:
    """A free spot (x, y, z of the object's centre) [m] on a furniture's top surface, nearest to
    ``near_xy`` along the closest edge, inset so the object is fully on the surface and at
    least PLACE_GAP from every other object but ``held`` (on a furniture of several parts, wholly on
    one of them); None if there is no room."""
    f = scene.furniture[furniture_id]
    x0, y0, x1, y1 = f.footprint
    sx, sy, sz = (float(v) for v in obj_size)
    m = 0.03
    lox, hix = x0 + sx / 2 + m, x1 - sx / 2 - m
    loy, hiy = y0 + sy / 2 + m, y1 - sy / 2 - m
    if lox > hix or loy > hiy:
        return None
    others = [o for o in scene.objects_on(furniture_id) if o.id != held]
    base = np.array([np.clip(near_xy[0], lox, hix), np.clip(near_xy[1], loy, hiy)])
    # candidates: growing offsets along x and y from the nearest point, ordered by distance
    offs = np.arange(-1.0, 1.0001, 0.05)
    cand = np.array([[base[0] + dx, base[1] + dy] for dx in offs for dy in offs])
    cand = cand[(cand[:, 0] >= lox - 1e-9) & (cand[:, 0] <= hix + 1e-9) & (cand[:, 1] >= loy - 1e-9)
                & (cand[:, 1] <= hiy + 1e-9)]
    if f.parts:  # a furniture that is no box: the object must stand wholly on one part
        on = np.zeros(len(cand), dtype=bool)
        for px0, py0, px1, py1 in f.parts:
            on |= ((cand[:, 0] >= px0 + sx / 2 + m - 1e-9) & (cand[:, 0] <= px1 - sx / 2 - m + 1e-9)
                   & (cand[:, 1] >= py0 + sy / 2 + m - 1e-9) & (cand[:, 1] <= py1 - sy / 2 - m + 1e-9))
        cand = cand[on]
    d = np.hypot(cand[:, 0] - near_xy[0], cand[:, 1] - near_xy[1])
    for k in np.lexsort((cand[:, 1], cand[:, 0], np.round(d, 9))):
        cx, cy = cand[k]
        free = True
        for o in others:
            gx = abs(cx - o.position[0]) - (sx + o.size[0]) / 2
            gy = abs(cy - o.position[1]) - (sy + o.size[1]) / 2
            if gx < PLACE_GAP and gy < PLACE_GAP:
                free = False
                break
        if free:
            return np.array([round(float(cx), 6), round(float(cy), 6), round(f.surface_height + sz / 2, 6)])
    return None


@dataclass(frozen=True)
class Goal:
    """Where the gripper goes for a pickup or place: target [m], the box the grip site must end in,
    the object left out of the IK model (the held one), and the failure text."""

    target: np.ndarray
    inside: tuple[np.ndarray, np.ndarray]
    ik_exclude: tuple[str, ...]
    what_failed: str
    spot: Optional[np.ndarray] = None  # place: the object's centre on the surface [m]


def why_the_state_forbids(state: State, action: Action, holding: Optional[str]) -> str:
    """Why the robot's state does not allow ``action`` ("" when it does)."""
    if holding is None and state.holding is not None:
        return f"the hand is not free (holding {state.holding})"
    if holding is not None and state.holding != holding:
        return f"the robot is not holding {holding} (holding {state.holding or 'nothing'})"
    if state.at_furniture != action.furniture:
        return f"the robot is at {state.at_furniture}, not at {action.furniture}"
    return ""


def _unknown(scene: SceneGraph, action: Action) -> str:
    """Why ``action`` names something the scene does not have ("" when it names nothing unknown)."""
    if action.furniture not in scene.furniture:
        return f"unknown furniture {action.furniture!r}"
    if action.obj not in scene.objects:
        return f"unknown object {action.obj!r}"
    return ""


def _goal_at(scene: SceneGraph, action: Action, centre, exclude: tuple[str, ...], what_failed: str,
             spot=None) -> Goal:
    """The gripper's target for the object centred at ``centre`` [m] on the action's furniture (at
    least GRASP_MIN_HEIGHT above the surface) and the box the grip site must end in."""
    o, f = scene.objects[action.obj], scene.furniture[action.furniture]
    centre = np.asarray(centre, dtype=float)
    target = np.array([centre[0], centre[1], max(centre[2], f.surface_height + GRASP_MIN_HEIGHT)])
    half = np.asarray(o.size, dtype=float) / 2
    return Goal(target, (centre - half, centre + half + [0, 0, GRASP_MIN_HEIGHT]), exclude, what_failed, spot)


def pickup_goal(scene: SceneGraph, action: Action) -> Goal | str:
    """The grasp of ``action.obj`` where it stands, or why there is none."""
    why = _unknown(scene, action)
    if why:
        return why
    o = scene.objects[action.obj]
    if o.furniture != action.furniture:
        return f"{action.obj} is on {o.furniture}, not on {action.furniture}"
    if o.placement == "inside":
        return f"{action.obj} is inside {o.furniture}, which is closed: the robot does not open doors"
    return _goal_at(scene, action, o.position, (), "no collision-free grasp")


def place_goal(scene: SceneGraph, action: Action, robot_xy) -> Goal | str:
    """The release of the held ``action.obj`` at the free spot nearest ``robot_xy``, or why there is none."""
    why = _unknown(scene, action)
    if why:
        return why
    spot = place_spot(scene, action.furniture, scene.objects[action.obj].size, robot_xy, action.obj)
    if spot is None:
        return f"no free spot for {action.obj} on {action.furniture}"
    return _goal_at(scene, action, spot, (action.obj,), "no collision-free placing pose", spot)
