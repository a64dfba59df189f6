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
  programme per node and splits a node on the first object two commands' plans share.

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
from dataclasses import dataclass, field

NavCost = Callable[[str, str], float]  # (from location, to furniture) -> cost; math.inf: no path


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


Score = tuple[int, float]  # (slots missed, cost [cost units]): the less, the better, in that order
Plan = tuple[frozenset[str], float, tuple[Delivery, ...]]  # one command's (objects, cost, deliveries)


def cheapest_mission(start: str, commands: Sequence[CommandSlots], nav: NavCost) -> MissionPlan:
    """The plan of every command (module docstring): deliveries first, then the least cost.

    start: the robot's location key for ``nav`` (e.g. "@robot" or a furniture id).
    nav(a, b): navigation cost from location a to furniture b (math.inf when there is no path).
    """
    plans, costs = _MissionSearch(start, commands, nav).run()
    total = 0.0
    for cost in reversed(costs):  # summed from the last command: cost + rest
        total = cost + total
    n_done = sum(len(p) for p in plans)
    return MissionPlan(plans, n_done, total if n_done else 0.0)


def cheapest_assignment(start: str, deliveries: Sequence[Delivery], n: int, nav: NavCost) -> tuple[list[Delivery], float]:
    """(ordered deliveries, total cost) of the cheapest plan with the most distinct objects (<= n)
    of one command: ``cheapest_mission`` with one command."""
    plan = cheapest_mission(start, [CommandSlots(n, tuple(deliveries))], nav)
    return list(plan.plans[0]), plan.cost


class _MissionSearch:
    """Best-first search over object restrictions for ``cheapest_mission`` (conflict-based search,
    as in multi-agent path finding). A node forbids some objects to some commands. Its relaxed
    plan is the best combination of plans, each command starting where the previous one ended,
    that avoids the node's forbidden objects but may take an object another command takes:
    dynamic programming over (command, location), exact and cheap. A relaxed plan in which no object serves
    two commands is a mission plan. Otherwise an object o serves several commands, and every
    mission plan leaves o to at most one of them: the node has a child per such command, in which
    o may serve that command and is forbidden to the others. Nodes are expanded in order of their
    relaxed (slots missed, cost), which never falls from a node to its children, so the first node
    whose relaxed plan is a mission plan is the best mission plan. Where objects are scarce (more
    commands want them than there are), the relaxed plan misses fewer slots than any mission plan
    and the search examines many nodes: a few hundred, up to about 1,000, for five commands
    competing for four objects (tests); the first search of a mechanism mission, 9 to 14."""

    def __init__(self, start: str, commands: Sequence[CommandSlots], nav: NavCost) -> None:
        self.start, self.commands, self.nav = start, commands, nav
        self.by_obj = [_options_by_object(c.options) for c in commands]
        self._ranked: dict[tuple[int, str], list[tuple[str, list[tuple[Score, Plan]]]]] = {}

    def ranked(self, i: int, loc: str) -> list[tuple[str, list[tuple[Score, Plan]]]]:
        """Command i's plans from ``loc`` (``_command_plans``) grouped by where they end, each group
        best first by (slots missed, cost)."""
        if (i, loc) not in self._ranked:
            n, per_end = self.commands[i].n, {}
            for plan in _command_plans(loc, self.by_obj[i], n, self.nav):
                end = plan[2][-1].target if plan[2] else loc
                per_end.setdefault(end, []).append(((n - len(plan[2]), plan[1]), plan))
            for group in per_end.values():
                group.sort(key=lambda entry: entry[0])  # stable: equal scores keep the search's order
            self._ranked[(i, loc)] = list(per_end.items())
        return self._ranked[(i, loc)]

    def relaxed(self, node: _Node, i: int, loc: str) -> Score:
        """(slots missed, cost) of the best plans of commands i, i+1, ... from ``loc`` that avoid
        the node's forbidden objects; the plan chosen for (i, loc) is kept in ``node.chosen``."""
        if i == len(self.commands):
            return 0, 0.0
        if (i, loc) not in node.chosen:
            forbidden = node.forbidden.get(i, frozenset())
            best: tuple[Score, Plan] | None = None
            for end, group in self.ranked(i, loc):
                allowed = next((e for e in group if not e[1][0] & forbidden), None)  # the group ending at loc has the empty plan
                if allowed is None:
                    continue
                score, plan = allowed
                rest = self.relaxed(node, i + 1, end)
                total = (score[0] + rest[0], score[1] + rest[1])
                if best is None or total < best[0]:
                    best = (total, plan)
            node.chosen[(i, loc)] = best  # type: ignore[assignment]
        return node.chosen[(i, loc)][0]

    def plans_of(self, node: _Node) -> list[Plan]:
        """The node's relaxed plan, per command."""
        out, loc = [], self.start
        for i in range(len(self.commands)):
            plan = node.chosen[(i, loc)][1]
            out.append(plan)
            loc = plan[2][-1].target if plan[2] else loc
        return out

    def run(self) -> tuple[tuple[tuple[Delivery, ...], ...], list[float]]:
        """(per command, its ordered deliveries), (per command, their cost) of the best mission plan."""
        root = _Node({})
        order = itertools.count(1)  # ties: the node made first
        heap: list[tuple[Score, int, _Node]] = [(self.relaxed(root, 0, self.start), 0, root)]
        seen = {root.key()}
        while heap:
            node = heapq.heappop(heap)[2]
            plans = self.plans_of(node)
            conflict = _first_conflict(plans)
            if conflict is None:
                return tuple(p[2] for p in plans), [p[1] for p in plans]
            obj, commands = conflict
            for keeper in commands:  # the object serves this one of them, or none
                child = node.forbidding([i for i in commands if i != keeper], obj)
                if child.key() not in seen:
                    seen.add(child.key())
                    heapq.heappush(heap, (self.relaxed(child, 0, self.start), next(order), child))
        raise AssertionError("unreachable: forbidding every object leaves the empty plans, a mission plan")


@dataclass
class _Node:
    """A node of ``_MissionSearch``: the objects forbidden per command, and its relaxed plan's
    choices by (command, location)."""

    forbidden: dict[int, frozenset[str]]
    chosen: dict[tuple[int, str], tuple[Score, Plan]] = field(default_factory=dict)

    def key(self) -> frozenset[tuple[int, str]]:
        return frozenset((i, o) for i, objs in self.forbidden.items() for o in objs)

    def forbidding(self, commands: list[int], obj: str) -> _Node:
        """A child that also forbids ``obj`` to ``commands``: the choices of later commands carry over."""
        forbidden = dict(self.forbidden)
        for i in commands:
            forbidden[i] = forbidden.get(i, frozenset()) | {obj}
        return _Node(forbidden, {k: v for k, v in self.chosen.items() if k[0] > max(commands)})


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
