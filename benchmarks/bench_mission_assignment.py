"""The ``optimal`` reference's mission-level assignment on the mechanism experiment's 10-command
missions: the conflict-based search (``interllm.planning.assignment``) against the obvious exact
alternative it replaced, a dynamic programme whose state carries the objects taken so far.

    .venv/bin/python benchmarks/bench_mission_assignment.py [--scenes 2] [--limit 60]

For the first mission of the first ``--scenes`` houses of the frozen benchmark
``data/benchmarks/mechanism-v1``, builds the world, lets ``optimal`` measure its options for the
first command (MuJoCo, about 30 s per house) and captures the assignment problem it solves: 10
commands of 3 slots whose categories overlap (cellphone, tablet, book, towel, headphones...). Then
solves its first k commands, k = 3, 5, 7, 10, with both methods and prints per k the CPU seconds
(``time.process_time``: the machine is shared), the search's nodes, the share of its time spent
building each command's plans (Held-Karp per start location, the part both methods pay), and
whether both found the same deliveries and cost. The alternative is stopped after ``--limit`` CPU
seconds (SIGPROF). The floor of the search is that plan building: a search expanding a single
node costs no less.
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import argparse
import math
import signal
import time
from pathlib import Path

import interllm.planners.optimal as optimal_module
from interllm.config import from_dict
from interllm.overrides import compose_config
from interllm.planners.context import PlannerContext
from interllm.planning import assignment
from interllm.planning.assignment import CommandSlots, MissionPlan
from interllm.planning.memory import KnownCosts
from interllm.record.api import NullRecorder
from interllm.sim.world import World
from interllm.stages.inputs import load_scene_and_missions, scene_ids

BENCHMARK = Path(__file__).resolve().parent.parent / "data" / "benchmarks" / "mechanism-v1"
PREFIXES = (3, 5, 7, 10)


class Stopped(Exception):
    """The alternative ran out of its CPU seconds."""


def state_space_dp(start: str, commands: list[CommandSlots], nav) -> MissionPlan:
    """The alternative: best(i, loc, used) = the best over command i's plans p from loc avoiding
    ``used`` of (|p|, cost(p)) + best(i + 1, end(p), used ∪ objects(p)), with ``used`` kept to the
    objects a later command can use. Exact; its states multiply with every object that several
    commands want."""
    by_obj = [assignment._options_by_object(c.options) for c in commands]
    later = [frozenset()] * (len(commands) + 1)
    for i in range(len(commands) - 1, -1, -1):
        later[i] = later[i + 1] | frozenset(by_obj[i])
    plans: dict = {}
    memo: dict = {}

    def best(i: int, loc: str, used: frozenset) -> tuple:
        if i == len(commands):
            return 0, 0.0, ()
        if (i, loc, used) not in memo:
            if (i, loc) not in plans:
                plans[(i, loc)] = assignment._command_plans(loc, by_obj[i], commands[i].n, nav)
            outcomes: dict = {}  # the cheapest plan per (end, objects later commands lose, deliveries)
            for objs, cost, seq in plans[(i, loc)]:
                if not objs & used:
                    key = (seq[-1].target if seq else loc, (used | objs) & later[i + 1], len(seq))
                    if key not in outcomes or cost < outcomes[key][0]:
                        outcomes[key] = (cost, seq)
            found = (-1, math.inf, ())
            for (end, nxt, _), (cost, seq) in outcomes.items():
                rest = best(i + 1, end, nxt)
                cand = (len(seq) + rest[0], cost + rest[1], (seq,) + rest[2])
                if cand[0] > found[0] or (cand[0] == found[0] and cand[1] < found[1]):
                    found = cand
            memo[(i, loc, used)] = found
        return memo[(i, loc, used)]

    n, cost, chosen = best(0, start, frozenset())
    return MissionPlan(chosen, n, cost)


def first_problem(cfg, sid: str) -> tuple[str, list[CommandSlots], object]:
    """The assignment ``optimal`` solves at the first command of ``sid``'s first mission."""
    scene, missions = load_scene_and_missions(BENCHMARK, sid, cfg)
    world = World(scene, cfg.sim, cfg.scene.grid_resolution)
    world.reset(missions[0])
    ctx = PlannerContext(world=world, proposer=None, memory=KnownCosts(), recorder=NullRecorder(),  # type: ignore[arg-type]
                         cfg=cfg.planner, mission=missions[0], planner="optimal", base_speed=cfg.sim.base_speed)
    captured: list = []

    def capture(start, slots, nav):
        captured.append((start, list(slots), nav))
        raise Stopped  # the problem is all this benchmark needs

    solve, optimal_module.cheapest_mission = optimal_module.cheapest_mission, capture
    try:
        optimal_module.OptimalPlanner().search(missions[0].commands[0], ctx)
    except Stopped:
        pass
    finally:
        optimal_module.cheapest_mission = solve
    return captured[0]


class CountingSearch(assignment._MissionSearch):
    """The search, counting its nodes and the CPU seconds spent building command plans."""

    def __init__(self, *args) -> None:
        super().__init__(*args)
        self.nodes, self.building = 0, 0.0

    def ranked(self, i, loc):
        t = time.process_time()
        out = super().ranked(i, loc)
        self.building += time.process_time() - t
        return out

    def expand(self, forbidden, plans):
        self.nodes += 1
        return super().expand(forbidden, plans)


def timed_dp(start, slots, nav, limit: float) -> tuple[float, MissionPlan | None]:
    def stop(signum, frame):
        raise Stopped
    previous = signal.signal(signal.SIGPROF, stop)
    signal.setitimer(signal.ITIMER_PROF, limit)
    t = time.process_time()
    try:
        plan = state_space_dp(start, slots, nav)
        return time.process_time() - t, plan
    except Stopped:
        return time.process_time() - t, None
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.signal(signal.SIGPROF, previous)


def main(n_scenes: int, limit: float) -> None:
    cfg = from_dict(compose_config(["experiment=mechanism"]))
    print(f"{'house':<14} {'k':>2} {'slots':>5} {'options':>7} | {'search [s]':>10} {'nodes':>5} {'building':>8} | "
          f"{'state-space DP [s]':>18} | same")
    for sid in scene_ids(BENCHMARK)[:n_scenes]:
        start, slots, nav = first_problem(cfg, sid)
        for k in PREFIXES:
            part = slots[:k]
            t = time.process_time()
            search = CountingSearch(start, part, nav)
            found = search.run()
            took = time.process_time() - t
            dp_took, dp = timed_dp(start, part, nav, limit)
            total = 0.0
            for plan in reversed(found or []):
                total = plan[1] + total
            same = "-" if dp is None or found is None else ("yes" if (dp.deliveries, dp.cost) == (sum(len(p[2]) for p in found), total) else
                                           f"NO: {dp.deliveries}, {dp.cost:.3f}")
            dp_text = f"> {limit:.0f} (stopped)" if dp is None else f"{dp_took:.2f}"
            print(f"{sid:<14} {k:>2} {sum(s.n for s in part):>5} {sum(len(s.options) for s in part):>7} | "
                  f"{took:>10.2f} {search.nodes:>5} {search.building / max(took, 1e-9):>7.0%} | {dp_text:>18} | {same}",
                  flush=True)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", type=int, default=2, help="houses of mechanism-v1 to measure (default 2)")
    ap.add_argument("--limit", type=float, default=60.0, help="CPU seconds the state-space DP gets per problem")
    args = ap.parse_args()
    main(args.scenes, args.limit)
