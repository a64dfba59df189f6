"""Hand-made scene, actions and trajectories shared by the record tests (no tests here).

Also runnable as a script: ``python tests/helpers/recording.py OUT.mcap N_ACTIONS`` writes a
run action by action, printing "ACTION k" after each one is flushed (the SIGKILL test).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

from interllm.core.actions import Action
from interllm.core.results import ActionResult, ManipulationTrial, Trajectory
from interllm.record.recorder import McapRecorder
from interllm.scene.graph import Door, Furniture, Room, SceneGraph, SceneObject, Wall
from interllm.scene.grid import rasterize

JOINTS = ("shoulder", "elbow", "wrist")


def rerun_cli() -> str | None:
    """The rerun CLI of the venv running the tests (or on PATH)."""
    cand = Path(sys.executable).with_name("rerun")
    return str(cand) if cand.exists() else shutil.which("rerun")


def run_cli(*args: str) -> subprocess.CompletedProcess:
    import os

    return subprocess.run([rerun_cli(), *args], capture_output=True, text=True, timeout=120,
                          env={**os.environ, "CI": "1"})


def make_scene() -> SceneGraph:
    s = SceneGraph(id="tiny", seed=7)
    s.rooms["kitchen_1"] = Room("kitchen_1", "kitchen", ((0, 0), (4, 0), (4, 4), (0, 4)))
    s.rooms["bedroom_1"] = Room("bedroom_1", "bedroom", ((4, 0), (8, 0), (8, 4), (4, 4)))
    s.walls["wall_1"] = Wall("wall_1", (4, 0), (4, 1.5), 0.1, 2.5)
    s.walls["wall_2"] = Wall("wall_2", (4, 2.5), (4, 4), 0.1, 2.5)
    s.doors["door_1"] = Door("door_1", ("kitchen_1", "bedroom_1"), (4, 2), "y", 1.0, 0.5)
    s.doors["door_2"] = Door("door_2", ("kitchen_1", "bedroom_1"), (2, 4), "x", 1.0, 1.0)  # no leaf
    s.furniture["table_1"] = Furniture("table_1", "dining_table", "kitchen_1", (1.0, 1.0), (1.0, 0.8, 0.75))
    s.furniture["bed_1"] = Furniture("bed_1", "bed", "bedroom_1", (6.5, 3.0), (1.5, 1.8, 0.5))
    s.objects["apple_1"] = SceneObject("apple_1", "apple", "table_1", (1.0, 1.0, 0.79), (0.08, 0.08, 0.08))
    s.objects["book_1"] = SceneObject("book_1", "book", "bed_1", (6.4, 3.1, 0.52), (0.2, 0.15, 0.04),
                                      placement="deep")
    return s


def make_grids(scene: SceneGraph) -> dict:
    return {"presumed": rasterize(scene, 0.1, 0.25, "presumed"), "true": rasterize(scene, 0.1, 0.25, "true")}


def make_actions(n: int = 6, samples: int = 40) -> list[tuple[ActionResult, dict]]:
    """n actions cycling navigate / pickup / place, each with a trajectory of ``samples`` points."""
    out = []
    clock = 0.0
    rng = np.random.default_rng(3)
    for k in range(n):
        kind = ("navigate", "pickup", "place")[k % 3]
        dur = 4.0 + k
        t = clock + np.linspace(0.0, dur, samples)
        base = np.c_[np.linspace(1.0, 6.0, samples), np.linspace(1.5, 2.5, samples),
                     np.linspace(-3.0, 3.0, samples)]
        joints = rng.uniform(-1.5, 1.5, size=(samples, len(JOINTS)))
        traj = Trajectory(t=t, base=base, joints=joints, joint_names=JOINTS)
        if kind == "navigate":
            r = ActionResult(Action("navigate", "bed_1", room="bedroom_1"), success=k != 3, cost=25.5 + k,
                             time=dur, t_start=clock, collisions=k % 2, distance=5.25,
                             presumed_path=np.c_[np.linspace(1, 6, 7), np.linspace(1.5, 2.5, 7)],
                             driven_path=np.c_[np.linspace(1, 6, 9), np.linspace(1.5, 2.6, 9)] + 1e-3 * k,
                             reason="" if k != 3 else "navigate(bed_1): blocked at door door_1 after 2 collisions",
                             trajectory=traj)
        else:
            trials = [ManipulationTrial((1.5, 1.0 + 0.1 * i, 3.14159), success=i % 2 == 0, time=3.5 + i,
                                        reason="" if i % 2 == 0 else "ik_no_convergence", ik_error=0.01 * i)
                      for i in range(3)]
            r = ActionResult(Action(kind, "table_1", obj="apple_1"), success=True, cost=38.83333, time=dur,
                             t_start=clock, success_rate=2 / 3, trials=trials, trajectory=traj)
        out.append((r, {"planner": "inter_llm", "command": f"c{k // 3}", "step": k}))
        clock += dur
    return out


def write_run(path, n: int = 6, samples: int = 40, **kw) -> tuple[list, dict]:
    """Write a full run; returns (actions with contexts, what was logged besides actions)."""
    scene = make_scene()
    acts = make_actions(n, samples)
    meta = {"seed": 11, "git_commit": "abc123", "config": {"planner": {"M": 3}, "sim": {"gamma_nav": 10.0}},
            "packages": {"mcap": "1.6.0"}}
    events = []
    with McapRecorder(path, scene, meta, grids=make_grids(scene), joint_names=JOINTS, **kw) as rec:
        for r, ctx in acts:
            ev = ("/planner/candidates", r.t_start, {"candidates": [[str(r.action)]], "M": 3, "x": np.float64(1.5)})
            rec.event(*ev)
            events.append(ev)
            rec.log(r.t_start, "info", f"executing {r.action}")
            rec.action(r, ctx)
            rec.event("/planner/costs", r.t_start + r.time, {"cost": r.cost})
            events.append(("/planner/costs", r.t_start + r.time, {"cost": r.cost}))
    return acts, {"events": events, "meta": meta, "scene": scene}


if __name__ == "__main__":
    # python tests/helpers/recording.py OUT.mcap N_ACTIONS STOP_AFTER: after STOP_AFTER actions, log
    # a few events that stay in the unfinished chunk and block on stdin until killed.
    out, n, stop_after = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    scene = make_scene()
    rec = McapRecorder(out, scene, {"seed": 1}, grids=make_grids(scene), joint_names=JOINTS, chunk_size=4096)
    for k, (r, ctx) in enumerate(make_actions(n, samples=200)):
        rec.event("/planner/selected", r.t_start, {"k": k})
        rec.action(r, ctx)
        print(f"ACTION {k}", flush=True)
        if k + 1 == stop_after:
            rec.event("/planner/selected", r.t_start + r.time, {"unflushed": True})
            print("WAITING", flush=True)
            sys.stdin.readline()
    rec.close()
    print("CLOSED", flush=True)
