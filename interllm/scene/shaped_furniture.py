"""Furniture that is no box: L- and C-shaped counters as the rectangles they stand on.

ProcTHOR's counter assets name their shape and size (``procthor_db.counter_shape``):
``Countertop_L_10x4`` is an L whose bounding box is 10 by 4 feet, its arms 2 feet (0.61 m) deep;
``Countertop_C_8x6`` a C (a U) of 8 by 6 feet; ``I`` and ``Island`` pieces are boxes. An L is its
*back* arm along one side of the bounding box and a *side* arm along a perpendicular side; a C has
side arms on both ends. The floor in the inner corner is free: on the grid, in MuJoCo, for the
base poses and for the place-spot search (``Furniture.parts``).

Sides are named by the bounding box's edge they run along: "S" (y min), "N" (y max), "W" (x min),
"E" (x max). Units: metres.
"""

from __future__ import annotations

import math

from interllm.scene.geometry import r4
from interllm.scene.graph import Box2

SIDES = ("S", "N", "W", "E")
PERPENDICULAR = {"S": ("W", "E"), "N": ("W", "E"), "W": ("S", "N"), "E": ("S", "N")}
ARM_DEPTH = 2 * 0.3048  # [m] an L or C counter's arms are 2 ft deep (ProcTHOR's Countertop_I_*x2)


def strip(box: Box2, side: str, depth: float) -> Box2:
    """The strip of ``box`` (x0, y0, x1, y1) [m] along ``side``, ``depth`` [m] deep (at most the box)."""
    x0, y0, x1, y1 = box
    if side == "S":
        return x0, y0, x1, min(y1, y0 + depth)
    if side == "N":
        return x0, max(y0, y1 - depth), x1, y1
    if side == "W":
        return x0, y0, min(x1, x0 + depth), y1
    if side == "E":
        return max(x0, x1 - depth), y0, x1, y1
    raise ValueError(f"unknown side {side!r}; valid sides: {SIDES}")


def shaped_parts(shape: str, box: Box2, back: str, arm: str | None = None,
                 depth: float = ARM_DEPTH) -> tuple[Box2, ...]:
    """The rectangles of a counter of ``shape`` ("L", "C"; "I" and "Island" are boxes: ()) whose
    bounding box is ``box``: the back arm along ``back``, then the side arm(s): ``arm`` for an L (one of
    the two sides perpendicular to ``back``), both for a C. The side arms start where the back arm
    ends, so the parts do not overlap. Rounded to 1e-4 m; () when the arms would fill the box."""
    if shape not in ("L", "C"):
        return ()
    if back not in SIDES:
        raise ValueError(f"unknown back side {back!r}; valid sides: {SIDES}")
    arms = PERPENDICULAR[back] if shape == "C" else (arm,)
    if shape == "L" and arm not in PERPENDICULAR[back]:
        raise ValueError(f"an L's arm runs along a side perpendicular to its back {back!r}: one of "
                         f"{PERPENDICULAR[back]}, got {arm!r}")
    back_part = strip(box, back, depth)
    rest = _remainder(box, back, depth)
    if rest is None:
        return ()
    parts = [back_part] + [strip(rest, a, depth) for a in arms]
    # arms that together cover the rest of the box leave no inner floor: the piece is a box
    free = (rest[2] - rest[0]) * (rest[3] - rest[1]) - sum((p[2] - p[0]) * (p[3] - p[1]) for p in parts[1:])
    if free <= 1e-6:
        return ()
    return tuple(tuple(r4(v) for v in p) for p in parts)


def front_side(yaw_deg: float) -> str:
    """The bounding-box side a ProcTHOR asset faces at yaw ``yaw_deg`` (its ``rotation.y``): at 0 its
    front is ProcTHOR's +z, our +y ("N"); yaw turns +z towards +x (clockwise seen from above).
    Yaws are rounded to the nearest quarter turn."""
    quarter = int(round(float(yaw_deg) / 90.0)) % 4
    return ("N", "E", "S", "W")[quarter]


def opposite(side: str) -> str:
    return {"S": "N", "N": "S", "W": "E", "E": "W"}[side]


def wall_distance(box: Box2, side: str, room_bounds: Box2) -> float:
    """How far [m] the ``side`` edge of ``box`` is from the room's bounding box on that side."""
    x0, y0, x1, y1 = box
    rx0, ry0, rx1, ry1 = room_bounds
    return {"S": y0 - ry0, "N": ry1 - y1, "W": x0 - rx0, "E": rx1 - x1}[side]


def arm_towards_wall(box: Box2, back: str, room_bounds: Box2) -> str:
    """An L's side arm: of the two sides perpendicular to ``back``, the one nearer the room's wall (an L
    stands in a corner with both arms against walls); ties: the first of ``PERPENDICULAR[back]``."""
    a, b = PERPENDICULAR[back]
    da, db = wall_distance(box, a, room_bounds), wall_distance(box, b, room_bounds)
    return a if da <= db + 1e-9 else b


def _remainder(box: Box2, back: str, depth: float) -> Box2 | None:
    """``box`` less its back strip, or None when the strip takes it all."""
    x0, y0, x1, y1 = box
    rest = {"S": (x0, y0 + depth, x1, y1), "N": (x0, y0, x1, y1 - depth),
            "W": (x0 + depth, y0, x1, y1), "E": (x0, y0, x1 - depth, y1)}[back]
    if rest[2] - rest[0] <= 1e-6 or rest[3] - rest[1] <= 1e-6 or math.isnan(rest[0]):
        return None
    return rest
