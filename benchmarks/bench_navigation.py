"""Navigation contacts on the default experiment's houses: the base's contact radius and the
clearance-weighted search side by side, on the same drives.

    .venv/bin/python benchmarks/bench_navigation.py [--scenes data/scenes] [--drives 40]

Per scene, ``--drives`` navigations between furniture drawn with a fixed seed (each from the
previous goal, starting at the first mission's start pose), run under three settings of
``sim.footprint_radius`` / ``sim.clearance_cost``:
- ``map radius``: the contact radius of the map's inflation less half a cell (the earlier
  protocol: walls and furniture are never touched, only door leaves);
- ``footprint, shortest``: the true footprint (0.30 m) on plain shortest paths;
- ``footprint, clearance``: the true footprint on clearance-weighted paths (the default).
Prints per setting: collisions per navigate, the share of navigates with a collision, failed
navigates, mean driven distance [m], what was hit (door / wall / furniture), and the wall time
per navigate [ms] with the ratio to the first setting. No LLM is involved.
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import argparse
import time
from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np

from interllm.config import ExperimentConfig
from interllm.core.actions import Action
from interllm.sim.world import World
from interllm.stages.inputs import load_grids, load_scene_and_missions, scene_ids

SETTINGS = (("map radius", {"footprint_radius": None, "clearance_cost": 0.0}),
            ("footprint, shortest", {"footprint_radius": 0.30, "clearance_cost": 0.0}),
            ("footprint, clearance", {"footprint_radius": 0.30, "clearance_cost": 2.0}))


def _counting(base_contacts, hit: Counter):
    """``base_contacts`` that also counts the kinds of obstacle touched into ``hit``."""
    def counted():
        c = base_contacts()
        hit.update({kind for _, _, kind, _ in c})
        return c
    return counted


def drives(scenes_dir: Path, n: int, overrides: dict) -> tuple[list, Counter, float]:
    """(every navigate's ActionResult, what the contacts hit, wall seconds of the navigates)."""
    cfg = ExperimentConfig()
    sim = replace(cfg.sim, **overrides)
    results, hit, wall = [], Counter(), 0.0
    for sid in scene_ids(scenes_dir):
        scene, missions = load_scene_and_missions(scenes_dir, sid, cfg)
        world = World(scene, sim, cfg.scene.grid_resolution, load_grids(scenes_dir, sid, cfg))
        world.reset(missions[0])
        rng = np.random.default_rng(0)
        furniture = sorted(scene.furniture)
        world.physics.base_contacts = _counting(world.physics.base_contacts, hit)
        for _ in range(n):
            fid = furniture[int(rng.integers(len(furniture)))]
            t0 = time.perf_counter()
            r = world.execute(Action("navigate", fid, room=scene.furniture[fid].room))
            wall += time.perf_counter() - t0
            results.append(r)
    return results, hit, wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", type=Path, default=Path("data/scenes"))
    ap.add_argument("--drives", type=int, default=40, help="navigations per scene")
    args = ap.parse_args()
    base = None
    for name, overrides in SETTINGS:
        res, hit, wall = drives(args.scenes, args.drives, overrides)
        n = len(res)
        cc = [r.collisions for r in res]
        ms = 1e3 * wall / n
        base = base or ms
        print(f"{name:22s} {n} navigates | collisions/navigate {np.mean(cc):.2f} | with a collision "
              f"{100 * np.mean([c > 0 for c in cc]):.0f}% | failed {sum(not r.success for r in res)} | "
              f"distance {np.mean([r.distance for r in res]):.2f} m | hit {dict(sorted(hit.items()))} | "
              f"{ms:.0f} ms/navigate ({ms / base:.2f}x)")


if __name__ == "__main__":
    main()
