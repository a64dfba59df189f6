"""``BeliefMap``: the robot's map of the house (paper §IV-B).

``presumed``: every door presumed open, plus the cells where collisions were felt during the
mission (``block_cells``, ``block_box``; with ``sim.persistent_map=false`` only during the
navigate action that felt them: ``forget``); ``true``: door leaves as they are (the reference, never
used for planning). Grid search runs on the presumed map; ``anchor`` gives the goal point of a
navigation to a furniture. ``reset`` forgets what a mission learned.
"""

from __future__ import annotations

import math
from typing import Optional

import numpy as np
from scipy import ndimage

from interllm.planning.search import GridSearch
from interllm.scene.geometry import boxes_distance
from interllm.scene.graph import Furniture
from interllm.scene.grid import OccupancyGrid, clear_of_obstacles

ANCHOR_RINGS = (0.25, 0.5, 1.0)  # [m] beyond the robot radius: how far an anchor may be from a footprint


class BeliefMap:
    """presumed / true occupancy grids of a house for a robot of ``robot_radius`` [m].

    furniture: the house's furniture (static: anchors are computed once per furniture).
    clearance: (sim.clearance_cost, sim.clearance_band [m]) of the path search (``GridSearch``).
    footprint_extra: [m] how much the true footprint exceeds ``robot_radius``; anchors keep that
        much farther from obstacles where they can.
    """

    def __init__(self, presumed: OccupancyGrid, true: OccupancyGrid, furniture: dict[str, Furniture],
                 robot_radius: float, clearance: tuple[float, float] = (0.0, 0.2),
                 footprint_extra: float = 0.0) -> None:
        self.true = true
        self.initial = presumed
        self.robot_radius = float(robot_radius)
        self._furniture = furniture
        lab, n = ndimage.label(presumed.free, structure=np.ones((3, 3), dtype=bool))
        sizes = np.bincount(lab.ravel())[1:]
        self._main_component = (lab == (int(np.argmax(sizes)) + 1)) if n else np.zeros_like(lab, dtype=bool)
        self._standable = clear_of_obstacles(presumed.free, footprint_extra, presumed.resolution)
        self._anchors: dict[str, tuple[float, float]] = {}
        self.clearance = (float(clearance[0]), float(clearance[1]))
        self.presumed = presumed.copy()
        # the initial map's search graph and distance fields, kept for every mission of the world
        prior = presumed.copy()
        prior.occupied.setflags(write=False)  # never changes: its search skips the per-query map check
        self._prior = GridSearch(prior, clearance_cost=self.clearance[0], clearance_band=self.clearance[1])
        self._learned_search: Optional[GridSearch] = None
        self.learned = 0  # cells blocked since the last reset
        self.version = 0  # 0: the initial map; else a number no other map of this belief had
        self._versions = 0

    @property
    def search(self) -> GridSearch:
        """Path search on the current presumed map: the initial map's (shared, with its cached distance
        fields) until a collision blocks cells, then one over the changed map."""
        if not self.learned:
            return self._prior
        if self._learned_search is None:
            self._learned_search = GridSearch(self.presumed, clearance_cost=self.clearance[0],
                                              clearance_band=self.clearance[1])
        return self._learned_search

    def reset(self) -> None:
        """The initial presumed map again (a new mission, or a navigate without a persistent map)."""
        self.presumed = self.initial.copy()
        self._learned_search = None
        self.learned = 0
        self.version = 0

    def forget(self) -> None:
        """Forget the cells collisions blocked (cheap when there are none)."""
        if self.learned:
            self.reset()

    def _changed(self, cells: int) -> None:
        if cells:
            self._versions += 1
            self.version = self._versions

    def anchor(self, furniture_id: str) -> tuple[float, float]:
        """Goal point [m] for navigating to a furniture: the free cell of the initial presumed
        map (where the true footprint touches nothing, if there is such a cell) next to it (within robot_radius + 0.25 m of its footprint, widening to 0.5 and 1 m
        if needed), in the largest connected free region, closest to the furniture centre."""
        if furniture_id in self._anchors:
            return self._anchors[furniture_id]
        if furniture_id not in self._furniture:
            raise KeyError(f"unknown furniture {furniture_id!r}; valid: {sorted(self._furniture)}")
        f = self._furniture[furniture_id]
        g = self.initial
        cells = np.argwhere(g.free & self._main_component & self._standable)
        if len(cells) == 0:
            cells = np.argwhere(g.free & self._main_component)
        if len(cells) == 0:
            cells = np.argwhere(g.free)
        pts = g.cell_to_world(cells)
        d_fp = boxes_distance(pts, f.boxes)
        for ring in ANCHOR_RINGS:
            ok = d_fp <= self.robot_radius + ring
            if ok.any():
                cand = pts[ok]
                dc = np.hypot(cand[:, 0] - f.center[0], cand[:, 1] - f.center[1])
                k = int(np.argmin(np.round(dc, 9)))
                a = (float(cand[k, 0]), float(cand[k, 1]))
                self._anchors[furniture_id] = a
                return a
        raise ValueError(f"furniture {furniture_id!r} has no free cell within "
                         f"{self.robot_radius + ANCHOR_RINGS[-1]:.2f} m of its footprint; the robot cannot "
                         f"reach it (check the scene layout or sim.robot_radius)")

    def presumed_path(self, start_xy, furniture_id: str) -> Optional[np.ndarray]:
        """Shortest path [N, 2] on the current presumed map from ``start_xy`` to the furniture's
        anchor, or None. This is the paper's presumed path p^pre."""
        return self.search.path(start_xy, self.anchor(furniture_id))

    def block_cells(self, xy_center, radius: float) -> int:
        """Mark presumed cells within ``radius`` [m] of a point as occupied; returns how many changed."""
        g = self.presumed
        rc = g.world_to_cell(np.asarray(xy_center, dtype=float))
        rad = int(math.ceil(radius / g.resolution))
        r0, r1 = max(0, rc[0] - rad), min(g.shape[0], rc[0] + rad + 1)
        c0, c1 = max(0, rc[1] - rad), min(g.shape[1], rc[1] + rad + 1)
        if r0 >= r1 or c0 >= c1:
            return 0
        rr, cc = np.mgrid[r0:r1, c0:c1]
        ctr = g.cell_to_world(np.stack([rr, cc], -1))
        m = np.hypot(ctr[..., 0] - xy_center[0], ctr[..., 1] - xy_center[1]) <= radius
        before = int(g.occupied[r0:r1, c0:c1].sum())
        g.occupied[r0:r1, c0:c1] |= m
        changed = int(g.occupied[r0:r1, c0:c1].sum()) - before
        self.learned += changed
        self._changed(changed)
        return changed

    def block_box(self, x0: float, y0: float, x1: float, y1: float) -> int:
        """Mark the presumed cells of an axis-aligned box [m] as occupied; returns how many changed."""
        g = self.presumed
        c0, r0 = g.world_to_cell(np.array([x0, y0]))[::-1]
        c1, r1 = g.world_to_cell(np.array([x1, y1]))[::-1]
        r0, c0 = max(0, r0), max(0, c0)
        r1, c1 = min(g.shape[0] - 1, r1), min(g.shape[1] - 1, c1)
        if r0 > r1 or c0 > c1:
            return 0
        before = int(g.occupied[r0:r1 + 1, c0:c1 + 1].sum())
        g.occupied[r0:r1 + 1, c0:c1 + 1] = True
        changed = int(g.occupied[r0:r1 + 1, c0:c1 + 1].sum()) - before
        self.learned += changed
        self._changed(changed)
        return changed
