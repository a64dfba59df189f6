"""The two base-pose protocols (``sim.pose_protocol``) side by side on the default experiment's
houses: every object of every scene picked up once, from the furniture's navigation anchor.

    .venv/bin/python benchmarks/bench_manipulation.py [--scenes data/scenes] [--n-l 5] [--pose-reach 0.8] [--pose-margin 0.1]

Prints per protocol: how many pickups have a graded success rate (0 < sr_man < 1), the share of
the paper's cost classes of the measured c_man (easy < 5 <= medium <= 15 < hard), the mean trial
time t_man [s] (simulated), the reasons of failed trials, and the wall time per pickup [ms]. This is
what the planners' costs can learn from; no LLM is involved.
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

from interllm.config import POSE_PROTOCOLS, ExperimentConfig, SimConfig
from interllm.core.actions import Action
from interllm.planning.costs import encode_cost
from interllm.sim.world import World
from interllm.stages.inputs import load_grids, load_scene_and_missions, scene_ids


def pickups(scenes_dir: Path, protocol: str, n_l: int, pose_reach: float, pose_margin: float) -> tuple[list, float]:
    """(every pickup's ActionResult, wall seconds of the pickups alone)."""
    cfg = ExperimentConfig()
    sim = replace(cfg.sim, pose_protocol=protocol, n_l=n_l, pose_reach=pose_reach, pose_margin=pose_margin)
    out, wall = [], 0.0
    for sid in scene_ids(scenes_dir):
        scene, missions = load_scene_and_missions(scenes_dir, sid, cfg)
        world = World(scene, sim, cfg.scene.grid_resolution, load_grids(scenes_dir, sid, cfg))
        for oid in sorted(scene.objects):
            o = scene.objects[oid]
            world.reset(missions[0])
            if not world.execute(Action("navigate", o.furniture, room=scene.furniture[o.furniture].room)).success:
                continue
            t0 = time.perf_counter()
            out.append(world.execute(Action("pickup", o.furniture, obj=oid)))
            wall += time.perf_counter() - t0
    return out, wall


def summary(protocol: str, results: list, wall: float) -> str:
    sr = np.array([r.success_rate for r in results])
    classes = Counter(encode_cost(r.cost) for r in results)
    n = len(results)
    reasons = Counter(t.reason for r in results for t in r.trials if not t.success)
    share = ", ".join(f"{k} {100 * classes[k] / n:.0f}%" for k in ("easy", "medium", "hard"))
    return (f"{protocol:7s} {n:3d} pickups | 0<sr<1: {100 * np.mean((sr > 0) & (sr < 1)):4.0f}% | sr mean "
            f"{sr.mean():.2f} | success {100 * np.mean(sr > 0):.0f}% | classes {share} | t_man "
            f"{np.mean([r.time for r in results]):.2f} s | {1000 * wall / n:.0f} ms/pickup\n"
            f"        failed trials: {dict(sorted(reasons.items()))}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=Path, default=Path("data/scenes"))
    ap.add_argument("--n-l", type=int, default=5)
    ap.add_argument("--pose-reach", type=float, default=SimConfig().pose_reach, help="[m] sim.pose_reach")
    ap.add_argument("--pose-margin", type=float, default=SimConfig().pose_margin, help="[m] sim.pose_margin")
    args = ap.parse_args()
    walls = {}
    for protocol in POSE_PROTOCOLS:
        results, wall = pickups(args.scenes, protocol, args.n_l, args.pose_reach, args.pose_margin)
        walls[protocol] = wall / max(1, len(results))
        print(summary(protocol, results, wall), flush=True)
    print(f"reach / window wall time per pickup: {walls['reach'] / walls['window']:.2f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
