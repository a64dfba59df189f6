"""Occupancy grid graph G^o: free/occupied cells from walls, door leaves and furniture footprints.

Two maps per scene (paper §III, §IV-B):
- ``presumed``: what the planner believes; every door is open.
- ``true``: door leaves as they are; partly closed or narrow doors block the way.
Both are inflated by the robot radius, so a free cell is a cell the base centre may occupy.

Cell (i, j) = (row, col) covers x in [ox + j*res, ox + (j+1)*res), y in [oy + i*res, ...).
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from interllm.scene.graph import SceneGraph


@dataclass
class OccupancyGrid:
    occupied: np.ndarray  # bool [rows, cols]; True = base centre may not be there
    resolution: float  # [m] per cell
    origin: tuple[float, float]  # world (x, y) of cell (0, 0)'s corner [m]

    @property
    def shape(self) -> tuple[int, int]:
        return self.occupied.shape  # type: ignore[return-value]

    @property
    def free(self) -> np.ndarray:
        return ~self.occupied

    def world_to_cell(self, xy) -> np.ndarray:
        """World points [m] (..., 2) -> integer cells (..., 2) as (row, col)."""
        xy = np.asarray(xy, dtype=float)
        col = np.floor((xy[..., 0] - self.origin[0]) / self.resolution).astype(int)
        row = np.floor((xy[..., 1] - self.origin[1]) / self.resolution).astype(int)
        return np.stack([row, col], axis=-1)

    def cell_to_world(self, rc) -> np.ndarray:
        """Cells (..., 2) as (row, col) -> world (x, y) of the cell centres [m]."""
        rc = np.asarray(rc)
        x = self.origin[0] + (rc[..., 1] + 0.5) * self.resolution
        y = self.origin[1] + (rc[..., 0] + 0.5) * self.resolution
        return np.stack([x, y], axis=-1)

    def in_bounds(self, rc) -> bool:
        r, c = int(rc[0]), int(rc[1])
        return 0 <= r < self.shape[0] and 0 <= c < self.shape[1]

    def is_free(self, rc) -> bool:
        return self.in_bounds(rc) and not bool(self.occupied[int(rc[0]), int(rc[1])])

    def copy(self) -> OccupancyGrid:
        return OccupancyGrid(self.occupied.copy(), self.resolution, self.origin)

    def to_npz_bytes(self, **extra: np.ndarray) -> bytes:
        buf = io.BytesIO()
        np.savez_compressed(buf, occupied=self.occupied, resolution=np.array(self.resolution),
                            origin=np.array(self.origin), **extra)
        return buf.getvalue()

    @staticmethod
    def pair_npz_bytes(presumed: OccupancyGrid, true: OccupancyGrid, robot_radius: float) -> bytes:
        """``grid.npz`` of the scenes stage: the presumed grid, the true grid's cells, the robot
        radius [m] both are inflated by."""
        return presumed.to_npz_bytes(true_occupied=true.occupied, robot_radius=np.array(float(robot_radius)))

    @staticmethod
    def load_pair(path, resolution: float, robot_radius: float) -> dict[str, OccupancyGrid]:
        """{"presumed", "true"} from a ``grid.npz``; raises ``ValueError`` naming the fix when it was
        made with another resolution or robot radius (the scenes stage must run again)."""
        with np.load(path) as z:
            res, origin = float(z["resolution"]), (float(z["origin"][0]), float(z["origin"][1]))
            radius = float(z["robot_radius"]) if "robot_radius" in z.files else float("nan")
            presumed = OccupancyGrid(z["occupied"].astype(bool), res, origin)
            true = OccupancyGrid(z["true_occupied"].astype(bool), res, origin)
        if res != float(resolution) or radius != float(robot_radius):
            raise ValueError(f"{path} was made with grid resolution {res} m and robot radius {radius} m, not "
                             f"scene.grid_resolution={resolution} and sim.robot_radius={robot_radius}; rerun the "
                             f"scenes stage (dvc repro scenes)")
        return {"presumed": presumed, "true": true}


def _fill_box(occ: np.ndarray, origin: tuple[float, float], res: float, box: tuple[float, float, float, float]
              ) -> None:
    """Set the cells of ``occ`` (grid origin [m], ``res`` [m/cell]) that the rectangle ``box``
    (x0, y0, x1, y1) [m] touches."""
    x0, y0, x1, y1 = box
    c0 = int(np.floor((x0 - origin[0]) / res))
    c1 = int(np.ceil((x1 - origin[0]) / res))
    r0 = int(np.floor((y0 - origin[1]) / res))
    r1 = int(np.ceil((y1 - origin[1]) / res))
    occ[max(r0, 0):max(r1, 0), max(c0, 0):max(c1, 0)] = True


def rasterize(scene: SceneGraph, resolution: float = 0.05, robot_radius: float = 0.25,
              doors: str = "presumed", inflate: bool = True) -> OccupancyGrid:
    """Occupancy grid of a scene.

    doors: "presumed" (all doors open) or "true" (door leaves as they are).
    inflate: grow obstacles by ``robot_radius`` (configuration space of the base centre).
    """
    if doors not in ("presumed", "true"):
        raise ValueError(f"doors must be 'presumed' or 'true', got {doors!r}")
    x0, y0, x1, y1 = scene.bounds
    margin = 0.5
    origin = (round(x0 - margin, 6), round(y0 - margin, 6))
    cols = int(np.ceil((x1 - x0 + 2 * margin) / resolution))
    rows = int(np.ceil((y1 - y0 + 2 * margin) / resolution))
    occ = np.zeros((rows, cols), dtype=bool)

    # Outside every room is occupied.
    inside = np.zeros_like(occ)
    for r in scene.rooms.values():
        _fill_box(inside, origin, resolution, r.bounds)
    occ |= ~inside
    for w in scene.walls.values():
        t = w.thickness / 2
        _fill_box(occ, origin, resolution, (min(w.start[0], w.end[0]) - t, min(w.start[1], w.end[1]) - t,
                                            max(w.start[0], w.end[0]) + t, max(w.start[1], w.end[1]) + t))
    for f in scene.furniture.values():
        for box in f.boxes:
            _fill_box(occ, origin, resolution, box)
    if doors == "true":
        for d in scene.doors.values():
            seg = d.leaf_segment()
            if seg is None:
                continue
            (ax, ay), (bx, by) = seg
            t = 0.03
            _fill_box(occ, origin, resolution,
                      (min(ax, bx) - t, min(ay, by) - t, max(ax, bx) + t, max(ay, by) + t))
    if inflate and robot_radius > 0:
        rad = int(np.ceil(robot_radius / resolution))
        yy, xx = np.mgrid[-rad:rad + 1, -rad:rad + 1]
        disk = (xx * xx + yy * yy) <= rad * rad
        occ = ndimage.binary_dilation(occ, structure=disk)
    return OccupancyGrid(occupied=occ, resolution=resolution, origin=origin)


def clear_of_obstacles(free: np.ndarray, extra: float, resolution: float) -> np.ndarray:
    """Free cells whose neighbours within ``extra`` [m] are all free too (``free`` eroded by a disc):
    where a footprint ``extra`` larger than the grid's inflation radius touches nothing. Cells
    beyond the array's border count as free (pass a window larger than the disc)."""
    rad = int(np.ceil(extra / resolution - 1e-9))
    if rad <= 0:
        return free.copy()
    yy, xx = np.mgrid[-rad:rad + 1, -rad:rad + 1]
    return ndimage.binary_erosion(free, structure=(xx * xx + yy * yy) <= rad * rad, border_value=1)


