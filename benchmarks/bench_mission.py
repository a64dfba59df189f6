"""One paper-size mission per planner: execution time without the LLM, and MCAP logging overhead.

    .venv/bin/python benchmarks/bench_mission.py [--repeats 3]

Uses the default experiment's first scene and mission (regenerated from the config, seed 0) and
the committed LLM cache in replay mode, so no model runs: the time is planning + MuJoCo execution
(+ logging). Per planner it measures, best of N:

- exec: the mission with a recorder that only keeps the calls (planning + MuJoCo, no logging), in
  one World per scene reset for each run, as the missions stage keeps it;
- log: writing exactly those calls to an MCAP (McapRecorder with the robot model: /tf with the
  arm's link frames, /joint_states, /scene updates, paths, actions, LLM calls, metrics); the
  overhead is log / exec (goal <= 10%);
- end to end: the whole mission with the McapRecorder against one with NullRecorder (noisier:
  two full runs on a shared machine).
Times are CPU seconds of this process (``time.process_time``, best of N), so that other tenants
of a shared machine do not move the ratios; the real-time factor is simulated time over CPU
time. Also prints simulated mission time, the file size and the wall time to replay the file to a
rerun .rrd (``interllm replay --save``; goal <= 5 s).
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

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
from interllm.record import McapRecorder, NullRecorder, replay  # noqa: E402
from interllm.scene import generate_missions, generate_scene  # noqa: E402
from interllm.scene.grid import rasterize  # noqa: E402
from interllm.sim.kinematics import RobotKinematics  # noqa: E402
from interllm.sim.world import World  # noqa: E402
from pipeline._hydra import compose  # noqa: E402


class CallLog:
    """A recorder that keeps every call (to replay them into a real recorder)."""

    def __init__(self) -> None:
        self.calls: list = []

    def event(self, *a) -> None:
        self.calls.append(("event", a))

    def log(self, *a) -> None:
        self.calls.append(("log", a))

    def action(self, *a) -> None:
        self.calls.append(("action", a))


def cpu_time() -> float:
    """CPU seconds of this process (all its threads): on a shared machine, time other tenants take
    from us moves wall-clock times by +-30% between repeats, CPU time by a few percent."""
    return time.process_time()


def write(path: Path, calls, scene, grids, robot) -> float:
    """CPU seconds to write ``calls`` to an MCAP at ``path``."""
    t = cpu_time()
    with McapRecorder(path, scene, {"bench": "1"}, grids=grids, robot=robot) as r:
        for name, args in calls:
            getattr(r, name)(*args)
    return cpu_time() - t


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    cfg = OmegaConf.to_object(compose(["llm.cache_mode=replay"]))
    cfg.llm.cache_dir = str(ROOT / "data" / "llm_cache")
    scene = generate_scene(cfg.scene, 0, robot_radius=cfg.sim.robot_radius)
    mission = generate_missions(scene, cfg.mission, cfg.sim.robot_radius, cfg.scene.grid_resolution,
                                footprint_radius=cfg.sim.footprint_radius)[0]
    client = make_client(cfg.llm)
    cands = generate_initial_candidates(scene, mission, client, cfg)
    grids = {k: rasterize(scene, cfg.scene.grid_resolution, cfg.sim.robot_radius, k) for k in ("presumed", "true")}
    robot = RobotKinematics(cfg.sim)
    shared = World(scene, cfg.sim, cfg.scene.grid_resolution, grids)

    def world() -> World:  # one world per scene, reset by run_mission, as the missions stage keeps it
        return shared
    print(f"scene {scene.id}, mission {mission.id} ({len(mission.commands)} commands), replayed LLM cache")
    print("CPU seconds, best of", args.repeats, "(log columns: seconds, then overhead = log / exec)")
    print(f"{'planner':<11}{'actions':>8}{'samples':>8}{'sim [s]':>9}{'exec [s]':>9}{'log':>8}{'':>7}"
          f"{'end-to-end':>11}{'x real time':>12}{'MB':>6}{'replay [s]':>11}")
    with tempfile.TemporaryDirectory() as tmp:
        for planner in cfg.planner.names:
            best = {"exec": float("inf"), "log": float("inf"), "null": float("inf"), "mcap": float("inf")}
            for i in range(args.repeats):
                cl = CallLog()
                t = cpu_time()
                rec = run_mission(planner, world(), mission, cands, client, cfg, recorder=cl).to_dict()
                best["exec"] = min(best["exec"], cpu_time() - t)
                log_path = Path(tmp) / f"{planner}_{i}.mcap"
                best["log"] = min(best["log"], write(log_path, cl.calls, scene, grids, robot))
                t = cpu_time()
                run_mission(planner, world(), mission, cands, client, cfg, recorder=NullRecorder())
                best["null"] = min(best["null"], cpu_time() - t)
                t = cpu_time()
                with McapRecorder(Path(tmp) / f"{planner}_e2e.mcap", scene, {"bench": "1"}, grids=grids,
                                  robot=robot) as r:
                    run_mission(planner, world(), mission, cands, client, cfg, recorder=r)
                best["mcap"] = min(best["mcap"], cpu_time() - t)
            n = sum(len(c["actions"]) for c in rec["commands"])
            samples = sum(a[0].trajectory.t.size for name, a in cl.calls if name == "action" and a[0].trajectory)
            size = log_path.stat().st_size / 1e6
            t = time.perf_counter()
            replay(log_path, save=str(Path(tmp) / f"{planner}.rrd"))
            t_replay = time.perf_counter() - t
            logs = f"{best['log']:>8.3f}{best['log'] / best['exec']:>7.1%}"
            print(f"{planner:<11}{n:>8}{samples:>8}{rec['sim_time']:>9.1f}{best['exec']:>9.2f}{logs}"
                  f"{(best['mcap'] - best['null']) / best['null']:>11.1%}{rec['sim_time'] / best['exec']:>12.0f}"
                  f"{size:>6.2f}{t_replay:>11.2f}")
    client.close()


if __name__ == "__main__":
    main()
