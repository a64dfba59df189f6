"""Where the robot stands for each of the N_l trials of a manipulation (paper §IV-B: "5 free
locations around the sofa based on the occupancy grid map"), by ``sim.pose_protocol``:

``window``: N_l cells drawn *with* replacement from the
robot's map's free cells at most ``POSE_RING`` beyond the robot radius from the furniture's
footprint and at most ``LOCAL_WINDOW`` farther from the target than the closest such cell. The
window is so small that a pickup succeeds from all poses or from none, and moving between poses
costs nothing.

``reach`` (the paper's): N_l *distinct* cells drawn without replacement from the cells that are
free on the true grid *and* on the robot's map (for a ``sim.footprint_radius`` larger than the
map's radius: with the whole footprint clear of obstacles), whose centre lies within
``pose_radius`` [m] (horizontal) of the target — the arm's reach at the target's height plus
``sim.pose_margin`` — and that the robot can drive to from where it stands over such cells
without leaving the furniture's neighbourhood (so no pose strands the robot in a pocket: it came
by a path and can go back by it). The poses are visited in a nearest-neighbour tour from the
robot's position;
``BasePose.drive`` [m] is the path length on the robot's map from the previous pose, which the
trial's time includes. Where fewer than N_l cells qualify, the missing trials are failures
(``BasePose.free`` False: a cramped spot is a hard spot).

Both samplers are seeded with ``core.seeding.pose_sampling_seed(sim.seed, action)``; the yaw faces the target.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.sparse.csgraph import dijkstra

from interllm.config import POSE_PROTOCOLS, SimConfig
from interllm.core.actions import Action
from interllm.core.seeding import pose_sampling_seed
from interllm.planning.search import grid_csr
from interllm.scene.geometry import boxes_distance
from interllm.scene.graph import Furniture
from interllm.scene.grid import OccupancyGrid, clear_of_obstacles
from interllm.sim.physics import contact_radius
from interllm.sim.robot import (
    FOREARM,
    SHOULDER_FORWARD,
    SHOULDER_HEIGHT,
    UPPER_ARM,
    WRIST_TO_GRIP,
    robot_parts,
)

POSE_RING = 0.30  # [m] window protocol: poses at most this far beyond robot_radius from the footprint
LOCAL_WINDOW = 0.15  # [m] window protocol: at most this much farther from the target than the closest
PRE_GRASP_HEIGHT = 0.10  # [m] the pre-grasp pose above the target (sim/trials.py uses this one)
NEIGHBOURHOOD_MARGIN = 1.0  # [m] reach protocol: the drive between poses stays this close to the reach disc
__all__ = ["POSE_PROTOCOLS", "BasePose", "sample_base_poses", "window_poses", "reach_poses"]


@dataclass(frozen=True)
class BasePose:
    """One trial's base pose: x [m], y [m], yaw [rad] facing the target; ``drive`` [m] from the
    previous pose of the tour (0 in the window protocol); ``free`` False marks a trial for which
    no free cell was left (reach protocol)."""

    x: float
    y: float
    yaw: float
    drive: float = 0.0
    free: bool = True

    @property
    def pose(self) -> tuple[float, float, float]:
        return (self.x, self.y, self.yaw)


def _facing(x: float, y: float, target_xy, drive: float = 0.0, free: bool = True, cfg: SimConfig | None = None
            ) -> BasePose:
    return BasePose(x, y, facing_yaw(cfg, (x, y), target_xy), drive, free)


def facing_yaw(cfg: SimConfig | None, base_xy, target_xy) -> float:
    """[rad] the base yaw that turns the arm to the target: the generic robot faces it; a
    described robot puts it on its arm's line (heading and lateral offset of ``robot.Reach``)."""
    theta = math.atan2(target_xy[1] - base_xy[1], target_xy[0] - base_xy[0])
    parts = robot_parts(cfg.robot) if cfg is not None else None
    if parts is None or parts.reach is None:
        return theta
    r = math.hypot(target_xy[0] - base_xy[0], target_xy[1] - base_xy[1])
    side = math.asin(max(-1.0, min(1.0, parts.reach.lateral / r))) if r > 1e-9 else 0.0
    return math.remainder(theta - parts.heading - side, math.tau)


