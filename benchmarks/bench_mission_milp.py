"""The ``optimal`` reference's mission assignment where its conflict-based search does not close:
the search alone (no budget) against the integer programme it hands over to
(``interllm.planning.mission_milp``), on the problem captured from mechanism-v2 medium_s0007 m000
(``tests/golden/mission_assignment_medium_s0007_m000.json``: 10 commands of 3 slots).

    .venv/bin/python benchmarks/bench_mission_milp.py [--prefixes 5 7 8 10] [--nodes 20000]

For each prefix of k commands prints the search's CPU seconds (``time.process_time``: the machine
is shared), its nodes and the cost it closes at (or "not closed" after ``--nodes``); then
HiGHS's CPU seconds on the same plans, its cost and deliveries, and the arcs (plans) of its
programme. The floor of both is building the plans (Held-Karp per command and start location),
printed as its own column.
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import argparse
import json
import time
from pathlib import Path

from interllm.planning import assignment, mission_milp
from interllm.planning.assignment import CommandSlots, Delivery

PROBLEM = Path(__file__).resolve().parent.parent / "tests" / "golden" / "mission_assignment_medium_s0007_m000.json"


def load(k: int):
    data = json.loads(PROBLEM.read_text())
    table = {(a, b): v for a, b, v in data["nav"]}
    commands = [CommandSlots(c["n"], tuple(Delivery(*d) for d in c["options"])) for c in data["commands"][:k]]
    return data["start"], commands, lambda a, b: table[(a, b)]


class CountingSearch(assignment._MissionSearch):
    """The search, counting the nodes it expands."""

    nodes = 0

    def expand(self, forbidden, plans):
        self.nodes += 1
        return super().expand(forbidden, plans)


def main(prefixes: list[int], nodes: int) -> None:
    print(f"{'k':>2} {'plans [s]':>9} | {'search [s]':>10} {'nodes':>6} {'result':>22} | {'HiGHS [s]':>9} "
          f"{'arcs':>6} {'cost':>10} {'deliveries':>10}")
    for k in prefixes:
        start, commands, nav = load(k)
        t = time.process_time()
        search = CountingSearch(start, commands, nav, nodes)
        found = search.run()
        took = time.process_time() - t
        result = f"cost {sum(p[1] for p in found):.2f}" if found is not None else "not closed"
        t = time.process_time()
        fresh = assignment._MissionSearch(start, commands, nav)
        arcs = mission_milp.layered_arcs(start, k, fresh.ranked)
        building = time.process_time() - t
        solved = mission_milp.solve_mission(start, k, fresh.ranked, fresh.max_deliveries({}))
        highs = time.process_time() - t - building
        print(f"{k:>2} {building:>9.1f} | {took:>10.1f} {search.nodes:>6} {result:>22} | {highs:>9.1f} {len(arcs):>6} "
              f"{sum(p[1] for p in solved.plans):>10.2f} {sum(len(p[2]) for p in solved.plans):>10}"
              + ("" if solved.optimal else " (not proved)"), flush=True)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--prefixes", type=int, nargs="+", default=[5, 7, 8, 10], help="commands of the problem to solve")
    ap.add_argument("--nodes", type=int, default=20_000, help="nodes the search alone may expand")
    args = ap.parse_args()
    main(args.prefixes, args.nodes)
