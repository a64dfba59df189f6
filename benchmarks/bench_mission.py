"""One paper-size mission per planner: execution time without the LLM, and MCAP logging overhead.

    .venv/bin/python benchmarks/bench_mission.py [--repeats 3]

Uses the default experiment's first scene and mission (regenerated from the config, seed 0) and
the committed LLM cache in replay mode, so no model runs: the time is planning + MuJoCo execution
(+ logging). Each planner's mission runs with a NullRecorder and with the McapRecorder, interleaved,
best of N; the logging overhead is their difference as a share of the NullRecorder time
(goal <= 10%). Also prints simulated mission time and the real-time factor.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from omegaconf import OmegaConf  # noqa: E402

from interllm.llm import make_client  # noqa: E402
from interllm.planners.candidates import generate_initial_candidates  # noqa: E402
from interllm.planners.runner import run_mission  # noqa: E402
from interllm.record import McapRecorder, NullRecorder  # noqa: E402
from interllm.scene import generate_missions, generate_scene  # noqa: E402
from interllm.scene.grid import rasterize  # noqa: E402
from pipeline._hydra import compose  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    cfg = OmegaConf.to_object(compose(["llm.cache_mode=replay"]))
    cfg.llm.cache_dir = str(ROOT / "data" / "llm_cache")
    scene = generate_scene(cfg.scene, 0, robot_radius=cfg.sim.robot_radius)
    mission = generate_missions(scene, cfg.mission, cfg.sim.robot_radius, cfg.scene.grid_resolution)[0]
    client = make_client(cfg.llm)
    cands = generate_initial_candidates(scene, mission, client, cfg)
    grids = {k: rasterize(scene, cfg.scene.grid_resolution, cfg.sim.robot_radius, k) for k in ("presumed", "true")}
    print(f"scene {scene.id}, mission {mission.id} ({len(mission.commands)} commands), replayed LLM cache")
    print(f"{'planner':<11}{'actions':>8}{'sim [s]':>9}{'null [s]':>10}{'mcap [s]':>10}{'overhead':>10}"
          f"{'x real time':>13}{'mcap MB':>9}")
    with tempfile.TemporaryDirectory() as tmp:
        for planner in cfg.planner.names:
            best_null = best_mcap = float("inf")
            size = 0.0
            for i in range(args.repeats):
                t = time.perf_counter()
                rec = run_mission(planner, scene, mission, cands, client, cfg, NullRecorder())
                best_null = min(best_null, time.perf_counter() - t)
                path = Path(tmp) / f"{planner}_{i}.mcap"
                t = time.perf_counter()
                with McapRecorder(path, scene, {"bench": "1"}, grids=grids) as r:
                    run_mission(planner, scene, mission, cands, client, cfg, r)
                best_mcap = min(best_mcap, time.perf_counter() - t)
                size = path.stat().st_size / 1e6
            n = sum(len(c["actions"]) for c in rec["commands"])
            over = (best_mcap - best_null) / best_null
            print(f"{planner:<11}{n:>8}{rec['sim_time']:>9.1f}{best_null:>10.2f}{best_mcap:>10.2f}{over:>10.1%}"
                  f"{rec['sim_time'] / best_null:>13.0f}{size:>9.2f}")
    client.close()


if __name__ == "__main__":
    main()
