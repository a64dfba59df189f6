"""Grid search benchmark: GridSearch (cached scipy Dijkstra fields) vs networkx.astar_path.

Same grid, same 8-connected octile graph (no corner cutting), same start/goal pairs. Prints
per-query times, the speed-up ratio and checks both give the same path cost.

Run: .venv/bin/python benchmarks/bench_search.py [--rooms 49] [--nx-queries 4]
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import argparse
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import networkx as nx  # noqa: E402
import numpy as np  # noqa: E402

from interllm.planning.search import GridSearch, path_length  # noqa: E402
from interllm.scene.graph import Door, Furniture, Room, SceneGraph, Wall  # noqa: E402
from interllm.scene.grid import rasterize  # noqa: E402


def grid_house(n_rooms: int, room: float = 4.0, seed: int = 0) -> SceneGraph:
    """A procedural house: a k x k block of square rooms, doors between random neighbours
    (a spanning tree plus extra loops), two pieces of furniture per room."""
    rng = np.random.default_rng(seed)
    k = int(math.ceil(math.sqrt(n_rooms)))
    sg = SceneGraph(id=f"bench_{n_rooms}", seed=seed)
    cells = [(i, j) for i in range(k) for j in range(k)][:n_rooms]
    for i, j in cells:
        x0, y0 = j * room, i * room
        rid = f"room_{i}_{j}"
        sg.rooms[rid] = Room(rid, "room", ((x0, y0), (x0 + room, y0), (x0 + room, y0 + room), (x0, y0 + room)))
        for n, (fx, fy) in enumerate(((0.8, 0.8), (room - 1.0, room - 0.9))):
            fid = f"table_{i}_{j}_{n}"
            sg.furniture[fid] = Furniture(fid, "table", rid, (x0 + fx, y0 + fy), (0.8, 0.6, 0.75))
    in_house = set(cells)
    # walls: every room edge, split around doors
    edges = []
    for i, j in cells:
        if (i, j + 1) in in_house:
            edges.append(((i, j), (i, j + 1)))
        if (i + 1, j) in in_house:
            edges.append(((i, j), (i + 1, j)))
    # spanning tree by random order union-find, then 30 % extra doors
    parent = {c: c for c in cells}

    def find(c):
        while parent[c] != c:
            parent[c] = parent[parent[c]]
            c = parent[c]
        return c

    order = rng.permutation(len(edges))
    doors = []
    for e in order:
        a, b = edges[e]
        if find(a) != find(b):
            parent[find(a)] = find(b)
            doors.append(edges[e])
        elif rng.random() < 0.3:
            doors.append(edges[e])
    door_set = set(doors)
    wid = 0
    for (a, b) in edges:
        (i, j), (i2, j2) = a, b
        if i2 == i:  # vertical wall at x = (j+1)*room
            x = (j + 1) * room
            y0, y1 = i * room, (i + 1) * room
            if (a, b) in door_set:
                d = Door(f"door_{len(sg.doors)}", (f"room_{i}_{j}", f"room_{i2}_{j2}"), (x, y0 + room / 2), "y", 1.0)
                sg.doors[d.id] = d
                segs = [((x, y0), (x, y0 + room / 2 - 0.5)), ((x, y0 + room / 2 + 0.5), (x, y1))]
            else:
                segs = [((x, y0), (x, y1))]
        else:  # horizontal wall at y = (i+1)*room
            y = (i + 1) * room
            x0, x1 = j * room, (j + 1) * room
            if (a, b) in door_set:
                d = Door(f"door_{len(sg.doors)}", (f"room_{i}_{j}", f"room_{i2}_{j2}"), (x0 + room / 2, y), "x", 1.0)
                sg.doors[d.id] = d
                segs = [((x0, y), (x0 + room / 2 - 0.5, y)), ((x0 + room / 2 + 0.5, y), (x1, y))]
            else:
                segs = [((x0, y), (x1, y))]
        for s, e in segs:
            sg.walls[f"wall_{wid}"] = Wall(f"wall_{wid}", s, e, 0.1, 2.5)
            wid += 1
    return sg


def nx_graph(occ: np.ndarray, res: float) -> nx.Graph:
    rows, cols = occ.shape
    free = ~occ
    g = nx.Graph()
    idx = np.arange(rows * cols).reshape(rows, cols)
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        r0, r1 = max(0, -dr), rows - max(0, dr)
        c0, c1 = max(0, -dc), cols - max(0, dc)
        ok = free[r0:r1, c0:c1] & free[r0 + dr:r1 + dr, c0 + dc:c1 + dc]
        if dr and dc:
            ok &= free[r0 + dr:r1 + dr, c0:c1] & free[r0:r1, c0 + dc:c1 + dc]
        w = res * (math.sqrt(2) if dr and dc else 1.0)
        g.add_weighted_edges_from(zip(idx[r0:r1, c0:c1][ok].tolist(),
                                      idx[r0 + dr:r1 + dr, c0 + dc:c1 + dc][ok].tolist(),
                                      [w] * int(ok.sum()), strict=False))
    return g


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rooms", type=int, default=49)
    ap.add_argument("--nx-queries", type=int, default=4)
    ap.add_argument("--starts-per-goal", type=int, default=20)
    args = ap.parse_args()
    try:  # the project's generator when it exists
        from interllm.config import SceneConfig
        from interllm.scene.generator import generate_scene  # type: ignore

        scene = generate_scene(SceneConfig(name="custom", n_rooms=args.rooms, n_furniture=2 * args.rooms,
                                           n_objects=args.rooms), 0)
        src = "interllm.scene.generator"
    except Exception:
        scene = grid_house(args.rooms)
        src = "procedural grid house"
    grid = rasterize(scene, 0.05, 0.25, doors="presumed")
    rows, cols = grid.shape
    print(f"scene: {src}, {len(scene.rooms)} rooms, grid {rows}x{cols} = {rows * cols} cells "
          f"({int(grid.free.sum())} free)")

    t = time.perf_counter()
    gs = GridSearch(grid)
    t_build = time.perf_counter() - t
    t = time.perf_counter()
    g = nx_graph(grid.occupied, grid.resolution)
    t_nxbuild = time.perf_counter() - t
    print(f"graph build: GridSearch {t_build * 1e3:.1f} ms, networkx {t_nxbuild * 1e3:.1f} ms")

    # queries between furniture sides (free cells nearest to furniture centres)
    rng = np.random.default_rng(0)
    free = np.argwhere(grid.free)
    comp = nx.node_connected_component(g, int(free[len(free) // 2][0] * cols + free[len(free) // 2][1]))
    comp_cells = np.array(sorted(comp))

    def rand_pt():
        n = int(comp_cells[rng.integers(len(comp_cells))])
        return grid.cell_to_world(np.array([n // cols, n % cols]))

    pairs = [(rand_pt(), rand_pt()) for _ in range(args.nx_queries)]
    h = lambda u, v: grid.resolution * math.hypot(u // cols - v // cols, u % cols - v % cols)  # noqa: E731
    nx_times, nx_costs = [], []
    for a, b in pairs:
        ca, cb = grid.world_to_cell(a), grid.world_to_cell(b)
        na, nb = int(ca[0] * cols + ca[1]), int(cb[0] * cols + cb[1])
        t = time.perf_counter()
        p = nx.astar_path(g, na, nb, heuristic=h, weight="weight")
        nx_times.append(time.perf_counter() - t)
        pts = grid.cell_to_world(np.array([[n // cols, n % cols] for n in p]))
        nx_costs.append(path_length(pts))
    # GridSearch: first (cold) query per goal, then warm queries from other starts
    cold, ours_costs = [], []
    for a, b in pairs:
        t = time.perf_counter()
        p = gs.path(a, b)
        cold.append(time.perf_counter() - t)
        ours_costs.append(path_length(p))
    warm = []
    for _, b in pairs:
        for _ in range(args.starts_per_goal):
            a = rand_pt()
            t = time.perf_counter()
            gs.path(a, b)
            warm.append(time.perf_counter() - t)
    same = np.allclose(nx_costs, ours_costs, atol=1e-9)
    n_q = len(pairs) + len(warm)
    amort = (sum(cold) + sum(warm)) / n_q
    nx_mean = float(np.mean(nx_times))
    print(f"networkx astar_path: {nx_mean * 1e3:.1f} ms/query over {len(pairs)} queries")
    print(f"GridSearch cold (new goal, Dijkstra field): {np.mean(cold) * 1e3:.1f} ms/query "
          f"-> {nx_mean / np.mean(cold):.1f}x faster")
    print(f"GridSearch warm (cached goal field): {np.mean(warm) * 1e3:.3f} ms/query "
          f"-> {nx_mean / np.mean(warm):.0f}x faster")
    print(f"GridSearch amortised over {n_q} queries ({args.starts_per_goal} starts per goal): "
          f"{amort * 1e3:.2f} ms/query -> {nx_mean / amort:.0f}x faster")
    print(f"same path cost as networkx on every query: {same} "
          f"(costs {', '.join(f'{c:.3f}' for c in ours_costs)} m)")


if __name__ == "__main__":
    main()
