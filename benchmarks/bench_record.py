"""Recording benchmark: MCAP logging overhead per action and replay time to .rrd.

1. Logging: a synthetic mission of ``--actions`` actions with ``--samples``-sample trajectories,
   logged through NullRecorder (baseline), McapRecorder, and the obvious alternative of dumping
   each ActionResult record + trajectory to JSON lines. Prints ms per action and ratios.
2. Replay: a paper-size mission (9 rooms, 26 furniture, 30 objects; 3 commands x 3 objects x
   navigate/pickup/place = 27 actions) read back and replayed to .rrd (goal <= 5 s), compared with
   rerun's own MCAP importer (``rerun mcap convert``) on the same file.

Run: .venv/bin/python benchmarks/bench_record.py [--actions 25] [--samples 2000]
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from interllm.core.actions import Action
from interllm.core.results import ActionResult, ManipulationTrial, Trajectory
from interllm.record import McapRecorder, NullRecorder, read_run, replay
from interllm.scene.graph import Door, Furniture, Room, SceneGraph, SceneObject, Wall
from interllm.scene.grid import rasterize

JOINTS = tuple(f"joint_{i}" for i in range(1, 8))


def paper_house(seed: int = 0) -> SceneGraph:
    """3 x 3 rooms of 4 m, doors between neighbours, 26 furniture and 30 objects."""
    rng = np.random.default_rng(seed)
    s = SceneGraph(id="bench_paper", seed=seed)
    for i in range(3):
        for j in range(3):
            rid = f"room_{i}{j}"
            x0, y0 = 4.0 * j, 4.0 * i
            s.rooms[rid] = Room(rid, "room", ((x0, y0), (x0 + 4, y0), (x0 + 4, y0 + 4), (x0, y0 + 4)))
    for i in range(3):
        for j in range(3):
            if j < 2:
                did = f"door_{i}{j}_e"
                s.doors[did] = Door(did, (f"room_{i}{j}", f"room_{i}{j + 1}"), (4.0 * (j + 1), 4.0 * i + 2), "y",
                                    1.0, float(rng.choice([1.0, 0.5])))
                s.walls[did + "_w"] = Wall(did + "_w", (4.0 * (j + 1), 4.0 * i), (4.0 * (j + 1), 4.0 * i + 1.5),
                                           0.1, 2.5)
            if i < 2:
                did = f"door_{i}{j}_n"
                s.doors[did] = Door(did, (f"room_{i}{j}", f"room_{i + 1}{j}"), (4.0 * j + 2, 4.0 * (i + 1)), "x",
                                    1.0, 1.0)
                s.walls[did + "_w"] = Wall(did + "_w", (4.0 * j, 4.0 * (i + 1)), (4.0 * j + 1.5, 4.0 * (i + 1)),
                                           0.1, 2.5)
    rooms = sorted(s.rooms)
    for k in range(26):
        rid = rooms[k % 9]
        x0, y0, _, _ = s.rooms[rid].bounds
        fid = f"furniture_{k}"
        s.furniture[fid] = Furniture(fid, "table", rid, (x0 + 1.0 + (k // 9) * 1.0, y0 + 0.8), (0.8, 0.6, 0.75))
    for k in range(30):
        f = s.furniture[f"furniture_{k % 26}"]
        oid = f"object_{k}"
        s.objects[oid] = SceneObject(oid, "cup", f.id, (f.center[0], f.center[1], 0.8), (0.08, 0.08, 0.1))
    return s


def synthetic_mission(n_actions: int, samples: int, seed: int = 0) -> list[tuple[ActionResult, dict]]:
    rng = np.random.default_rng(seed)
    out, clock = [], 0.0
    for k in range(n_actions):
        kind = ("navigate", "pickup", "place")[k % 3]
        dur = float(rng.uniform(5, 30))
        t = clock + np.linspace(0, dur, samples)
        xy = np.cumsum(rng.normal(0, 0.01, size=(samples, 2)), axis=0) + rng.uniform(1, 11, 2)
        traj = Trajectory(t, np.c_[xy, np.linspace(0, 3, samples)], rng.uniform(-2, 2, (samples, len(JOINTS))),
                          JOINTS)
        if kind == "navigate":
            r = ActionResult(Action("navigate", "furniture_1", room="room_00"), True, 30.0, dur, clock,
                             distance=5.0, presumed_path=xy[::10], driven_path=xy[::5], trajectory=traj)
        else:
            trials = [ManipulationTrial((1.0, 2.0, 0.5), bool(i % 2), 3.0) for i in range(5)]
            r = ActionResult(Action(kind, "furniture_1", obj="object_1"), True, 43.0, dur, clock,
                             success_rate=0.4, trials=trials, trajectory=traj)
        out.append((r, {"planner": "inter_llm", "command": f"c{k // 9}"}))
        clock += dur
    return out


def log_mission(rec, acts) -> None:
    for r, ctx in acts:
        rec.event("/planner/candidates", r.t_start, {"candidates": [[str(r.action)]] * 3})
        rec.event("/planner/estimates", r.t_start, {"nav": [10.0, 12.0, 9.5], "man": [5, 10, 20]})
        rec.log(r.t_start, "info", f"executing {r.action}")
        rec.action(r, ctx)


class JsonlRecorder:
    """The obvious alternative: one JSON line per action with its trajectory as lists."""

    def __init__(self, path: Path) -> None:
        self.f = open(path, "w")

    def event(self, topic, t, payload):
        self.f.write(json.dumps({"topic": topic, "t": t, "payload": payload}) + "\n")

    def log(self, t, level, message):
        self.f.write(json.dumps({"t": t, "level": level, "message": message}) + "\n")

    def action(self, r, ctx):
        tr = r.trajectory
        self.f.write(json.dumps({**r.to_record(), "context": ctx, "trajectory": {
            "t": tr.t.tolist(), "base": tr.base.tolist(), "joints": tr.joints.tolist()}}) + "\n")
        self.f.flush()

    def close(self):
        self.f.close()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--actions", type=int, default=25)
    ap.add_argument("--samples", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="bench_record_"))
    scene = paper_house()
    grids = {"presumed": rasterize(scene, 0.05, 0.25, "presumed"), "true": rasterize(scene, 0.05, 0.25, "true")}
    acts = synthetic_mission(a.actions, a.samples)
    print(f"scene: {len(scene.rooms)} rooms, {len(scene.furniture)} furniture, {len(scene.objects)} objects; "
          f"mission: {a.actions} actions x {a.samples} samples, {len(JOINTS)} arm joints")

    def best(fn):
        ts = []
        for _ in range(a.repeats):
            t0 = time.perf_counter()
            fn()
            ts.append(time.perf_counter() - t0)
        return min(ts)

    t_null = best(lambda: log_mission(NullRecorder(), acts))

    def mcap():
        with McapRecorder(tmp / "bench.mcap", scene, {"seed": 0}, grids=grids, joint_names=JOINTS) as rec:
            log_mission(rec, acts)

    def jsonl():
        rec = JsonlRecorder(tmp / "bench.jsonl")
        log_mission(rec, acts)
        rec.close()

    t_mcap = best(mcap)
    t_jsonl = best(jsonl)
    n = a.actions
    size_mcap = (tmp / "bench.mcap").stat().st_size
    size_jsonl = (tmp / "bench.jsonl").stat().st_size
    print(f"\n[1] logging (best of {a.repeats})")
    print(f"  NullRecorder      {1e3 * t_null / n:8.3f} ms/action")
    print(f"  McapRecorder      {1e3 * t_mcap / n:8.3f} ms/action  overhead vs null "
          f"{1e3 * (t_mcap - t_null) / n:.2f} ms/action; {size_mcap / 1e6:.2f} MB "
          f"(incl. scene + 2 grids at t=0)")
    print(f"  JSON lines        {1e3 * t_jsonl / n:8.3f} ms/action; {size_jsonl / 1e6:.2f} MB")
    print(f"  ratio mcap / jsonl time {t_mcap / t_jsonl:.2f}, size {size_mcap / size_jsonl:.2f}")

    paper = synthetic_mission(27, a.samples, seed=1)
    with McapRecorder(tmp / "paper.mcap", scene, {"seed": 0}, grids=grids, joint_names=JOINTS) as rec:
        log_mission(rec, paper)
    t0 = time.perf_counter()
    run = read_run(tmp / "paper.mcap")
    t_read = time.perf_counter() - t0
    t0 = time.perf_counter()
    replay(tmp / "paper.mcap", save=str(tmp / "paper.rrd"))
    t_replay = time.perf_counter() - t0
    print(f"\n[2] paper-size mission (27 actions x {a.samples} samples, {sum(run.counts.values())} messages, "
          f"{(tmp / 'paper.mcap').stat().st_size / 1e6:.2f} MB)")
    print(f"  read_run               {t_read:6.2f} s")
    print(f"  replay -> .rrd (total) {t_replay:6.2f} s   goal <= 5 s: {'OK' if t_replay <= 5 else 'MISSED'}; "
          f".rrd {(tmp / 'paper.rrd').stat().st_size / 1e6:.2f} MB")
    cli = Path(sys.executable).with_name("rerun")
    if cli.exists():
        t0 = time.perf_counter()
        p = subprocess.run([str(cli), "mcap", "convert", str(tmp / "paper.mcap"), "-o", str(tmp / "native.rrd")],
                           capture_output=True, text=True, env={"CI": "1", "PATH": "/usr/bin:/bin"})
        t_native = time.perf_counter() - t0
        if p.returncode == 0:
            print(f"  rerun mcap convert     {t_native:6.2f} s   (generic import, no semantic types); "
                  f"ratio ours / native {t_replay / t_native:.2f}")
        else:
            print(f"  rerun mcap convert failed: {p.stderr.strip()[:200]}")
    shutil.rmtree(tmp)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
