"""Measured feasibility of a scene's commands: which instances a planner can deliver,
judged by the simulator's own measurement, and how the missions' slots are filled.

``measure_scene`` builds a ``World`` of the scene and measures with ``World.measure_manipulation``
(the N_l-trial measurement from the furniture's anchor, in scratch; nothing moves):
- the pickup of every object from its furniture (``scene.reach_report``; otherwise only of the
  instances examined below);
- for every catalog command whose targets exist, the place of each of its candidate instances
  (its category, not on one of its targets, pickup success rate > 0) on each target, the target's
  current objects left where they are, target after target (sorted ids) up to the first place with
  success rate > 0: then the instance is *fulfillable* for the command. Instances are examined in
  id order until k x commands_per_mission are fulfillable: enough for any mission's commands to
  get k distinct ones each, so the draw's fills are those of examining all;
- the targets' capacity: per target, the fulfillable instances that place on it (smallest
  footprint first, then highest pickup success rate, then id) are placed one after the other in a
  scratch copy of the scene, each at the spot its place measurement uses
  (``sim.grasp_goals.place_spot``), until a place fails or k are on it; target after target until
  they take k. The command's capacity is the sum over its targets, at most k. Approximations: the capacity is that of the smallest
  instances (a planner taking larger ones may fit fewer), the matching of a mission's slots to
  instances ignores sizes, and what an earlier command of the mission left on a shared target is
  not counted.

``Fulfillable`` (``interllm.scene.missions``) carries the result to the mission draw as plain data;
``feasibility_record`` writes what was measured and how each mission's commands are filled
(``feasibility.json``, format in its docstring).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Optional

from interllm.config import SimConfig
from interllm.core.actions import Action
from interllm.core.results import ActionResult
from interllm.scene.catalog import Catalog, CommandSpec, load_catalog
from interllm.scene.graph import Mission, SceneGraph, SceneObject
from interllm.scene.grid import OccupancyGrid
from interllm.scene.missions import CommandFill, Fulfillable
from interllm.sim.grasp_goals import place_spot
from interllm.sim.measurements import MeasurementStore
from interllm.sim.reach_report import CAUSES, pickup_cause
from interllm.sim.world import World

FEASIBILITY_SCHEMA_VERSION = 3  # 2: objects[].cause and reach; 3: objects_measured, lazy command search
DIFFICULTY = {"front": "easy", "clutter": "medium", "deep": "hard", "high": "hard", "inside": "hard"}  # by placement label
DIGITS = 6  # rounding of success rates, costs and times in the record
MAX_PASSED = 2  # capacity: instances passed over (cannot be placed on the empty target) before giving up


@dataclass(frozen=True)
class PickupMeasure:
    """One object's pickup from where it stands: success rate over the N_l trials, cost
    (γ_man·(1 − sr) + t) and mean trial time t [s]; sr 0 when it cannot be tried; ``cause``: why it
    cannot be picked up ('' when sr > 0; ``sim.reach_report.CAUSES``)."""

    furniture: str
    category: str
    placement: str
    sr: float
    cost: float
    time: float
    cause: str = ""


@dataclass(frozen=True)
class CommandMeasure:
    """One command: its targets, candidate instances, place success rate per (instance, target),
    the fulfillable instances and the capacity per target (objects placed one after another)."""

    targets: tuple[str, ...]
    instances: tuple[str, ...]
    place_sr: dict[str, dict[str, float]]
    fulfillable: tuple[str, ...]
    capacity: dict[str, int]

    def total_capacity(self, k: int) -> int:
        return min(int(k), sum(self.capacity.values()))


@dataclass(frozen=True)
class SceneFeasibility:
    """The measurement of one scene for commands of k objects."""

    scene_id: str
    k: int
    pickups: dict[str, PickupMeasure]
    commands: dict[str, CommandMeasure]
    reach: dict[str, dict] = field(default_factory=dict)  # per furniture category (``_reach``)
    all_pickups: bool = True  # pickups holds every object (else only the instances examined)
    measurements: Optional[MeasurementStore] = None  # every measurement made, for the stages after (``sim.measurements``)

    def fulfillable(self) -> Fulfillable:
        """The plain data the mission draw takes."""
        return Fulfillable(objects={c: m.fulfillable for c, m in self.commands.items()},
                           capacity={c: m.total_capacity(self.k) for c, m in self.commands.items()})


def _measure(world: World, action: Action) -> Optional[ActionResult]:
    """``World.measure_manipulation``; None when the action cannot be tried (also when the furniture has
    no anchor cell: no free floor next to it)."""
    try:
        return world.measure_manipulation(action)
    except ValueError:
        return None


def _sr(res: Optional[ActionResult]) -> float:
    return 0.0 if res is None else round(float(res.success_rate), DIGITS)


def measure_scene(scene: SceneGraph, sim_cfg: SimConfig, grid_resolution: float, k: int,
                  grids: Optional[dict[str, OccupancyGrid]] = None, catalog: Optional[Catalog] = None,
                  *, need: Optional[int] = None, all_pickups: bool = True) -> SceneFeasibility:
    """Measure ``scene`` (module doc) for commands of ``k`` objects.

    sim_cfg: the simulator's config (robot, N_l, IK, seed: the measurement depends on all of it).
    grid_resolution: [m] per cell; grids: the scene's {"presumed", "true"} grids if already made.
    need: a command's instances are examined (sorted ids) until this many are fulfillable (None:
        all). The draw needs k x commands_per_mission at most: with that many, any mission's
        commands can each get k distinct ones, so the fills are those of measuring everything.
    all_pickups: measure every object's pickup (the reach report covers the whole house); False:
        only those of the instances examined.
    """
    cat = catalog or load_catalog()
    world = World(scene, sim_cfg, grid_resolution, grids)
    pickups: dict[str, PickupMeasure] = {}

    def pickup(oid: str) -> PickupMeasure:
        if oid not in pickups:
            o = scene.objects[oid]
            res = _measure(world, Action("pickup", o.furniture, obj=oid))
            pickups[oid] = PickupMeasure(o.furniture, o.category, o.placement, _sr(res),
                                         round(float(res.cost), DIGITS) if res else 0.0,
                                         round(float(res.time), DIGITS) if res else 0.0,
                                         pickup_cause(sim_cfg, scene, oid, res))
        return pickups[oid]

    for oid in sorted(scene.objects) if all_pickups else ():
        pickup(oid)
    commands = {}
    for spec in cat.commands:
        targets = spec.resolve_targets(scene)
        if targets:
            commands[spec.id] = _measure_command(world, spec, targets, pickup, k, need)
    measured = {o: pickups[o] for o in sorted(pickups)}
    return SceneFeasibility(scene.id, int(k), measured, commands, _reach(scene, measured), all_pickups,
                            world.measurements)


def _measure_command(world: World, spec: CommandSpec, targets: tuple[str, ...],
                     pickup: Callable[[str], PickupMeasure], k: int, need: Optional[int]) -> CommandMeasure:
    """Place measurements of the command's pickable instances on each target (until ``need`` are
    fulfillable), and the targets' capacities (target after target until they take k)."""
    instances = spec.valid_objects(world.initial_scene)
    place_sr: dict[str, dict[str, float]] = {}
    fulfillable: list[str] = []
    for o in instances:
        if need is not None and len(fulfillable) >= need:
            break
        if pickup(o).sr > 0:
            place_sr[o] = _first_place(world, o, targets)
            if any(v > 0 for v in place_sr[o].values()):
                fulfillable.append(o)
    scene = world.initial_scene
    order = sorted(fulfillable, key=lambda o: (scene.objects[o].size[0] * scene.objects[o].size[1], -pickup(o).sr, o))
    capacity: dict[str, int] = {}
    for t in targets:
        if sum(capacity.values()) >= k:
            break
        capacity[t] = _capacity(world, t, order, k)
    return CommandMeasure(targets, tuple(instances), place_sr, tuple(fulfillable), capacity)


