"""Where a robot can act in a house: the pickable share of the objects per furniture category, and
the cause of each failure (``interllm scene reach``).

Every object's pickup is measured as the scenes stage measures it (``World.measure_manipulation``:
N_l trials from the base poses the configured protocol draws, from the furniture's anchor). An
object is *pickable* when its success rate is above 0. A failed object gets one cause, checked in
this order:

- ``closed``: it is inside a closed receptacle (a fridge; the robot does not open doors);
- ``no_floor``: no free floor next to its furniture that joins the house (no anchor cell);
- ``height``: its grasp height lies outside what the arm reaches top-down at any lift position;
- ``no_free_pose``: no free base pose within reach (most of its trials found none);
- ``ik``: the arm does not reach the grasp pose from the poses it had (IK did not converge);
- ``collision``: the arm reaches it but touches furniture, walls or other objects;
- ``grip``: the gripper ends outside the object's box.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

from interllm.config import SimConfig
from interllm.core.actions import Action
from interllm.core.results import ActionResult
from interllm.scene.graph import SceneGraph
from interllm.sim.base_poses import arm_reach
from interllm.sim.grasp_goals import pickup_goal
from interllm.sim.world import World

CAUSES = ("closed", "no_floor", "height", "no_free_pose", "ik", "collision", "grip")
TRIAL_CAUSE = {"no_free_pose": "no_free_pose", "ik_no_convergence": "ik", "ik_infeasible": "ik",
               "collision": "collision", "not_in_gripper": "grip"}


@dataclass
class CategoryReach:
    """One furniture category: objects on it, how many are pickable, and the causes of the rest."""

    objects: int = 0
    pickable: int = 0
    causes: Counter = field(default_factory=Counter)

    @property
    def share(self) -> float:
        return self.pickable / self.objects if self.objects else 0.0


def pickup_cause(cfg: SimConfig, scene: SceneGraph, oid: str, res: ActionResult | None) -> str:
    """'' when the measured pickup ``res`` of object ``oid`` (None: it could not be tried) succeeded
    at least once, else its cause (module doc)."""
    o = scene.objects[oid]
    if o.placement == "inside":
        return "closed"
    if res is not None and res.success_rate > 0:
        return ""
    goal = pickup_goal(scene, Action("pickup", o.furniture, obj=oid))
    if not isinstance(goal, str) and arm_reach(float(goal.target[2]), cfg) <= 0.0:
        return "height"
    if res is None:
        return "no_floor"
    votes = Counter(TRIAL_CAUSE.get(t.reason, "ik") for t in res.trials)
    return min(votes, key=lambda c: (-votes[c], CAUSES.index(c))) if votes else "no_free_pose"


def object_cause(world: World, scene: SceneGraph, oid: str) -> str:
    """Measure the pickup of object ``oid`` where it stands and return its cause ('' if pickable)."""
    o = scene.objects[oid]
    try:
        res = world.measure_manipulation(Action("pickup", o.furniture, obj=oid))
    except ValueError:
        res = None
    return pickup_cause(world.cfg, scene, oid, res)


def reach_report(scene: SceneGraph, cfg: SimConfig, resolution: float = 0.05) -> dict[str, CategoryReach]:
    """Per furniture category (sorted), the pickable objects on it and the causes of the rest."""
    world = World(scene, cfg, resolution)
    out: dict[str, CategoryReach] = {}
    for oid in sorted(scene.objects):
        cat = scene.furniture[scene.objects[oid].furniture].category
        row = out.setdefault(cat, CategoryReach())
        row.objects += 1
        cause = object_cause(world, scene, oid)
        if cause:
            row.causes[cause] += 1
        else:
            row.pickable += 1
    return dict(sorted(out.items()))


def report_lines(rows: dict[str, CategoryReach], robot: str) -> list[str]:
    """The report as text: a total line, then one line per furniture category."""
    n = sum(r.objects for r in rows.values())
    k = sum(r.pickable for r in rows.values())
    total: Counter = sum((r.causes for r in rows.values()), Counter())
    why = ", ".join(f"{c} {total[c]}" for c in CAUSES if total[c])
    lines = [f"robot {robot}: {k} of {n} objects pickable ({100 * k / max(n, 1):.0f}%)" + (f"; not: {why}" if why else "")]
    width = max((len(c) for c in rows), default=8)
    for cat, r in rows.items():
        causes = ", ".join(f"{c} {r.causes[c]}" for c in CAUSES if r.causes[c])
        lines.append(f"  {cat:<{width}}  {r.pickable:>3}/{r.objects:<3} {100 * r.share:>4.0f}%  {causes}")
    return lines


def report_json(rows: dict[str, CategoryReach], robot: str) -> dict:
    """The report as plain data (``--json``)."""
    return {"robot": robot, "objects": sum(r.objects for r in rows.values()),
            "pickable": sum(r.pickable for r in rows.values()),
            "by_furniture_category": {c: {"objects": r.objects, "pickable": r.pickable,
                                          "causes": {k: r.causes[k] for k in CAUSES if r.causes[k]}}
                                      for c, r in rows.items()}}
