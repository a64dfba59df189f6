"""The mission assignment as an integer programme, for the missions the conflict-based search of
``planning.assignment`` does not close within its node budget.

The commands' plans form a layered graph: a node is (command i, the location it starts from), an
arc is one of command i's plans from there (``_command_plans``: the cheapest order per object set
and last target), leading to (i + 1, where the plan ends). A mission plan is a path from (0,
start) through every layer in which no object is on two arcs. With x_p in {0, 1} per arc:

    minimise   sum_p cost(p) x_p
    subject to one unit of flow out of (0, start), flow in = flow out at every other node,
               sum over the arcs taking object o of x_p <= 1, for every object o,
               sum_p |p| x_p = d,

solved by HiGHS (``scipy.optimize.milp``), deterministic for a given problem: no time limit, a
node limit, relative gap 0. ``d`` is the most deliveries a mission plan can make: the matching
bound first, one less while the programme is infeasible (a matched object can lie out of reach).
On medium_s0007's first search of mechanism-v2 (10 commands, 92,706 arcs) HiGHS needs about
70 CPU seconds, where the search had not closed after 20,000 nodes
(``benchmarks/bench_mission_milp.py``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

MILP_NODE_LIMIT = 20_000  # HiGHS branch-and-bound nodes at most: a bound, not a time, keeps it deterministic


@dataclass(frozen=True)
class Arc:
    command: int
    start: str  # where the command starts (the previous plan's end)
    end: str  # where its plan ends
    plan: tuple  # (objects, cost [cost units], deliveries): ``assignment.Plan``


@dataclass(frozen=True)
class MilpResult:
    plans: list  # per command, the chosen ``assignment.Plan``
    lower_bound: float  # [cost units] HiGHS's dual bound: the cost no mission plan of these deliveries is below
    optimal: bool  # HiGHS proved the plan the cheapest of its deliveries


def layered_arcs(start: str, n_commands: int, ranked) -> list[Arc]:
    """Every plan of every command from every location the previous command can end at.
    ranked(i, loc): command i's plans from loc grouped by end and size (``_MissionSearch.ranked``)."""
    arcs, frontier = [], [start]
    for i in range(n_commands):
        ends: dict[str, None] = {}
        for loc in frontier:
            for end, by_size in ranked(i, loc):
                arcs += [Arc(i, loc, end, plan) for plans in by_size for plan in plans]
                ends[end] = None
        frontier = list(ends)
    return arcs


def solve_mission(start: str, n_commands: int, ranked, most_deliveries: int,
                  node_limit: int = MILP_NODE_LIMIT) -> MilpResult:
    """The cheapest mission plan with the most deliveries (at most ``most_deliveries``)."""
    arcs = layered_arcs(start, n_commands, ranked)
    for d in range(most_deliveries, -1, -1):
        result = _solve_with_deliveries(start, n_commands, arcs, d, node_limit)
        if result is not None:
            return result
    raise AssertionError("unreachable: the empty plans make 0 deliveries")


def _solve_with_deliveries(start: str, n_commands: int, arcs: Sequence[Arc], d: int,
                           node_limit: int) -> MilpResult | None:
    from scipy.optimize import Bounds, LinearConstraint, milp  # lazy: only past the search budget
    from scipy.sparse import coo_matrix  # lazy: as above

    rows, cols, vals, node_row = [], [], [], {}

    def entry(row: int, col: int, value: float) -> None:
        rows.append(row)
        cols.append(col)
        vals.append(value)

    for j, arc in enumerate(arcs):  # flow: out minus in, per (command, start location)
        entry(node_row.setdefault((arc.command, arc.start), len(node_row)), j, 1.0)
        if arc.command + 1 < n_commands:
            entry(node_row.setdefault((arc.command + 1, arc.end), len(node_row)), j, -1.0)
    objects = {o: len(node_row) + k for k, o in enumerate(sorted({o for a in arcs for o in a.plan[0]}))}
    deliveries_row = len(node_row) + len(objects)
    for j, arc in enumerate(arcs):
        for o in sorted(arc.plan[0]):
            entry(objects[o], j, 1.0)
        if arc.plan[2]:
            entry(deliveries_row, j, float(len(arc.plan[2])))
    flow = np.zeros(len(node_row))
    flow[node_row[(0, start)]] = 1.0
    lo = np.concatenate([flow, np.full(len(objects), -np.inf), [d]])
    hi = np.concatenate([flow, np.ones(len(objects)), [d]])
    matrix = coo_matrix((vals, (rows, cols)), shape=(deliveries_row + 1, len(arcs))).tocsr()
    res = milp(np.array([a.plan[1] for a in arcs]), constraints=LinearConstraint(matrix, lo, hi),
               integrality=np.ones(len(arcs)), bounds=Bounds(0, 1),
               options={"node_limit": node_limit, "mip_rel_gap": 0.0, "presolve": True})
    if res.status == 2:  # infeasible: no mission plan makes d deliveries
        return None
    if res.x is None:
        raise RuntimeError(f"mission assignment: HiGHS found no mission plan of {d} deliveries within {node_limit} "
                           f"nodes ({res.message}); raise interllm.planning.mission_milp.MILP_NODE_LIMIT")
    return MilpResult(_path(start, n_commands, arcs, res.x), float(res.mip_dual_bound), res.status == 0)


def _path(start: str, n_commands: int, arcs: Sequence[Arc], x: np.ndarray) -> list:
    """The chosen plans, command by command, following the path from (0, start)."""
    chosen = {(a.command, a.start): a for a, v in zip(arcs, x, strict=True) if v > 0.5}
    plans, loc = [], start
    for i in range(n_commands):
        arc = chosen[(i, loc)]
        plans.append(arc.plan)
        loc = arc.end
    return plans