def _first_place(world: World, oid: str, targets: Sequence[str]) -> dict[str, float]:
    """Place success rates of ``oid`` on ``targets`` in order, up to the first that succeeds."""
    out = {}
    for t in targets:
        out[t] = _sr(_measure(world, Action("place", t, obj=oid)))
        if out[t] > 0:
            break
    return out


def _capacity(world: World, target: str, order: Sequence[str], k: int) -> int:
    """How many of ``order`` (at most k) can be placed on ``target`` one after the other: each is put
    at its place spot in a scratch copy of the scene before the next is measured. An instance that
    cannot be placed on the target as it stands is passed over (at most MAX_PASSED of them); once
    one is on it, the first failure ends the count."""
    n = passed = 0
    moved: dict[str, SceneObject] = {}  # what the count changed, put back after it (a copy of a
    # 2,000-object scene per target cost the huge house 90 s)
    try:
        for oid in order:
            if n >= k or passed > MAX_PASSED:
                break
            spot = place_spot(world.scene, target, world.scene.objects[oid].size, world.anchor(target), oid) \
                if _sr(_measure(world, Action("place", target, obj=oid))) > 0 else None
            if spot is None:
                if n:
                    break
                passed += 1
                continue
            moved.setdefault(oid, world.scene.objects[oid])
            world.scene.move_object(oid, target, tuple(float(v) for v in spot))
            n += 1
    finally:
        world.scene.objects.update(moved)
    return n


