"""Frame names of the run log (/tf, /scene, /objects/events) and of replay, and quaternions.

Two quaternion orders meet here: MuJoCo's (w, x, y, z) and the (x, y, z, w) of Foxglove, rerun
and the run log. Every helper says which one it returns in its name.
"""

from __future__ import annotations

import math

WORLD_FRAME = "world"
BASE_FRAME = "base_link"  # the mobile base; world->base_link is the base pose
GRIP_FRAME = "grip"  # the gripper site, end of the arm chain; a held object's frame


def yaw_quat_wxyz(yaw: float) -> list[float]:
    """MuJoCo-order quaternion (w, x, y, z) of a rotation by ``yaw`` [rad] about +z."""
    return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]


def yaw_quat_xyzw(yaw: float) -> tuple[float, float, float, float]:
    """Foxglove/rerun-order quaternion (x, y, z, w) of a rotation by ``yaw`` [rad] about +z."""
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def wxyz_to_xyzw(q) -> tuple[float, float, float, float]:
    """MuJoCo's (w, x, y, z) quaternion in the (x, y, z, w) order of Foxglove, rerun and the run log."""
    return (float(q[1]), float(q[2]), float(q[3]), float(q[0]))
