"""The cheapest assignment of objects to a mission's slots and targets, over given costs (what the
``optimal`` anchor computes from ground truth).

A delivery is (object, target): navigate to the object's furniture, pick it up, navigate to the
target, place it. From location ``loc`` it costs

    nav(loc, source) + pick + nav(source, target) + place.

A command's plan is an ordered list of deliveries of distinct objects, at most the command's ``n``;
it starts where the previous command's plan ended (the robot's start for the first command) and
ends at its last target. ``cheapest_mission`` picks one plan per command, no object in two
commands, with the most deliveries over the whole mission first and then the least summed cost.
It is exact over the costs it is given:

- Each command's plans come from a Held-Karp recursion, once per start location: for every (set
  of objects delivered, last target), only the cheapest order is kept.
- Without the rule "no object in two commands" the best mission plan is a dynamic programme over
  (command, location): the best combination of plans, each command starting where the previous
  one ended.
- With it, a best-first search over which objects are forbidden to which commands
  (conflict-based search, as in multi-agent path finding; ``_MissionSearch``) solves that
  programme per node, for no more deliveries than a matching of slots to objects allows, and
  splits a node on the first object two commands' plans share.

The search is exact but can grow exponentially: on medium_s0007's first mission of mechanism-v2
(10 commands competing for bowls, cellphones and books, within a few cost units of each other) it
had not closed after 16,000 nodes on 9 of the commands, and an earlier version that kept a memo per
node outgrew 21 GB. It expands at most ``MAX_NODES`` nodes (the memory per node: its forbidden
objects and its plan); then the same plans go to an integer programme (``mission_milp``).

An earlier exact version kept, per command, the set of objects taken in its state; on 10-command
missions whose commands share categories that state space grew past 60 CPU seconds from five
commands on (a mechanism mission's run stopped after 10.5 min), while the search takes seconds
(``benchmarks/bench_mission_assignment.py``). On exact ties the two may pick different plans of
equal deliveries and cost.
``cheapest_assignment`` is the one-command case.
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Optional

from interllm.planning.mission_milp import solve_mission

NavCost = Callable[[str, str], float]  # (from location, to furniture) -> cost; math.inf: no path
MAX_NODES = 10_000  # nodes the mission search expands at most (``_MissionSearch.run``), then ``mission_milp``:
# about 2 ms a node on a 10-command mechanism mission, so a third of what HiGHS takes there (bench_mission_milp.py)


@dataclass(frozen=True)
class Delivery:
    obj: str
    source: str  # furniture the object stands on
    target: str  # furniture it is placed on
    pick: float  # cost of the pickup [cost units]
    place: float  # cost of the place [cost units]


@dataclass(frozen=True)
class CommandSlots:
    """One command of a mission as the assignment sees it."""

    n: int  # objects it still asks for
    options: tuple[Delivery, ...]  # every feasible (object, target) with its manipulation costs


@dataclass(frozen=True)
class MissionPlan:
    plans: tuple[tuple[Delivery, ...], ...]  # per command, its ordered deliveries
    deliveries: int
    cost: float  # [cost units] summed over the mission
    missed: int = 0  # slots asked for and not delivered
    bound: Optional[tuple[int, float]] = None  # None: the best mission plan; else neither method closed the
    # gap, and this is a lower bound (slots missed, cost [cost units]) on the best one
    method: str = "search"  # what found it: the conflict-based search, or "milp" once its budget ran out

    def gap(self) -> float:
        """How far this plan's cost lies above the lower bound, as a share of the bound: 0 for the
        best plan, math.inf when it misses more slots than the bound does."""
        if self.bound is None:
            return 0.0
        if self.missed > self.bound[0]:
            return math.inf
        return self.cost / self.bound[1] - 1.0 if self.bound[1] > 0 else 0.0


Score = tuple[int, float]  # (slots missed, cost [cost units]): the less, the better, in that order
Plan = tuple[frozenset[str], float, tuple[Delivery, ...]]  # one command's (objects, cost, deliveries)


def cheapest_mission(start: str, commands: Sequence[CommandSlots], nav: NavCost,
                     max_nodes: int = MAX_NODES) -> MissionPlan:
    """The plan of every command (module docstring): deliveries first, then the least cost.

    start: the robot's location key for ``nav`` (e.g. "@robot" or a furniture id).
    nav(a, b): navigation cost from location a to furniture b (math.inf when there is no path).
    max_nodes: the search's node budget; a search that reaches it returns a mission plan with a
    lower bound on the best one (``MissionPlan.bound``, ``gap``) instead of the best.
    """
    search = _MissionSearch(start, commands, nav, max_nodes)
    found, solved = search.run(), None
    if found is None:  # the search's budget ran out: the integer programme over the same plans
        solved = solve_mission(start, len(commands), search.ranked, search.max_deliveries({}))
        found = solved.plans
    total = 0.0
    for plan in reversed(found):  # summed from the last command: cost + rest
        total = plan[1] + total
    n_done = sum(len(p[2]) for p in found)
    missed = sum(c.n for c in commands) - n_done
    bound = None if solved is None or solved.optimal else (missed, solved.lower_bound)
    return MissionPlan(tuple(p[2] for p in found), n_done, total if n_done else 0.0, missed, bound,
                       "search" if solved is None else "milp")


def cheapest_assignment(start: str, deliveries: Sequence[Delivery], n: int, nav: NavCost) -> tuple[list[Delivery], float]:
    """(ordered deliveries, total cost) of the cheapest plan with the most distinct objects (<= n)
    of one command: ``cheapest_mission`` with one command."""
    plan = cheapest_mission(start, [CommandSlots(n, tuple(deliveries))], nav)
    return list(plan.plans[0]), plan.cost


class _MissionSearch:
    """Best-first search over object restrictions for ``cheapest_mission`` (conflict-based search,
    as in multi-agent path finding). A node forbids some objects to some commands. Its relaxed
    plan is the best combination of plans, each command starting where the previous one ended,
    that avoids the node's forbidden objects but may take an object another command takes, among
    those with at most as many deliveries as a mission plan of the node can have:

    - that most, ``max_deliveries``, is a bipartite matching of slots to allowed objects (no
      object in two commands; costs aside), exact and cheap;
    - the best combination that misses exactly m slots is a dynamic programme over (command,
      location), for every m up to a limit at once (``best_by_missed``).

    A relaxed plan in which no object serves two commands is a mission plan. Otherwise an object o
    serves several commands, and every mission plan leaves o to at most one of them: the node has a
    child per such command, in which o may serve that command and is forbidden to the others.
    Nodes are expanded in order of their relaxed (slots missed, cost), which never falls from a
    node to its children (their plans are a subset, their matching no larger), so the first node
    whose relaxed plan is a mission plan is the best mission plan.

    Without the matching's cap, where objects are scarce (more commands want them than there
    are) the relaxed plan missed fewer slots than any mission plan, and the search had to examine
    every way of sharing the scarce objects before it could miss one slot more: on one
    10-command mechanism mission that outgrew 21 GB of memory. A node on the heap holds its
    forbidden objects and its relaxed plan (a reference per command to a plan of ``ranked``), no
    memo. After ``max_nodes`` expansions the search gives up (``run`` returns None)."""

    def __init__(self, start: str, commands: Sequence[CommandSlots], nav: NavCost, max_nodes: int = MAX_NODES) -> None:
        self.start, self.commands, self.nav, self.max_nodes = start, commands, nav, max_nodes
        self.by_obj = [_options_by_object(c.options) for c in commands]
        self._ranked: dict[tuple[int, str], list[tuple[str, list[list[Plan]]]]] = {}

    def ranked(self, i: int, loc: str) -> list[tuple[str, list[list[Plan]]]]:
        """Command i's plans from ``loc`` (``_command_plans``) grouped by where they end, and in a
        group by their number of deliveries (index), each list cheapest first."""
        if (i, loc) not in self._ranked:
            per_end: dict[str, list[list[Plan]]] = {}
            for plan in _command_plans(loc, self.by_obj[i], self.commands[i].n, self.nav):
                end = plan[2][-1].target if plan[2] else loc
                by_size = per_end.setdefault(end, [[] for _ in range(self.commands[i].n + 1)])
                by_size[len(plan[2])].append(plan)
            for by_size in per_end.values():
                for plans in by_size:
                    plans.sort(key=lambda plan: plan[1])  # stable: equal costs keep the search's order
            self._ranked[(i, loc)] = list(per_end.items())
        return self._ranked[(i, loc)]

    def max_deliveries(self, forbidden: Forbidden) -> int:
        """The most deliveries a mission plan avoiding ``forbidden`` can make: a maximum matching
        of command slots to distinct allowed objects (augmenting paths), costs aside."""
        allowed = [sorted(set(by_obj) - forbidden.get(i, frozenset())) for i, by_obj in enumerate(self.by_obj)]
        owner: dict[str, int] = {}

        def augment(i: int, visited: set[str]) -> bool:  # one more object for command i
            for o in allowed[i]:
                if o not in visited:
                    visited.add(o)
                    if o not in owner or augment(owner[o], visited):
                        owner[o] = i
                        return True
            return False

        return sum(1 for i, c in enumerate(self.commands) for _ in range(c.n) if augment(i, set()))

    def best_by_missed(self, forbidden: Forbidden, memo: Memo, i: int, loc: str, limit: int) -> list[Optional[tuple[float, Plan]]]:
        """Indexed by m = 0 .. limit: the least cost [cost units] of plans of commands i, i+1, ...
        from ``loc`` that miss m of their slots in all and avoid ``forbidden``, with command i's plan
        (None: no such plans). Kept in ``memo`` by (i, loc), for one ``limit``."""
        if i == len(self.commands):
            return [(0.0, _EMPTY_PLAN)] + [None] * limit
        if (i, loc) not in memo:
            n, out = self.commands[i].n, [None] * (limit + 1)
            taboo = forbidden.get(i, frozenset())
            for end, by_size in self.ranked(i, loc):
                rest: Optional[list] = None
                for size in range(max(n - limit, 0), n + 1):  # this command misses n - size of its slots
                    plan = next((p for p in by_size[size] if not p[0] & taboo), None)
                    if plan is None:
                        continue
                    rest = rest or self.best_by_missed(forbidden, memo, i + 1, end, limit)
                    for m_rest in range(limit - (n - size) + 1):
                        entry, m = rest[m_rest], n - size + m_rest
                        if entry is not None and (out[m] is None or plan[1] + entry[0] < out[m][0]):  # type: ignore[index]
                            out[m] = (plan[1] + entry[0], plan)
            memo[(i, loc)] = out
        return memo[(i, loc)]

    def relaxed(self, forbidden: Forbidden) -> tuple[Score, list[Plan]]:
        """The node's relaxed (slots missed, cost) and plan, per command: its least missed count
        no smaller than the matching allows, then its least cost. The programme is solved for at
        most ``limit`` missed slots, the matching's floor first (where nothing is scarce, 0: only
        full plans), and again with a higher limit while nothing within it is feasible."""
        total = sum(c.n for c in self.commands)
        floor = total - self.max_deliveries(forbidden)  # no mission plan of the node misses fewer slots
        limit = floor
        while True:
            memo: Memo = {}
            at_start = self.best_by_missed(forbidden, memo, 0, self.start, limit)
            m = next((k for k in range(floor, limit + 1) if at_start[k] is not None), None)
            if m is not None:
                break
            limit = min(total, 2 * limit + 1)  # at ``total``, the empty plans are feasible
        score, plans, loc = (m, at_start[m][0]), [], self.start  # type: ignore[index]
        for i, command in enumerate(self.commands):
            plan = self.best_by_missed(forbidden, memo, i, loc, limit)[m][1]  # type: ignore[index]
            plans.append(plan)
            m, loc = m - (command.n - len(plan[2])), (plan[2][-1].target if plan[2] else loc)
        return score, plans

    def run(self) -> list[Plan] | None:
        """The best mission plan, per command; None when ``max_nodes`` nodes were expanded first."""
        order = itertools.count(1)  # ties: the node made first
        root = self.relaxed({})
        heap: list[tuple[Score, int, Forbidden, list[Plan]]] = [(root[0], 0, {}, root[1])]
        seen: set[frozenset[tuple[int, str]]] = {frozenset()}
        for _ in range(self.max_nodes):
            if not heap:
                break
            _, _, forbidden, plans = heapq.heappop(heap)
            conflict = self.expand(forbidden, plans)
            if conflict is None:
                return plans
            obj, commands = conflict
            for keeper in commands:  # the object serves this one of them, or none
                child = _forbidding(forbidden, [i for i in commands if i != keeper], obj)
                key = frozenset((i, o) for i, objs in child.items() for o in objs)
                if key not in seen:
                    seen.add(key)
                    score, child_plans = self.relaxed(child)
                    heapq.heappush(heap, (score, next(order), child, child_plans))
        assert heap, "unreachable: forbidding every object leaves the empty plans, a mission plan"
        return None

    def expand(self, forbidden: Forbidden, plans: list[Plan]) -> tuple[str, list[int]] | None:
        """The first conflict of a node taken off the heap (``_first_conflict``), None if none."""
        return _first_conflict(plans)


Forbidden = dict[int, frozenset[str]]  # per command, the objects it may not take
Memo = dict[tuple[int, str], list[Optional[tuple[float, Plan]]]]
_EMPTY_PLAN: Plan = (frozenset(), 0.0, ())


def _forbidding(forbidden: Forbidden, commands: list[int], obj: str) -> Forbidden:
    """A child node's restrictions: also ``obj`` to ``commands``."""
    out = dict(forbidden)
    for i in commands:
        out[i] = out.get(i, frozenset()) | {obj}
    return out


