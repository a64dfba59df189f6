"""Fast shortest paths on an occupancy grid (the paper's A* on G^o, §IV-B).

8-connected grid, octile step costs: an axis move costs ``resolution`` [m], a diagonal move
``sqrt(2) * resolution`` [m]. A diagonal move is allowed only when both axis-neighbours it cuts
past are free (no corner cutting through an obstacle's corner).

Instead of one A* per query, ``GridSearch`` computes a *distance field* per goal (or goal region,
a set of cells of which any one will do) with ``scipy.sparse.csgraph.dijkstra`` once, caches it,
and answers every later query to the same goal from any start by following the predecessor
tree. Because the grid graph is undirected, the field is exactly the shortest-path cost from
every free cell to the nearest goal cell, so the returned path is optimal (same cost as A* with
an admissible heuristic).

Snapping: a start or goal on an occupied cell (or outside the grid) is snapped to the nearest
free cell; a start that cannot reach the goal from its own cell is snapped to the nearest cell
(within ``snap_radius``) that can. ``GridSearch.last_snap`` tells what happened on the last query.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass
from typing import Optional

import numpy as np
from scipy import ndimage
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from interllm.scene.grid import OccupancyGrid

SQRT2 = float(np.sqrt(2.0))
# (drow, dcol, cost in cells); axis moves first
_MOVES = ((0, 1, 1.0), (1, 0, 1.0), (1, 1, SQRT2), (1, -1, SQRT2))


@dataclass
class SnapInfo:
    """What the last query did with its endpoints."""

    start_snapped: bool = False
    goal_snapped: bool = False
    start_cell: tuple[int, int] = (0, 0)
    goal_cells: int = 0  # free goal cells actually used


@dataclass
class DistanceField:
    """Shortest-path cost [m] from every cell to the nearest goal cell, and the next cell."""

    dist: np.ndarray  # float [rows*cols]; inf = unreachable or occupied
    pred: np.ndarray  # int32 [rows*cols]; next node towards the goal, -9999 at goal / unreachable
    goal_nodes: np.ndarray  # int [K] flat indices of the goal cells


def path_length(path: Optional[np.ndarray]) -> float:
    """Sum of segment lengths of a polyline [N, 2] in metres (0 for None or < 2 points)."""
    if path is None:
        return 0.0
    p = np.asarray(path, dtype=float)
    if len(p) < 2:
        return 0.0
    return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))


def clearance_factor(occupied: np.ndarray, resolution: float, cost: float, band: float) -> np.ndarray:
    """Per-cell cost factor >= 1: ``1 + cost * max(0, 1 - d / band)``, d [m] the distance from a
    free cell's centre to the nearest occupied cell's centre (the clearance beyond the map's
    inflation). Shortest paths then keep to the middle of a passage where they can."""
    free = ~occupied
    if cost <= 0 or not free.any() or not occupied.any():
        return np.ones(occupied.shape)
    d = ndimage.distance_transform_edt(free) * resolution
    return 1.0 + cost * np.clip(1.0 - d / band, 0.0, 1.0)


def grid_csr(occupied: np.ndarray, resolution: float, clearance_cost: float = 0.0,
             clearance_band: float = 0.2) -> csr_matrix:
    """Sparse symmetric adjacency of the free cells: 8-connected, octile costs [m], each edge
    scaled by the mean ``clearance_factor`` of its two cells (1 everywhere when the cost is 0)."""
    rows, cols = occupied.shape
    free = ~occupied
    factor = clearance_factor(occupied, resolution, clearance_cost, clearance_band)
    idx = np.arange(rows * cols).reshape(rows, cols)
    src_l, dst_l, w_l = [], [], []
    for dr, dc, c in _MOVES:
        r0, r1 = max(0, -dr), rows - max(0, dr)
        c0, c1 = max(0, -dc), cols - max(0, dc)
        a = free[r0:r1, c0:c1]
        b = free[r0 + dr:r1 + dr, c0 + dc:c1 + dc]
        ok = a & b
        if dr and dc:  # no corner cutting: both axis-neighbours free
            ok &= free[r0 + dr:r1 + dr, c0:c1] & free[r0:r1, c0 + dc:c1 + dc]
        s = idx[r0:r1, c0:c1][ok]
        d = idx[r0 + dr:r1 + dr, c0 + dc:c1 + dc][ok]
        w = c * resolution * 0.5 * (factor[r0:r1, c0:c1][ok] + factor[r0 + dr:r1 + dr, c0 + dc:c1 + dc][ok])
        src_l += [s, d]
        dst_l += [d, s]
        w_l += [w, w]
    src = np.concatenate(src_l)
    dst = np.concatenate(dst_l)
    w = np.concatenate(w_l)
    return csr_matrix((w, (src, dst)), shape=(rows * cols, rows * cols))


class GridSearch:
    """Shortest paths on one occupancy grid with cached per-goal distance fields.

    grid: the OccupancyGrid (kept by reference; call ``refresh()`` after changing
        ``grid.occupied`` in place, e.g. when collisions add blocked cells).
    cache_size: distance fields kept (least recently used are dropped).
    snap_radius: [m] how far a start may be moved to reach a cell connected to the goal.
    clearance_cost, clearance_band: see ``clearance_factor`` (0: plain shortest paths; then
        ``distance`` is in metres, otherwise in metres weighted by the factor).
    """

    def __init__(self, grid: OccupancyGrid, cache_size: int = 64, snap_radius: float = 1.0,
                 clearance_cost: float = 0.0, clearance_band: float = 0.2):
        if not isinstance(grid, OccupancyGrid):
            raise TypeError(f"GridSearch needs an OccupancyGrid, got {type(grid).__name__}")
        self.grid = grid
        self.cache_size = int(cache_size)
        self.snap_radius = float(snap_radius)
        self.clearance = (float(clearance_cost), float(clearance_band))
        self._fields: OrderedDict[bytes, DistanceField] = OrderedDict()
        self.last_snap = SnapInfo()
        self.n_dijkstra = 0  # distance fields computed (for benchmarks / tests)
        self.refresh()

    # ---- graph maintenance -------------------------------------------------------------
    def refresh(self) -> None:
        """Rebuild the graph from ``grid.occupied`` and drop every cached field."""
        self._occ = self.grid.occupied.copy()
        occ = self.grid.occupied
        self._read_only = occ if not occ.flags.writeable else None  # skips the comparison per query
        self._csr = grid_csr(self._occ, self.grid.resolution, *self.clearance)
        self._fields.clear()
        if self._occ.all():
            self._near_free = None
        else:
            _, ind = ndimage.distance_transform_edt(self._occ, return_indices=True)
            self._near_free = ind  # [2, rows, cols] nearest free cell of each cell

    def _check_fresh(self) -> None:
        occ = self.grid.occupied
        if occ is self._read_only:  # a read-only map cannot have changed since refresh()
            return
        if occ.shape != self._occ.shape or not np.array_equal(occ, self._occ):
            self.refresh()

    # ---- cells -------------------------------------------------------------------------
    def _clip_cell(self, rc) -> tuple[int, int]:
        rows, cols = self._occ.shape
        return int(np.clip(rc[0], 0, rows - 1)), int(np.clip(rc[1], 0, cols - 1))

    def nearest_free_cell(self, rc) -> tuple[int, int]:
        """The nearest free cell (Euclidean) to a cell; the cell itself if free."""
        if self._near_free is None:
            raise ValueError("the occupancy grid has no free cell; check robot_radius and the scene")
        r, c = self._clip_cell(rc)
        return int(self._near_free[0, r, c]), int(self._near_free[1, r, c])

    def _goal_nodes(self, goal) -> tuple[np.ndarray, bool]:
        g = np.asarray(goal)
        cols = self._occ.shape[1]
        if g.ndim == 1 and g.shape == (2,):
            cell = tuple(self.grid.world_to_cell(g.astype(float)))
            fc = self.nearest_free_cell(cell)
            snapped = fc != cell
            return np.array([fc[0] * cols + fc[1]]), snapped
        if g.ndim == 2 and g.shape[1] == 2:
            if len(g) == 0:
                raise ValueError("goal region is empty: pass at least one (row, col) cell")
            cells = g.astype(int)
            rows_, cols_ = self._occ.shape
            inb = (cells[:, 0] >= 0) & (cells[:, 0] < rows_) & (cells[:, 1] >= 0) & (cells[:, 1] < cols_)
            cells = cells[inb]
            free = cells[~self._occ[cells[:, 0], cells[:, 1]]] if len(cells) else cells
            snapped = False
            if len(free) == 0:
                src = g.astype(int)
                free = np.array([self.nearest_free_cell(c) for c in src])
                snapped = True
            nodes = np.unique(free[:, 0] * cols + free[:, 1])
            return nodes, snapped
        raise ValueError(f"goal must be a world point (x, y) [m] or an array of (row, col) cells [K, 2]; "
                         f"got shape {g.shape}")

    # ---- distance fields ---------------------------------------------------------------
    def field(self, goal) -> DistanceField:
        """The (cached) distance field to a goal point (x, y) [m] or a goal region of cells [K, 2]."""
        self._check_fresh()
        nodes, snapped = self._goal_nodes(goal)
        self.last_snap.goal_snapped = snapped
        self.last_snap.goal_cells = len(nodes)
        return self._field_nodes(nodes)

    def _field_nodes(self, nodes: np.ndarray) -> DistanceField:
        key = np.asarray(nodes, dtype=np.int64).tobytes()
        f = self._fields.get(key)
        if f is not None:
            self._fields.move_to_end(key)
            return f
        dist, pred, _ = dijkstra(self._csr, directed=False, indices=nodes, min_only=True,
                                 return_predecessors=True)
        self.n_dijkstra += 1
        f = DistanceField(dist=dist, pred=pred.astype(np.int32), goal_nodes=nodes)
        self._fields[key] = f
        while len(self._fields) > self.cache_size:
            self._fields.popitem(last=False)
        return f

    def _start_node(self, start_xy, f: DistanceField) -> Optional[int]:
        rows, cols = self._occ.shape
        cell = tuple(int(v) for v in self.grid.world_to_cell(np.asarray(start_xy, dtype=float)))
        if self.grid.in_bounds(cell):
            n = cell[0] * cols + cell[1]
            if np.isfinite(f.dist[n]):
                self.last_snap.start_snapped = False
                self.last_snap.start_cell = cell
                return n
        # nearest cell connected to the goal within snap_radius (Euclidean, ties by lower cost)
        rad = max(1, int(np.ceil(self.snap_radius / self.grid.resolution)))
        r, c = cell
        r0, r1 = max(0, r - rad), min(rows, r + rad + 1)
        c0, c1 = max(0, c - rad), min(cols, c + rad + 1)
        if r0 >= r1 or c0 >= c1:
            return None
        rr, cc = np.mgrid[r0:r1, c0:c1]
        d = f.dist.reshape(rows, cols)[r0:r1, c0:c1]
        ok = np.isfinite(d)
        if not ok.any():
            return None
        e2 = (rr - r) ** 2 + (cc - c) ** 2
        e2 = np.where(ok & (e2 <= rad * rad), e2, np.iinfo(np.int64).max)
        if e2.min() == np.iinfo(np.int64).max:
            return None
        order = np.lexsort((d.ravel(), e2.ravel()))
        k = order[0]
        rs, cs = int(rr.ravel()[k]), int(cc.ravel()[k])
        self.last_snap.start_snapped = True
        self.last_snap.start_cell = (rs, cs)
        return rs * cols + cs

    # ---- queries -----------------------------------------------------------------------
    def path_cells(self, start_xy, goal) -> Optional[np.ndarray]:
        """Cells [N, 2] (row, col) from the start's cell to the nearest goal cell, or None."""
        f = self.field(goal)
        n = self._start_node(start_xy, f)
        if n is None:
            return None
        cols = self._occ.shape[1]
        out = [n]
        pred = f.pred
        while pred[n] >= 0:
            n = int(pred[n])
            out.append(n)
        arr = np.asarray(out, dtype=np.int64)
        return np.stack([arr // cols, arr % cols], axis=1)

    def path(self, start_xy, goal) -> Optional[np.ndarray]:
        """Shortest path as world points [N, 2] (cell centres) [m], or None if unreachable.

        start_xy: (x, y) [m]. goal: a world point (x, y) [m], or a goal region given as an
        integer array of (row, col) cells [K, 2] (any of them is a goal).
        """
        cells = self.path_cells(start_xy, goal)
        if cells is None:
            return None
        return self.grid.cell_to_world(cells)

    def distance(self, start_xy, goal) -> float:
        """Shortest-path cost [m] from a start point to a goal (inf if unreachable)."""
        f = self.field(goal)
        n = self._start_node(start_xy, f)
        return float("inf") if n is None else float(f.dist[n])

    def reachable(self, start_xy, goal) -> bool:
        return np.isfinite(self.distance(start_xy, goal))