def feasibility_record(meas: SceneFeasibility, drawn: Sequence[tuple[Mission, Sequence[CommandFill]]],
                       mode: str, object_design: str, commands_per_mission: int) -> dict:
    """The ``feasibility.json`` document of a scene:

    - ``objects_measured``: "all" (``scene.reach_report``) or "examined" (the instances the
      command search examined): which objects ``objects``, ``difficulty`` and ``reach`` cover;
    - ``objects``: object id -> {furniture, category, placement, difficulty (front: easy, clutter:
      medium, deep / high / inside: hard), pickup_sr, pickup_cost, pickup_time [s], cause};
    - ``commands``: command id -> {targets, instances (right category, not on a target),
      fulfillable, place_sr {instance: {target: sr}} (pickable instances examined, targets up to the
      first success), capacity {target: n} (targets measured, until they take k), fill (objects it can get on its own, at most k)};
    - ``missions``: [{id, commands: [{id, asked, n_objects, matched, status, instances, fulfillable}]}]
      (``scene.missions.CommandFill``; dropped commands are listed with n_objects 0);
    - ``difficulty``: per difficulty {instances, pickup_ok, fulfillable (for some command)};
    - ``reach``: per furniture category {objects, pickable (pickup_sr > 0), causes {cause: n}} of
      the objects that cannot be picked up (``sim.reach_report``: closed, no_floor, height,
      no_free_pose, ik, collision, grip); each object's own is ``objects[id].cause``;
    - ``totals``: {slots_asked (what the config asks: missions x commands_per_mission x k, so a
      mission short of commands counts as slots that cannot be filled), slots_drawn (Σ asked over
      the commands drawn), slots_fulfillable (Σ matched: slots a planner can deliver), commands
      (drawn), ok, reduced, dropped, short, unchecked (commands per status)}.
    """
    ful = meas.fulfillable()
    missions = [{"id": m.id, "commands": [f.to_dict() for f in fills]} for m, fills in drawn]
    fills = [f for _, fs in drawn for f in fs]
    totals = {"slots_asked": len(drawn) * int(commands_per_mission) * meas.k,
              "slots_drawn": sum(f.asked for f in fills), "slots_fulfillable": sum(f.matched for f in fills),
              "commands": len(fills)}
    for status in ("ok", "reduced", "dropped", "short", "unchecked"):
        totals[status] = sum(f.status == status for f in fills)
    return {
        "schema_version": FEASIBILITY_SCHEMA_VERSION, "scene": meas.scene_id, "objects_per_command": meas.k,
        "feasibility": mode, "object_design": object_design,
        "objects_measured": "all" if meas.all_pickups else "examined",
        "objects": {o: _object_entry(p) for o, p in meas.pickups.items()},
        "commands": {c: {"targets": list(m.targets), "instances": list(m.instances),
                         "fulfillable": list(m.fulfillable), "place_sr": m.place_sr, "capacity": m.capacity,
                         "fill": ful.fill(c, meas.k)} for c, m in meas.commands.items()},
        "missions": missions, "difficulty": _by_difficulty(meas), "reach": meas.reach, "totals": totals,
    }


def _object_entry(p: PickupMeasure) -> dict:
    return {"furniture": p.furniture, "category": p.category, "placement": p.placement,
            "difficulty": DIFFICULTY.get(p.placement, "easy"), "pickup_sr": p.sr, "pickup_cost": p.cost,
            "pickup_time": p.time, "cause": p.cause}


def _reach(scene: SceneGraph, pickups: dict[str, PickupMeasure]) -> dict[str, dict]:
    """Per furniture category (sorted): objects on it, those picked up at least once, and the causes
    of the others ({cause: count}, in ``CAUSES`` order)."""
    out: dict[str, dict] = {}
    for p in pickups.values():
        row = out.setdefault(scene.furniture[p.furniture].category, {"objects": 0, "pickable": 0, "causes": {}})
        row["objects"] += 1
        row["pickable"] += p.sr > 0
        if p.cause:
            row["causes"][p.cause] = row["causes"].get(p.cause, 0) + 1
    for row in out.values():
        row["causes"] = {c: row["causes"][c] for c in CAUSES if c in row["causes"]}
    return dict(sorted(out.items()))


def _by_difficulty(meas: SceneFeasibility) -> dict[str, dict[str, int]]:
    """Per difficulty: instances, those picked up at least sometimes, those fulfillable for a command."""
    anywhere = {o for m in meas.commands.values() for o in m.fulfillable}
    out = {d: {"instances": 0, "pickup_ok": 0, "fulfillable": 0} for d in ("easy", "medium", "hard")}
    for oid, p in meas.pickups.items():
        row = out[DIFFICULTY.get(p.placement, "easy")]
        row["instances"] += 1
        row["pickup_ok"] += p.sr > 0
        row["fulfillable"] += oid in anywhere
    return out
