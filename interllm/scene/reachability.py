"""Which rooms and furniture a robot can reach on an occupancy grid (generator and validation)."""

from __future__ import annotations

from interllm.scene.graph import SceneGraph
from interllm.scene.grid import approach_cells_of, free_components, largest_component

REACH_MARGIN = 0.35  # [m] beyond the robot radius: how far the arm reaches over an edge


def unreachable(scene: SceneGraph, grid, robot_radius: float) -> list[str]:
    """Ids of rooms and furniture not reachable from the largest free region of ``grid``.

    A furniture is reachable if a free cell within ``robot_radius + REACH_MARGIN`` m of its
    footprint lies in the largest free region; a room if any of its free cells does.
    """
    labels, _ = free_components(grid, connectivity=4)
    main = largest_component(labels)
    bad = []
    for rid in sorted(scene.rooms):
        x0, y0, x1, y1 = scene.rooms[rid].bounds
        lo = grid.world_to_cell((x0, y0))
        hi = grid.world_to_cell((x1, y1))
        sub = labels[max(lo[0], 0):hi[0] + 1, max(lo[1], 0):hi[1] + 1]
        if main == 0 or not (sub == main).any():
            bad.append(rid)
    for fid in sorted(scene.furniture):
        cells = approach_cells_of(grid, scene.furniture[fid].boxes, robot_radius + REACH_MARGIN)
        if main == 0 or not len(cells) or not (labels[cells[:, 0], cells[:, 1]] == main).any():
            bad.append(fid)
    return bad
