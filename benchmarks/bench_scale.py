"""Scale, measured: houses of 9, 30, 100 and 300 rooms, the hierarchical prompts beside the flat ones,
in one run, in score mode (the embedded model) or in generate mode (a real OpenAI-compatible server).

    .venv/bin/python benchmarks/bench_scale.py [--rooms 9,30,100,300] [--flat-max-rooms 100]
    .venv/bin/python benchmarks/bench_scale.py --mode generate [--rooms 9,33,110,330]

Generate mode (the paper's: the model writes the plans) starts llama-cpp-python's server on the
embedded GGUF on 127.0.0.1 (as the tests do; n_ctx 8192) and, per house and setting, with a fresh
LLM cache, proposes the M plans of the first mission's first command and repairs each with the
feasibility checker's feedback within ``planner.max_regenerations``, as a planner does before
executing. Printed: requests and prompt tokens per command by phase (the server's token counts),
the share of selections widened, and the wall time. ``flat`` (llm.room_beam = 0) sends the whole
scene graph; where one of its requests would not fit the server's context, its tokens are counted
with the model's tokenizer and nothing is sent. ``hierarchical``: the defaults (a room selection,
then plans over the chosen rooms; ``planning/expansion.py``).

Score mode:

Per house size (furniture and objects grow with the rooms at the density of the ``huge`` preset;
the paper's 9 rooms keep the paper's 26 furniture and 30 objects) and per setting, in a fresh
process each (so the peak memory is that run's), with a cold LLM cache:

- scene generation time [s];
- prompt tokens per command (everything the embedded model evaluates: prompts, continuations,
  calibration prompts) and LLM wall time per command [s];
- planning + simulation time per command [s]: Inter-LLM on the mission's first command in MuJoCo
  (world build included), less the LLM time;
- peak resident memory [MB].

Settings: ``flat``: every object scored one by one (llm.room_beam = furniture_beam = 0, one
continuation per decode); ``now``: the hierarchical prompts and batched scoring (the defaults).
The flat setting is skipped above ``--flat-max-rooms`` (it scores every object of the house).
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def house(rooms: int):
    from interllm.scene.catalog import scene_config

    if rooms <= 9:
        return replace(scene_config("paper"), n_rooms=rooms)
    return replace(scene_config("huge"), n_rooms=rooms, n_furniture=round(rooms * 360 / 110),
                   n_objects=round(rooms * 2000 / 110))


def measure(rooms: int, setting: str) -> dict:
    """One (size, setting) in this process; returns the figures."""
    from interllm.config import ExperimentConfig
    from interllm.llm import embedded, make_client
    from interllm.llm.types import ScoreRequest
    from interllm.planners.candidates import generate_initial_candidates
    from interllm.planners.runner import run_mission
    from interllm.scene.generator import generate_scene
    from interllm.scene.grid import rasterize
    from interllm.scene.missions import generate_missions
    from interllm.sim.world import World

    cfg = ExperimentConfig()
    if setting == "before":
        embedded.SCORE_SEQS = 1
        cfg.llm = replace(cfg.llm, room_beam=0, furniture_beam=0)
    cfg.planner.names = ["inter_llm"]
    t0 = time.perf_counter()
    scene = generate_scene(house(rooms), 0, robot_radius=cfg.sim.robot_radius)
    t_gen = time.perf_counter() - t0
    mission = generate_missions(scene, cfg.mission, cfg.sim.robot_radius, cfg.scene.grid_resolution,
                                footprint_radius=cfg.sim.footprint_radius)[0]
    mission = replace(mission, commands=mission.commands[:1])
    with tempfile.TemporaryDirectory() as tmp:
        cfg.llm = replace(cfg.llm, cache_dir=tmp)
        client = make_client(cfg.llm)
        client.score(ScoreRequest("warm-up", "Load the model.", (" ok",)))  # the model load is not timed
        tokens0, llm0 = client.stats.tokens_in, client.stats.backend_seconds
        cands = generate_initial_candidates(scene, mission, client, cfg)  # the candidates stage's request
        grids = {k: rasterize(scene, cfg.scene.grid_resolution, cfg.sim.robot_radius, k) for k in ("presumed", "true")}
        s = client.stats
        llm_s = s.backend_seconds - llm0
        t1 = time.perf_counter()
        world = World(scene, cfg.sim, cfg.scene.grid_resolution, grids)
        record = run_mission("inter_llm", world, mission, cands, client, cfg)
        t_run = time.perf_counter() - t1 - (s.backend_seconds - llm0 - llm_s)
        client.close()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return {"rooms": len(scene.rooms), "objects": len(scene.objects), "generate_s": t_gen,
            "tokens": s.tokens_in - tokens0, "llm_s": s.backend_seconds - llm0, "sim_s": t_run,
            "calls": s.calls, "actions": sum(len(c.actions) for c in record.commands),
            "sim_time": record.sim_time, "peak_mb": peak}


N_CTX = 8192  # the server's context [tokens]


def generate_one(rooms: int, setting: str, base_url: str, tokenizer) -> dict:
    """One (size, setting) in generate mode against the server at ``base_url``: the figures of the
    first command's proposal and repairs (module doc)."""
    from interllm.config import ExperimentConfig
    from interllm.llm import make_client
    from interllm.llm.calllog import read_records
    from interllm.metrics.llm_usage import planner_usage
    from interllm.planners.candidates import start_state
    from interllm.planning.expansion import flat_view
    from interllm.planning.feasibility import check_plan
    from interllm.planning.proposers import make_proposer
    from interllm.planning.request import PlanRequest
    from interllm.scene.generator import generate_scene
    from interllm.scene.missions import generate_missions

    cfg = ExperimentConfig()
    scene = generate_scene(house(rooms), 0, robot_radius=cfg.sim.robot_radius)
    mission = generate_missions(scene, cfg.mission, cfg.sim.robot_radius, cfg.scene.grid_resolution,
                                footprint_radius=cfg.sim.footprint_radius)[0]
    command, state, M = mission.commands[0], start_state(scene, mission), cfg.planner.M
    base = {"rooms": len(scene.rooms), "objects": len(scene.objects), "setting": setting}
    if setting == "flat":
        prompt = len(tokenizer.tokenize(flat_view(scene).text.encode(), add_bos=True, special=True))
        if prompt + cfg.llm.max_tokens > N_CTX:
            return {**base, "over_context": True, "requests": M, "tokens": M * prompt}
    with tempfile.TemporaryDirectory() as tmp:
        llm = replace(cfg.llm, backend="openai", model="gemma3-270m", base_url=base_url, proposal_mode="generate",
                      cost_inference_mode="generate", max_tokens=256, cache_dir=tmp, timeout_s=600,
                      room_beam=0 if setting == "flat" else cfg.llm.room_beam)
        client = make_client(llm, call_log_path=Path(tmp) / "calls.jsonl")
        proposer, ctx = make_proposer(client, llm).plans, (("planner", "bench"), ("command", command.id))
        req, t0 = PlanRequest(scene, state, command, int(command.goal.n_objects), context=ctx), time.perf_counter()
        for j, plan in enumerate(proposer.propose(req, n_plans=M, seed=0)):
            for rnd in range(cfg.planner.max_regenerations):
                report = check_plan(plan, scene, state)
                if report.valid:
                    break
                plan = proposer.repair(req, plan, report, round_index=rnd, candidate=j)
        wall = time.perf_counter() - t0
        client.close()
        u = planner_usage(read_records(Path(tmp) / "calls.jsonl"))["bench"]
    return {**base, "over_context": False, "requests": u["requests"], "tokens": u["tokens_in"], "wall_s": wall,
            "selection": u["selection_requests"], "repairs": u["phases"].get("repair", {}).get("requests", 0),
            "widened": u["room_selection"]["widened"]}


