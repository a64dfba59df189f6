"""Plane geometry of scene records: rounding for byte-stable JSON, rectangle gaps and overlaps,
distances to footprints, the free sides of a furniture. Units are metres."""

from __future__ import annotations

import math

import numpy as np

from interllm.scene.graph import Furniture, SceneGraph


def r4(v: float) -> float:
    """Round to 1e-4 (and turn -0.0 into 0.0) for byte-stable JSON."""
    return round(float(v), 4) + 0.0


def rect_gap(a, b) -> float:
    """Euclidean distance between two axis-aligned rectangles (x0, y0, x1, y1) [m]; 0 if touching."""
    dx = max(a[0] - b[2], b[0] - a[2], 0.0)
    dy = max(a[1] - b[3], b[1] - a[3], 0.0)
    return math.hypot(dx, dy)


def rects_overlap(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def point_in_polygon(poly, x: float, y: float) -> bool:
    """True when (x, y) [m] lies inside the polygon [(x, y), ...] (even-odd rule)."""
    inside = False
    n = len(poly)
    for i in range(n):
        (ax, ay), (bx, by) = poly[i], poly[(i + 1) % n]
        if (ay > y) != (by > y) and x < ax + (y - ay) * (bx - ax) / (by - ay):
            inside = not inside
    return inside


def free_edges(scene_or_interior, furniture: Furniture, wall_tol: float = 0.3) -> tuple[str, ...]:
    """Sides ("S", "N", "W", "E") of a furniture footprint that face free floor, not a wall.

    scene_or_interior: a SceneGraph (room bounds are used) or the room interior (x0, y0, x1, y1).
    A side closer than ``wall_tol`` [m] to the room boundary is against the wall.
    """
    if isinstance(scene_or_interior, SceneGraph):
        b = scene_or_interior.rooms[furniture.room].bounds
    else:
        b = scene_or_interior
    x0, y0, x1, y1 = furniture.footprint
    out = []
    if y0 - b[1] > wall_tol:
        out.append("S")
    if b[3] - y1 > wall_tol:
        out.append("N")
    if x0 - b[0] > wall_tol:
        out.append("W")
    if b[2] - x1 > wall_tol:
        out.append("E")
    return tuple(out)


def edge_distances(furniture: Furniture, x: float, y: float) -> dict[str, float]:
    """Distance [m] from a point on the surface to each side of the footprint."""
    x0, y0, x1, y1 = furniture.footprint
    return {"S": y - y0, "N": y1 - y, "W": x - x0, "E": x1 - x}


# ---- floor plan ----------------------------------------------------------------------------------


def boxes_distance(xy: np.ndarray, boxes) -> np.ndarray:
    """Distance [m] from points (..., 2) to the nearest of the rectangles ``boxes`` (0 inside one), e.g.
    ``Furniture.boxes``."""
    out = footprint_distance(xy, boxes[0])
    for b in boxes[1:]:
        out = np.minimum(out, footprint_distance(xy, b))
    return out


def footprint_distance(xy: np.ndarray, fp: tuple[float, float, float, float]) -> np.ndarray:
    """Distance [m] from points (..., 2) to an axis-aligned rectangle (x0, y0, x1, y1) (0 inside)."""
    x0, y0, x1, y1 = fp
    dx = np.maximum(np.maximum(x0 - xy[..., 0], 0.0), xy[..., 0] - x1)
    dy = np.maximum(np.maximum(y0 - xy[..., 1], 0.0), xy[..., 1] - y1)
    return np.hypot(dx, dy)