# ---- reachability helpers (added by the scene subpackage) ----------------------------------------
def free_components(grid: OccupancyGrid, connectivity: int = 4) -> tuple[np.ndarray, int]:
    """Label connected free regions: (labels int [rows, cols], 0 = occupied; n_labels).

    connectivity: 4 (edge neighbours; conservative) or 8 (also diagonal neighbours).
    """
    if connectivity not in (4, 8):
        raise ValueError(f"connectivity must be 4 or 8, got {connectivity!r}")
    structure = ndimage.generate_binary_structure(2, 1 if connectivity == 4 else 2)
    labels, n = ndimage.label(grid.free, structure=structure)
    return labels, int(n)


def largest_component(labels: np.ndarray) -> int:
    """Label of the largest free region (0 if there is no free cell)."""
    counts = np.bincount(labels.ravel())
    if counts.size <= 1:
        return 0
    counts[0] = 0
    return int(np.argmax(counts))


def approach_cells(grid: OccupancyGrid, footprint: tuple[float, float, float, float],
                   reach: float) -> np.ndarray:
    """Free cells (k, 2) as (row, col) whose centres lie within ``reach`` [m] of a rectangle.

    footprint: (x0, y0, x1, y1) [m], e.g. ``Furniture.footprint``. With an inflated grid the free
    cells near a furniture are at least the robot radius away, so ``reach`` should be the robot
    radius plus the arm's reach margin (e.g. 0.25 + 0.35 m).
    """
    x0, y0, x1, y1 = footprint
    lo = grid.world_to_cell((x0 - reach, y0 - reach))
    hi = grid.world_to_cell((x1 + reach, y1 + reach))
    r0, c0 = max(int(lo[0]), 0), max(int(lo[1]), 0)
    r1, c1 = min(int(hi[0]) + 1, grid.shape[0]), min(int(hi[1]) + 1, grid.shape[1])
    if r0 >= r1 or c0 >= c1:
        return np.zeros((0, 2), dtype=int)
    rr, cc = np.mgrid[r0:r1, c0:c1]
    xs = grid.origin[0] + (cc + 0.5) * grid.resolution
    ys = grid.origin[1] + (rr + 0.5) * grid.resolution
    dx = np.maximum(np.maximum(x0 - xs, xs - x1), 0.0)
    dy = np.maximum(np.maximum(y0 - ys, ys - y1), 0.0)
    ok = (np.hypot(dx, dy) <= reach) & grid.free[r0:r1, c0:c1]
    return np.stack([rr[ok], cc[ok]], axis=-1)


def approach_cells_of(grid: OccupancyGrid, boxes, reach: float) -> np.ndarray:
    """``approach_cells`` of a furniture of several rectangles (``Furniture.boxes``): the free cells
    within ``reach`` [m] of any of them, (row, col) sorted like ``approach_cells``'s."""
    if len(boxes) == 1:
        return approach_cells(grid, boxes[0], reach)
    cells = np.concatenate([approach_cells(grid, b, reach) for b in boxes])
    return np.unique(cells, axis=0) if len(cells) else cells