def sample_base_poses(cfg: SimConfig, presumed: OccupancyGrid, true: OccupancyGrid, furniture: Furniture,
                      target, *, robot_xy, action: Action, n: int) -> list[BasePose]:
    """``n`` base poses for ``action`` at ``furniture`` with the gripper target ``target`` (x, y, z) [m]
    and the robot at ``robot_xy`` [m], by ``cfg.pose_protocol`` (module doc); [] when the window
    protocol finds no free cell."""
    if cfg.pose_protocol == "window":
        return window_poses(presumed, furniture, target[:2], action, n, cfg)
    return reach_poses(presumed, true, target[:2], robot_xy, action=action, n=n, cfg=cfg,
                       radius=pose_radius(cfg, float(target[2])), min_radius=min_pose_radius(cfg))


def arm_reach(target_z: float, cfg: SimConfig | None = None) -> float:
    """[m] the farthest horizontal base-to-target distance from which the top-down pre-grasp of a
    target at height ``target_z`` [m] is reachable. Generic robot: within the arm's two links (the
    wrist, WRIST_TO_GRIP plus the pre-grasp height above the target, against UPPER_ARM + FOREARM from
    the shoulder). A described robot: its full extension where its lift brings the pre-grasp
    height within reach (``robot.Reach``); beyond that, an arm that tilts reaches
    sqrt(radius² − dz²), one that does not, 0."""
    reach = robot_parts(cfg.robot).reach if cfg is not None else None
    if reach is not None:
        z = target_z + PRE_GRASP_HEIGHT
        dz = max(reach.z_low - z, z - reach.z_high, 0.0)
        if not reach.tilts:
            return reach.radius if dz == 0.0 else 0.0
        return math.sqrt(max(reach.radius ** 2 - dz ** 2, 0.0))
    dz = target_z + PRE_GRASP_HEIGHT + WRIST_TO_GRIP - SHOULDER_HEIGHT
    links = UPPER_ARM + FOREARM
    return math.sqrt(max(links ** 2 - dz ** 2, 0.0)) + SHOULDER_FORWARD


def pose_radius(cfg: SimConfig, target_z: float) -> float:
    """[m] reach protocol: base centres this close to the target are candidates — the arm's reach at
    the target's height plus ``sim.pose_margin`` (poses a little beyond it: trials that may fail),
    at most ``sim.pose_reach``."""
    return min(arm_reach(target_z, cfg) + cfg.pose_margin, cfg.pose_reach)


def min_pose_radius(cfg: SimConfig) -> float:
    """[m] reach protocol: base centres closer to the target than this are no candidates — a
    described robot's grasp centre with the arm retracted, less ``sim.pose_margin`` (0: generic)."""
    reach = robot_parts(cfg.robot).reach
    if reach is None:
        return 0.0
    return max(0.0, reach.radius_min - cfg.pose_margin)


def window_poses(grid: OccupancyGrid, furniture: Furniture, target_xy, action: Action, n: int,
                 cfg: SimConfig) -> list[BasePose]:
    """The window protocol (module doc) on the robot's map ``grid``."""
    x0, y0, x1, y1 = furniture.footprint
    pad = cfg.robot_radius + POSE_RING + 2 * grid.resolution
    (r0, c0), (r1, c1) = _cell_window(grid, (x0 - pad, y0 - pad, x1 + pad, y1 + pad))
    if r0 >= r1 or c0 >= c1:
        return []
    cells = np.argwhere(grid.free[r0:r1, c0:c1]) + np.array([r0, c0])
    if len(cells) == 0:
        return []
    pts = grid.cell_to_world(cells)
    pts = pts[boxes_distance(pts, furniture.boxes) <= cfg.robot_radius + POSE_RING]
    if len(pts) == 0:
        return []
    dt = np.hypot(pts[:, 0] - target_xy[0], pts[:, 1] - target_xy[1])
    pts = pts[dt <= dt.min() + LOCAL_WINDOW + 1e-9]
    rng = np.random.default_rng(pose_sampling_seed(cfg.seed, action))
    idx = rng.choice(len(pts), size=n, replace=len(pts) < n)
    return [_facing(float(pts[k, 0]), float(pts[k, 1]), target_xy, cfg=cfg) for k in idx]


def _cell_window(grid: OccupancyGrid, box) -> tuple[tuple[int, int], tuple[int, int]]:
    """(row, col) bounds [lo, hi) of the cells covering a world box (x0, y0, x1, y1) [m], clipped."""
    lo = grid.world_to_cell(np.array([box[0], box[1]]))
    hi = grid.world_to_cell(np.array([box[2], box[3]]))
    return ((max(0, int(lo[0])), max(0, int(lo[1]))),
            (min(grid.shape[0], int(hi[0]) + 1), min(grid.shape[1], int(hi[1]) + 1)))


