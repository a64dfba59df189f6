"""Do the initial candidates pick objects that satisfy the command? (embedded model, real stage)

    .venv/bin/python benchmarks/bench_candidates.py                   # the default experiment
    .venv/bin/python benchmarks/bench_candidates.py experiment=quick  # any Hydra overrides

Runs the scenes and candidates stages into a temporary folder (empty LLM cache, so the model
answers) and prints, per command, the share of picked-up objects whose category satisfies the
command's ground truth, beside the rate of a uniform random choice among the scene's objects,
and their ratio (goal: >= 3x overall).
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import collections
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from _usage import overrides  # noqa: E402  (benchmarks/_usage.py, beside this script)
from omegaconf import OmegaConf  # noqa: E402

from interllm.scene import load_missions  # noqa: E402
from interllm.scene.graph import SceneGraph  # noqa: E402
from interllm.stages.candidates import run_candidates  # noqa: E402
from interllm.stages.scenes import run_scenes  # noqa: E402
from pipeline._hydra import compose  # noqa: E402


def main(argv: list[str]) -> None:
    cfg = OmegaConf.to_object(compose(overrides(argv, __doc__)))
    # every command's candidates from the mission's start state (the stage makes only the first
    # command's by default: later commands are proposed when they run), so each command is scored
    cfg.planner.fair_baselines = False
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        cfg.llm.cache_dir = str(out / "cache")
        run_scenes(cfg, out / "scenes")
        t = time.perf_counter()
        run_candidates(cfg, out / "scenes", out / "candidates")
        took = time.perf_counter() - t
        hit, tot, rnd = collections.Counter(), collections.Counter(), collections.defaultdict(list)
        for sd in sorted(p for p in (out / "scenes").iterdir() if p.is_dir()):
            scene = SceneGraph.from_json((sd / "scene.json").read_text())
            cands = json.loads((out / "candidates" / f"{sd.name}.json").read_text())
            for m in load_missions(sd / "missions.json"):
                for c in m.commands:
                    valid = sum(o.category in c.goal.categories for o in scene.objects.values())
                    rnd[c.id].append(valid / len(scene.objects))
                    for plan in cands[m.id][c.id]:
                        for a in plan:
                            if a["action"] == "pickup":
                                tot[c.id] += 1
                                hit[c.id] += scene.objects[a["object"]].category in c.goal.categories
    print(f"candidates stage: {took:.1f} s (cold cache)")
    print(f"{'command':<14}{'picked right':>14}{'uniform random':>16}{'ratio':>8}")
    for k in sorted(tot):
        r = float(np.mean(rnd[k]))
        print(f"{k:<14}{hit[k] / tot[k]:>14.2f}{r:>16.2f}{hit[k] / tot[k] / r:>8.1f}")
    h, n = sum(hit.values()), sum(tot.values())
    r = float(np.mean([x for v in rnd.values() for x in v]))
    print(f"{'all':<14}{h / n:>14.2f}{r:>16.2f}{h / n / r:>8.1f}")


if __name__ == "__main__":
    main(sys.argv[1:])