def _first_conflict(plans: list[Plan]) -> tuple[str, list[int]] | None:
    """(an object two commands' plans take, every command whose plan takes it), or None when no
    object serves two commands. The object is the one whose second taker comes first, then by name."""
    takers: dict[str, list[int]] = {}
    for i, (objs, _, _) in enumerate(plans):
        for o in objs:
            takers.setdefault(o, []).append(i)
    shared = sorted((i[1], o) for o, i in takers.items() if len(i) > 1)
    return (shared[0][1], takers[shared[0][1]]) if shared else None


def _options_by_object(options: Sequence[Delivery]) -> dict[str, tuple[Delivery, ...]]:
    out: dict[str, list[Delivery]] = {}
    for d in sorted(options, key=lambda d: (d.obj, d.target)):
        if out.get(d.obj) and out[d.obj][0].source != d.source:
            raise ValueError(f"object {d.obj!r} is delivered from {out[d.obj][0].source!r} and {d.source!r}: "
                             "an object's deliveries start where it stands, one source")
        out.setdefault(d.obj, []).append(d)
    return {o: tuple(ds) for o, ds in out.items()}


def _command_plans(loc: str, by_obj: dict[str, tuple[Delivery, ...]], n: int, nav: NavCost) -> list[Plan]:
    """(object set, cost, ordered plan) of one command from ``loc``: the cheapest order per (object
    set, last target), of every size up to ``n`` (the empty plan included). Plans that end at
    different targets are all kept: the next command starts there."""
    Layer = dict[tuple[frozenset[str], str], tuple[float, tuple[Delivery, ...]]]
    layer: Layer = {(frozenset(), loc): (0.0, ())}
    found: list[Plan] = [(frozenset(), 0.0, ())]
    onward = {o: [(d, nav(d.source, d.target)) for d in ds] for o, ds in by_obj.items()}
    for _ in range(max(n, 0)):
        grown: Layer = {}
        for (objs, end), (cost, seq) in layer.items():
            for o in by_obj:
                if o in objs:
                    continue
                reach = nav(end, by_obj[o][0].source)  # an object's deliveries share its source
                with_o = objs | {o}
                for d, carry in onward[o]:
                    c = cost + (reach + d.pick + carry + d.place)  # a delivery's cost, summed in this order
                    key = (with_o, d.target)
                    if c < math.inf and (key not in grown or c < grown[key][0]):
                        grown[key] = (c, seq + (d,))
        if not grown:  # no object left to add
            break
        found += [(objs, cost, seq) for (objs, _end), (cost, seq) in grown.items()]
        layer = grown
    return found