def reach_poses(presumed: OccupancyGrid, true: OccupancyGrid, target_xy, robot_xy, *, action: Action, n: int,
                cfg: SimConfig, radius: float, min_radius: float = 0.0) -> list[BasePose]:
    """The reach protocol (module doc) on the robot's map ``presumed`` and the ``true`` grid, from
    the robot at ``robot_xy`` [m], with base centres at most ``radius`` [m] from ``target_xy``;
    always ``n`` poses, the unfilled ones with ``free`` False."""
    tx, ty = float(target_xy[0]), float(target_xy[1])
    rx, ry = float(robot_xy[0]), float(robot_xy[1])
    m = radius + NEIGHBOURHOOD_MARGIN
    box = (min(tx - m, rx - 0.5), min(ty - m, ry - 0.5), max(tx + m, rx + 0.5), max(ty + m, ry + 0.5))
    (r0, c0), (r1, c1) = _cell_window(presumed, box)
    free = presumed.free[r0:r1, c0:c1] & true.free[r0:r1, c0:c1]  # where the robot may and can stand
    standable = clear_of_obstacles(free, contact_radius(cfg, presumed.resolution) - cfg.robot_radius,
                                   presumed.resolution)  # ... with its true footprint touching nothing
    rows, cols = free.shape
    graph = grid_csr(~free, presumed.resolution)
    start = _nearest_free(presumed, free, (r0, c0), (rx, ry))
    if start is None:
        return [_facing(rx, ry, target_xy, free=False, cfg=cfg) for _ in range(n)]
    dist = dijkstra(graph, directed=False, indices=start[0] * cols + start[1])
    rr, cc = np.mgrid[r0:r1, c0:c1]
    centres = presumed.cell_to_world(np.stack([rr, cc], -1))
    far = np.hypot(centres[..., 0] - tx, centres[..., 1] - ty)
    ok = standable & np.isfinite(dist.reshape(rows, cols)) & (far <= radius + 1e-9)
    if min_radius > 0:
        ok &= far >= min_radius
    cand = np.argwhere(ok)  # local (row, col), row-major: a stable order for the seeded draw
    rng = np.random.default_rng(pose_sampling_seed(cfg.seed, action))
    pick = cand[np.sort(rng.choice(len(cand), size=min(n, len(cand)), replace=False))] if len(cand) else cand
    tour = _nearest_neighbour_tour(graph, cols, start, pick)
    out = [_facing(float(centres[r, c, 0]), float(centres[r, c, 1]), target_xy, drive=d, cfg=cfg) for (r, c), d in tour]
    return out + [_facing(rx, ry, target_xy, free=False, cfg=cfg) for _ in range(n - len(out))]


def _nearest_free(grid: OccupancyGrid, free: np.ndarray, offset, xy) -> tuple[int, int] | None:
    """The free cell (local row, col) of a window nearest to ``xy`` [m], or None if none is free."""
    cells = np.argwhere(free)
    if len(cells) == 0:
        return None
    pts = grid.cell_to_world(cells + np.asarray(offset))
    d = np.round(np.hypot(pts[:, 0] - xy[0], pts[:, 1] - xy[1]), 9)
    k = int(np.lexsort((cells[:, 1], cells[:, 0], d))[0])
    return int(cells[k, 0]), int(cells[k, 1])


def _nearest_neighbour_tour(graph, cols: int, start: tuple[int, int], cells: np.ndarray):
    """Visit ``cells`` (local row, col) greedily nearest-first from ``start`` on the window's
    graph: [((row, col), drive [m] from the previous stop), ...]."""
    if len(cells) == 0:
        return []
    nodes = [start[0] * cols + start[1]] + [int(r) * cols + int(c) for r, c in cells]
    d = dijkstra(graph, directed=False, indices=nodes)[:, nodes]  # [1 + k, 1 + k] path lengths [m]
    left = list(range(1, len(nodes)))
    here, tour = 0, []
    while left:
        nxt = min(left, key=lambda j: (round(float(d[here, j]), 9), j))
        tour.append(((int(cells[nxt - 1][0]), int(cells[nxt - 1][1])), float(d[here, nxt])))
        left.remove(nxt)
        here = nxt
    return tour
