"""The robots of ``sim/robot=`` side by side: what each can pick up and how long the measurement takes.

    .venv/bin/python benchmarks/bench_robots.py [--seeds 3]

On the ProcTHOR-format test houses laid out like real ones (``tests/procthor_realistic.py``) it
runs ``interllm scene reach``'s measurement for every robot and prints, per robot: objects on open
surfaces picked up (share), the causes of the rest, the simulated mean pickup time [s] of the
pickable ones, and the wall time per object [ms] with its ratio to the generic robot's (the
machines are shared: compare the ratios). The floor of the wall time is N_l IK solves per object
(two solves a trial, each at most ``sim.ik_max_iters`` QP steps).
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import argparse
import json
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from procthor_realistic import realistic_house  # noqa: E402

from interllm.config import ROBOTS, SimConfig  # noqa: E402
from interllm.core.actions import Action  # noqa: E402
from interllm.overrides import compose_config  # noqa: E402
from interllm.scene.importer import import_procthor  # noqa: E402
from interllm.sim.reach_report import pickup_cause  # noqa: E402
from interllm.sim.world import World  # noqa: E402


def measure(robot: str, scenes) -> dict:
    cfg = SimConfig(**compose_config([f"sim/robot={robot}"])["sim"])
    causes: Counter = Counter()
    picked = total = 0
    times = []
    t0 = time.perf_counter()
    for scene in scenes:
        world = World(scene, cfg)
        for oid in sorted(scene.objects):
            o = scene.objects[oid]
            try:
                res = world.measure_manipulation(Action("pickup", o.furniture, obj=oid))
            except ValueError:
                res = None
            cause = pickup_cause(cfg, scene, oid, res)
            if o.placement == "inside":
                continue
            total += 1
            if cause:
                causes[cause] += 1
            else:
                picked += 1
                times.append(res.time)
    wall = time.perf_counter() - t0
    return {"picked": picked, "total": total, "causes": dict(causes),
            "t_man": sum(times) / max(len(times), 1), "ms_per_object": 1000 * wall / max(total, 1)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=3)
    args = ap.parse_args()
    scenes = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.seeds):
            path = Path(tmp) / f"house_{seed}.json"
            path.write_text(json.dumps(realistic_house(seed)))
            scenes.append(import_procthor(path))
    rows = {r: measure(r, scenes) for r in ROBOTS}
    base = rows["generic"]["ms_per_object"]
    print(f"{'robot':<14} {'open-surface objects picked up':<32} {'t_man [s]':>9} {'wall [ms/object]':>17} "
          f"{'ratio':>6}  causes of the rest")
    for r, row in rows.items():
        share = f"{row['picked']}/{row['total']} ({100 * row['picked'] / max(row['total'], 1):.0f}%)"
        causes = ", ".join(f"{k} {v}" for k, v in sorted(row["causes"].items(), key=lambda kv: -kv[1]))
        print(f"{r:<14} {share:<32} {row['t_man']:>9.1f} {row['ms_per_object']:>17.0f} "
              f"{row['ms_per_object'] / base:>6.2f}  {causes}")


if __name__ == "__main__":
    main()
