"""The cheapest assignment of objects to a mission's slots and targets, over given costs (what the
``optimal`` anchor computes from ground truth).

A delivery is (object, target): navigate to the object's furniture, pick it up, navigate to the
target, place it. From location ``loc`` it costs

    nav(loc, source) + pick + nav(source, target) + place.

A command's plan is an ordered list of deliveries of distinct objects, at most the command's ``n``;
it starts where the previous command's plan ended (the robot's start for the first command) and
ends at its last target. ``cheapest_mission`` picks one plan per command, no object in two
commands, with the most deliveries over the whole mission first and then the least summed cost.
It is exact over the costs it is given, by dynamic programming over the commands:

    best(i, loc, used) = the best over plans p of command i from loc that avoid ``used`` of
                         (|p|, cost(p)) + best(i + 1, end(p), used ∪ objects(p))

``used`` is kept only for the objects later commands can use. Commands that share no object
therefore do not multiply the states. Each command's plans come from a Held-Karp recursion, once
per start: for every (set of objects delivered, last target), only the cheapest order is kept. Of
them, only the cheapest per outcome that matters to the rest (where it ends, the objects later
commands lose, how many it delivers) is carried into the recursion.
``cheapest_assignment`` is the one-command case.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

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


Best = tuple[int, float, tuple]  # (deliveries, cost, per-command plans)
Plan = tuple[frozenset[str], float, tuple[Delivery, ...]]  # one command's (objects, cost, deliveries)


def cheapest_mission(start: str, commands: Sequence[CommandSlots], nav: NavCost) -> MissionPlan:
    """The plan of every command (module docstring): deliveries first, then the least cost.

    start: the robot's location key for ``nav`` (e.g. "@robot" or a furniture id).
    nav(a, b): navigation cost from location a to furniture b (math.inf when there is no path).
    """
    by_obj = [_options_by_object(c.options) for c in commands]
    later: list[frozenset[str]] = [frozenset()] * (len(commands) + 1)
    for i in range(len(commands) - 1, -1, -1):  # objects command i or a later one can use
        later[i] = later[i + 1] | frozenset(by_obj[i])
    memo: dict[tuple[int, str, frozenset[str]], Best] = {}
    plans: dict[tuple[int, str], list[Plan]] = {}

    def best(i: int, loc: str, used: frozenset[str]) -> Best:
        if i == len(commands):
            return 0, 0.0, ()
        key = (i, loc, used)
        if key not in memo:
            if (i, loc) not in plans:  # independent of ``used``: filtered below
                plans[(i, loc)] = _command_plans(loc, by_obj[i], commands[i].n, nav)
                if i == len(commands) - 1:  # the last: only its own (deliveries, cost) matter
                    plans[(i, loc)].sort(key=lambda p: (-len(p[2]), p[1]))
            if i == len(commands) - 1:
                _, cost, seq = next(p for p in plans[(i, loc)] if not p[0] & used)  # the empty plan at worst
                memo[key] = (len(seq), cost, (seq,))
                return memo[key]
            found: Best = (-1, math.inf, ())
            for (end, nxt, _), (cost, seq) in _cheapest_per_outcome(plans[(i, loc)], loc, used, later[i + 1]).items():
                rest = best(i + 1, end, nxt)
                cand = (len(seq) + rest[0], cost + rest[1], (seq,) + rest[2])
                if cand[0] > found[0] or (cand[0] == found[0] and cand[1] < found[1]):
                    found = cand
            memo[key] = found
        return memo[key]

    n_done, total, plans = best(0, start, frozenset())
    return MissionPlan(plans, n_done, total if n_done else 0.0)


def cheapest_assignment(start: str, deliveries: Sequence[Delivery], n: int, nav: NavCost) -> tuple[list[Delivery], float]:
    """(ordered deliveries, total cost) of the cheapest plan with the most distinct objects (<= n)
    of one command: ``cheapest_mission`` with one command."""
    plan = cheapest_mission(start, [CommandSlots(n, tuple(deliveries))], nav)
    return list(plan.plans[0]), plan.cost


def _options_by_object(options: Sequence[Delivery]) -> dict[str, tuple[Delivery, ...]]:
    out: dict[str, list[Delivery]] = {}
    for d in sorted(options, key=lambda d: (d.obj, d.target)):
        if out.get(d.obj) and out[d.obj][0].source != d.source:
            raise ValueError(f"object {d.obj!r} is delivered from {out[d.obj][0].source!r} and {d.source!r}: "
                             "an object's deliveries start where it stands, one source")
        out.setdefault(d.obj, []).append(d)
    return {o: tuple(ds) for o, ds in out.items()}


def _cheapest_per_outcome(plans: list[Plan], loc: str, used: frozenset[str], later: frozenset[str]
                          ) -> dict[tuple[str, frozenset[str], int], tuple[float, tuple[Delivery, ...]]]:
    """The plans that avoid ``used``, the cheapest per outcome that matters to the rest of the
    mission: (where it ends, the objects later commands can no longer take, deliveries)."""
    out: dict[tuple[str, frozenset[str], int], tuple[float, tuple[Delivery, ...]]] = {}
    for objs, cost, seq in plans:
        if objs & used:
            continue
        key = (seq[-1].target if seq else loc, (used | objs) & later, len(seq))
        if key not in out or cost < out[key][0]:
            out[key] = (cost, seq)
    return out


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
        found += [(objs, cost, seq) for (objs, _end), (cost, seq) in grown.items()]
        layer = grown
    return found
