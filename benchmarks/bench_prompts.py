"""Hierarchical against flat score-mode prompts, and batched against one-at-a-time scoring, on the
real embedded model with a cold cache, in one run.

    .venv/bin/python benchmarks/bench_prompts.py [--sizes paper,large] [--commands 6] [--scenes-seed 0]

For each house size and each setting it scores the first ``--commands`` distinct commands of the
size's missions (``planning.scoring.score_command``: categories, rooms, instances, targets), proposes
M = 3 candidates at the default temperature, and prints per command: prompt tokens sent (prompt +
continuations + calibration), LLM wall seconds, and the relevance of the candidates (share of the
objects they take that the command asks for; the catalog's ground truth). Settings:

- ``flat, one at a time``: every object scored (llm.room_beam = furniture_beam = 0), one decode per
  continuation (the flat setting);
- ``flat, batched``: every object, continuations decoded together;
- ``hierarchical, batched``: the defaults (room_beam 3, furniture_beam 6).
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import argparse
import tempfile
import time
from dataclasses import replace

import numpy as np

from interllm.config import ExperimentConfig
from interllm.core.actions import State
from interllm.llm import embedded, make_client
from interllm.llm.types import ScoreRequest
from interllm.planning import scoring
from interllm.planning.request import PlanRequest
from interllm.scene.catalog import scene_config
from interllm.scene.generator import generate_scene
from interllm.scene.missions import generate_missions

SETTINGS = (("flat, one at a time", 0, 0, 1), ("flat, batched", 0, 0, embedded.SCORE_SEQS),
            ("hierarchical, batched", 3, 6, embedded.SCORE_SEQS))


def commands(size: str, n: int):
    cfg = ExperimentConfig()
    scene = generate_scene(scene_config(size), 0)
    seen, out = set(), []
    for m in generate_missions(scene, cfg.mission):
        for c in m.commands:
            if c.id not in seen and len(out) < n:
                seen.add(c.id)
                out.append((m, c))
    return scene, out


def run(size: str, n: int) -> None:
    scene, cmds = commands(size, n)
    print(f"== {size}: {len(scene.rooms)} rooms, {len(scene.furniture)} furniture, {len(scene.objects)} objects; "
          f"{len(cmds)} commands")
    print(f"{'setting':<24}{'tokens/command':>16}{'LLM s/command':>15}{'relevance':>11}")
    base = ExperimentConfig()
    for name, room_beam, furniture_beam, seqs in SETTINGS:
        embedded.SCORE_SEQS = seqs
        cfg = replace(base.llm, room_beam=room_beam, furniture_beam=furniture_beam, cache_mode="off")
        with tempfile.TemporaryDirectory() as tmp:
            client = make_client(replace(cfg, cache_dir=tmp))
            client.score(ScoreRequest("warm-up", "Load the model.", (" ok",)))  # not timed: the model load
            tokens, secs, rel = [], [], []
            for mission, cmd in cmds:
                before = client.stats.tokens_in
                t0 = time.perf_counter()
                scores = scoring.score_command(client, scene, cmd, cfg)
                secs.append(time.perf_counter() - t0)
                tokens.append(client.stats.tokens_in - before)
                state = State(mission.start_furniture, scene.furniture[mission.start_furniture].room, None)
                req = PlanRequest(scene, state, cmd, cmd.goal.n_objects)
                plans = scoring.propose_by_scores(scores, req, n_plans=3, temperature=cfg.plan_sampling_temperature,
                                                  seed=0)
                objs = [a.obj for p in plans for a in p if a.kind == "pickup"]
                rel.append(np.mean([scene.objects[o].category in cmd.goal.categories for o in objs]) if objs else 0.0)
            client.close()
        print(f"{name:<24}{np.mean(tokens):>16.0f}{np.mean(secs):>15.2f}{np.mean(rel):>11.2f}", flush=True)
    embedded.SCORE_SEQS = SETTINGS[-1][3]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="paper,large")
    ap.add_argument("--commands", type=int, default=6)
    args = ap.parse_args()
    for size in args.sizes.split(","):
        run(size, args.commands)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