def main_generate(rooms_list: list[int]) -> int:
    import llama_cpp

    sys.path.insert(0, str(ROOT / "tests"))
    from helpers.openai_server import llama_server

    from interllm.llm.model_files import resolve_model_path

    model = str(resolve_model_path(""))
    tokenizer = llama_cpp.Llama(model, vocab_only=True, verbose=False)
    print(f"{'rooms':>6}{'objects':>8}{'setting':>14}{'requests/cmd':>14}{'of which rooms':>16}{'repairs':>9}"
          f"{'tokens/cmd':>12}{'widened':>9}{'wall s/cmd':>12}", flush=True)
    with llama_server(model, n_ctx=N_CTX) as base_url:
        for rooms in rooms_list:
            for setting in ("flat", "hierarchical"):
                r = generate_one(rooms, setting, base_url, tokenizer)
                if r["over_context"]:
                    print(f"{r['rooms']:>6}{r['objects']:>8}{setting:>14}{r['requests']:>14}{'':>16}{'':>9}"
                          f"{r['tokens']:>12,}  not sent: a request is over n_ctx {N_CTX}", flush=True)
                    continue
                print(f"{r['rooms']:>6}{r['objects']:>8}{setting:>14}{r['requests']:>14}{r['selection']:>16}"
                      f"{r['repairs']:>9}{r['tokens']:>12,}{r['widened']:>9}{r['wall_s']:>12.1f}", flush=True)
    tokenizer.close()
    print("per command: the first command of the first mission, M = 3 plans, each repaired at most "
          "planner.max_regenerations times; tokens: prompt tokens the server evaluated")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mode", choices=("score", "generate"), default="score")
    ap.add_argument("--rooms", default=None, help="house sizes [rooms] (score: 9,30,100,300; generate: 9,33,110,330)")
    ap.add_argument("--flat-max-rooms", type=int, default=100)
    ap.add_argument("--one", nargs=2, metavar=("ROOMS", "SETTING"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.mode == "generate":
        return main_generate([int(r) for r in (args.rooms or "9,33,110,330").split(",")])
    args.rooms = args.rooms or "9,30,100,300"
    if args.one:
        print(json.dumps(measure(int(args.one[0]), args.one[1])))
        return 0
    print(f"{'rooms':>6}{'objects':>8}{'setting':>12}{'gen [s]':>9}{'tokens/cmd':>12}{'LLM s/cmd':>11}"
          f"{'plan+sim s/cmd':>16}{'actions':>9}{'sim time [s]':>13}{'peak MB':>9}", flush=True)
    for rooms in (int(r) for r in args.rooms.split(",")):
        for setting in ("before", "now"):
            if setting == "before" and rooms > args.flat_max_rooms:
                print(f"{rooms:>6}{'':>8}{'flat':>12}  skipped (--flat-max-rooms {args.flat_max_rooms})")
                continue
            p = subprocess.run([sys.executable, __file__, "--one", str(rooms), setting], capture_output=True,
                               text=True, cwd=ROOT, timeout=3600)
            if p.returncode != 0:
                print(f"{rooms:>6} {setting}: failed: {p.stderr.strip().splitlines()[-1:]}", flush=True)
                continue
            r = json.loads(p.stdout.strip().splitlines()[-1])
            name = "flat" if setting == "before" else "now"
            print(f"{r['rooms']:>6}{r['objects']:>8}{name:>12}{r['generate_s']:>9.2f}{r['tokens']:>12.0f}"
                  f"{r['llm_s']:>11.2f}{r['sim_s']:>16.2f}{r['actions']:>9}{r['sim_time']:>13.1f}{r['peak_mb']:>9.0f}",
                  flush=True)
    print("per command: one mission of the first command, Inter-LLM: the candidates stage's scoring of the command,"
          " then its execution (no cost inference on a first command)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
