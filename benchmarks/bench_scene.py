"""Scene generation time per size preset (goals: paper <= 2 s, huge <= 30 s).

Compares the full generator with the obvious cheaper alternative in the same run: the layout alone
(floor plan + furniture + objects, no reachability verification on the presumed and true grids),
and reports the verification overhead as a ratio.

Run: .venv/bin/python benchmarks/bench_scene.py [--repeats 3] [--sizes tiny paper large huge]
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import argparse
import statistics
import time

import numpy as np

from interllm.scene import generate_scene, scene_config
from interllm.scene.build_state import BuildState
from interllm.scene.catalog import load_catalog
from interllm.scene.floor_plans import grid_plan
from interllm.scene.furnishing import place_all_furniture
from interllm.scene.surface_objects import place_legacy_objects


def layout_only(cfg, index):
    rng = np.random.default_rng([cfg.seed + index, 0])
    b = BuildState(load_catalog(), cfg, rng, 0.25)
    grid_plan(b)
    place_all_furniture(b)
    place_legacy_objects(b)
    return b


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--sizes", nargs="+", default=["tiny", "paper", "large", "huge"])
    a = ap.parse_args()
    goals = {"paper": 2.0, "huge": 30.0}
    print(f"{'size':6} {'rooms':>5} {'furn':>5} {'objs':>5} {'full [s]':>9} {'layout [s]':>10} "
          f"{'full/layout':>11} {'goal [s]':>8}")
    for name in a.sizes:
        cfg = scene_config(name)
        full, lay = [], []
        for i in range(a.repeats):
            t = time.perf_counter()
            s = generate_scene(cfg, i)
            full.append(time.perf_counter() - t)
            t = time.perf_counter()
            try:
                layout_only(cfg, i)
                lay.append(time.perf_counter() - t)
            except Exception:  # attempt 0 needed a redraw; layout time not comparable
                pass
        f = statistics.median(full)
        lo = statistics.median(lay) if lay else float("nan")
        print(f"{name:6} {len(s.rooms):5d} {len(s.furniture):5d} {len(s.objects):5d} {f:9.3f} {lo:10.3f} "
              f"{f / lo:11.2f} {goals.get(name, float('nan')):8.1f}")


if __name__ == "__main__":
    main()
