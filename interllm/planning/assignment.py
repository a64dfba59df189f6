"""The cheapest assignment of objects to a command's slots and targets, by exhaustive search over
given costs (what the ``optimal`` reference planner computes from ground truth).

A delivery is (object, target): navigate to the object's furniture, pick it up, navigate to the
target, place it. ``cheapest_assignment`` returns the ordered deliveries of ``n`` distinct objects
(fewer when fewer are deliverable) minimising the summed cost

    Σ nav(from, object's furniture) + pick(object) + nav(object's furniture, target) + place(object, target)

where ``from`` is the robot's start for the first delivery and the previous target after it.
Deliveries come first: a plan with more deliveries always beats a cheaper one with fewer (the
command asks for ``n`` objects). The search is depth-first with branch and bound, exact over the
``max_objects`` objects cheapest to deliver on their own (all of them by default).
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


def cheapest_assignment(start: str, deliveries: Sequence[Delivery], n: int, nav: NavCost,
                        max_objects: int = 0) -> tuple[list[Delivery], float]:
    """(ordered deliveries, total cost) of the cheapest plan with the most distinct objects (<= n).

    start: the robot's location key for ``nav`` (e.g. "@start" or a furniture id).
    deliveries: every feasible (object, target) option with its manipulation costs; an object may
        appear once per target.
    nav(a, b): navigation cost from location a to furniture b (math.inf when there is no path).
    max_objects: search only over the objects cheapest to deliver from ``start`` alone (0: all).
    """
    by_obj: dict[str, list[Delivery]] = {}
    for d in deliveries:
        by_obj.setdefault(d.obj, []).append(d)
    alone = {o: min(_step(start, d, nav) for d in ds) for o, ds in by_obj.items()}
    objs = sorted((o for o in by_obj if math.isfinite(alone[o])), key=lambda o: (alone[o], o))
    if max_objects > 0:
        objs = objs[:max_objects]
    options = {o: sorted(by_obj[o], key=lambda d: (d.target, d.pick + d.place)) for o in objs}
    best: list = [[], math.inf]
    want = min(n, len(objs))

    def dfs(loc: str, chosen: list[Delivery], cost: float) -> None:
        if len(chosen) == want:
            if cost < best[1]:
                best[0], best[1] = list(chosen), cost
            return
        if cost >= best[1]:
            return
        used = {d.obj for d in chosen}
        for o in objs:
            if o in used:
                continue
            for d in options[o]:
                c = _step(loc, d, nav)
                if math.isfinite(c):
                    chosen.append(d)
                    dfs(d.target, chosen, cost + c)
                    chosen.pop()

    dfs(start, [], 0.0)
    if want and not best[0]:  # no ordering of `want` objects is connected: take fewer
        return cheapest_assignment(start, deliveries, want - 1, nav, max_objects)
    return best[0], (best[1] if best[0] else 0.0)


def _step(loc: str, d: Delivery, nav: NavCost) -> float:
    """Cost of one delivery from ``loc``."""
    return nav(loc, d.source) + d.pick + nav(d.source, d.target) + d.place
