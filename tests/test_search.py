import math

import networkx as nx
import numpy as np
import pytest

from interllm.planning.search import GridSearch, path_length
from interllm.scene.grid import OccupancyGrid


def _nx_graph(occ: np.ndarray, res: float) -> nx.Graph:
    """Independent reference: 8-connected graph, no corner cutting, octile weights."""
    g = nx.Graph()
    rows, cols = occ.shape
    for r in range(rows):
        for c in range(cols):
            if occ[r, c]:
                continue
            g.add_node((r, c))
            for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
                r2, c2 = r + dr, c + dc
                if not (0 <= r2 < rows and 0 <= c2 < cols) or occ[r2, c2]:
                    continue
                if dr and dc and (occ[r + dr, c] or occ[r, c + dc]):
                    continue
                g.add_edge((r, c), (r2, c2), weight=res * (math.sqrt(2) if dr and dc else 1.0))
    return g


def _grid(occ, res=0.1):
    return OccupancyGrid(occupied=np.asarray(occ, dtype=bool), resolution=res, origin=(0.0, 0.0))


def test_straight_line_cost_by_hand():
    g = _grid(np.zeros((5, 10)))
    s = GridSearch(g)
    p = s.path((0.05, 0.25), (0.95, 0.25))
    assert p is not None
    assert len(p) == 10
    assert path_length(p) == pytest.approx(0.9)
    assert s.distance((0.05, 0.25), (0.95, 0.25)) == pytest.approx(0.9)
    # pure diagonal: 4 diagonal steps of 0.1*sqrt(2)
    assert s.distance((0.05, 0.05), (0.45, 0.45)) == pytest.approx(0.4 * math.sqrt(2))


def test_wall_with_gap_goes_through_gap_and_matches_by_hand():
    occ = np.zeros((7, 7), dtype=bool)
    occ[:, 3] = True
    occ[6, 3] = False  # a gap at the top row
    s = GridSearch(_grid(occ, 1.0))
    # from (r0,c0) to (r0,c6): must go via (6,3); corner cutting forbidden at the wall ends
    cells = s.path_cells((0.5, 0.5), (6.5, 0.5))
    assert tuple(cells[0]) == (0, 0) and tuple(cells[-1]) == (0, 6)
    assert any(tuple(c) == (6, 3) for c in cells)
    assert not occ[cells[:, 0], cells[:, 1]].any()
    # consecutive cells are 8-neighbours
    assert np.abs(np.diff(cells, axis=0)).max() == 1
    # the independent reference graph gives the cost
    ref = nx.dijkstra_path_length(_nx_graph(occ, 1.0), (0, 0), (0, 6))
    assert s.distance((0.5, 0.5), (6.5, 0.5)) == pytest.approx(ref)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_cost_equals_networkx_astar_on_random_grids(seed):
    rng = np.random.default_rng(seed)
    occ = rng.random((30, 40)) < 0.28
    res = 0.05
    grid = _grid(occ, res)
    s = GridSearch(grid)
    g = _nx_graph(occ, res)
    free = np.argwhere(~occ)
    comps = list(nx.connected_components(g))
    big = max(comps, key=len)
    cells = sorted(big)
    for _k in range(6):
        a = cells[rng.integers(len(cells))]
        b = cells[rng.integers(len(cells))]
        ref = nx.astar_path_length(g, a, b, heuristic=lambda u, v: res * math.dist(u, v), weight="weight")
        pa = grid.cell_to_world(np.array(a))
        pb = grid.cell_to_world(np.array(b))
        p = s.path(pa, pb)
        assert p is not None
        assert path_length(p) == pytest.approx(ref, abs=1e-9)
        assert s.distance(pa, pb) == pytest.approx(ref, abs=1e-9)
    assert len(free) > 0


def test_field_is_reused_for_every_start():
    rng = np.random.default_rng(5)
    occ = rng.random((20, 20)) < 0.1
    s = GridSearch(_grid(occ))
    goal = (1.05, 1.05)
    for x in (0.15, 0.55, 1.85):
        s.path((x, 0.15), goal)
    assert s.n_dijkstra == 1


def test_goal_region_reaches_nearest_cell():
    s = GridSearch(_grid(np.zeros((10, 10)), 1.0))
    region = np.array([[0, 9], [9, 0], [5, 3]])
    cells = s.path_cells((0.5, 0.5), region)  # start (0,0): (5,3) is 5 steps (3 diag + 2 axis)
    assert tuple(cells[-1]) == (5, 3)
    assert s.distance((0.5, 0.5), region) == pytest.approx(3 * math.sqrt(2) + 2)


def test_snapping_occupied_start_and_goal():
    occ = np.zeros((5, 10), dtype=bool)
    occ[:, 0] = True  # start column blocked
    occ[2, 9] = True  # goal cell blocked
    s = GridSearch(_grid(occ, 1.0))
    p = s.path_cells((0.5, 2.5), (9.5, 2.5))
    assert p is not None
    assert s.last_snap.start_snapped and s.last_snap.goal_snapped
    assert tuple(p[0]) == (2, 1)
    assert not occ[p[:, 0], p[:, 1]].any()


def test_unreachable_returns_none_and_inf():
    occ = np.zeros((5, 11), dtype=bool)
    occ[:, 5] = True
    s = GridSearch(_grid(occ, 1.0), snap_radius=1.0)
    assert s.path((0.5, 0.5), (10.5, 0.5)) is None
    assert s.distance((0.5, 0.5), (10.5, 0.5)) == math.inf


def test_refresh_after_in_place_block():
    grid = _grid(np.zeros((3, 10)), 1.0)
    s = GridSearch(grid)
    assert s.distance((0.5, 1.5), (9.5, 1.5)) == pytest.approx(9.0)
    grid.occupied[1:, 5] = True  # block two rows at column 5: must go around via row 0
    d = s.distance((0.5, 1.5), (9.5, 1.5))
    assert d == pytest.approx(7 + 2 * math.sqrt(2))  # refreshed automatically


def test_bad_goal_is_a_clear_error():
    s = GridSearch(_grid(np.zeros((3, 3))))
    with pytest.raises(ValueError, match="goal must be"):
        s.path((0.1, 0.1), np.zeros((2, 3)))
