"""Missions: sequences of household commands with ground-truth goals resolved in one scene.

Mission 0 is the paper's three commands (breakfast, meeting, reading) when
``MissionConfig.include_paper_mission``; the others draw ``commands_per_mission`` distinct commands
among those the scene supports, seeded by ``core.seeding.mission_seed`` of (scene id, mission seed,
mission index) so the result never depends on the process. The robot starts on a free cell of the
TRUE grid (hence also of the presumed one) in the largest free region, next to a start furniture,
facing it.

Which commands a scene supports (``mission.feasibility``):
- ``off`` (or no measurement given): target furniture present and ``objects_per_command`` valid
  objects (right category, not on a target), reachable or not: the unchecked draw;
- ``measured``: ``Fulfillable``, the simulator's measurement made by the scenes stage
  (``interllm.stages.feasibility``), says which instances a planner can deliver per command and
  how many objects its targets take. Commands are drawn among those it can fill with
  ``objects_per_command`` instances, one at a time, keeping a drawn command only if the mission's
  commands can still all be filled with *distinct* instances (``match_slots``: a bipartite matching
  of the commands' slots to instances; what command 1 delivers is gone for command 3). When too
  few commands fit (or the paper's commands do not fit together), a command is reduced to the
  slots the matching fills (``Goal.n_objects`` lowered) or dropped, with one warning line naming
  scene, mission, command and why.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from interllm.config import MissionConfig
from interllm.core.seeding import mission_seed
from interllm.errors import UserError
from interllm.io import read_json, write_json
from interllm.scene.catalog import Catalog, load_catalog
from interllm.scene.geometry import r4
from interllm.scene.graph import Command, Goal, Mission, SceneGraph
from interllm.scene.grid import (
    approach_cells_of,
    clear_of_obstacles,
    free_components,
    largest_component,
    rasterize,
)
from interllm.scene.reachability import REACH_MARGIN

MISSIONS_SCHEMA_VERSION = 1
log = logging.getLogger(__name__)


class MissionError(UserError, ValueError):
    """Missions cannot be built for this scene, or a missions file is invalid."""


@dataclass(frozen=True)
class Fulfillable:
    """The simulator's measurement of a scene's commands, as plain data (made by
    ``interllm.stages.feasibility``; the scene layer does not run the simulator).

    objects: command id -> the instances a planner can deliver for it (its category, not on one of
        its targets, pickup and place on some target measured to succeed at least sometimes).
    capacity: command id -> how many objects its targets take, as measured (at most the k asked).
    """

    objects: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    capacity: Mapping[str, int] = field(default_factory=dict)

    def fill(self, command_id: str, k: int) -> int:
        """How many of ``k`` objects the command can get on its own (0 for an unknown command)."""
        return min(int(k), int(self.capacity.get(command_id, 0)), len(self.objects.get(command_id, ())))


@dataclass(frozen=True)
class CommandFill:
    """How one command drawn for a mission is filled.

    asked: objects the command asks for (``mission.objects_per_command``).
    n_objects: objects it asks for in the mission written (0: dropped from the mission).
    matched: slots the mission's matching fills (== n_objects with ``mission.feasibility=measured``).
    status: ``ok`` | ``reduced`` | ``dropped`` (measured); ``ok`` | ``short`` (off, measured after the
        draw: the mission asks for more than can be delivered); ``unchecked`` (no measurement).
    instances: the instances the matching gives it; fulfillable: every instance it could take.
    """

    command: str
    asked: int
    n_objects: int
    matched: int
    status: str
    instances: tuple[str, ...] = ()
    fulfillable: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        return {"id": self.command, "asked": self.asked, "n_objects": self.n_objects, "matched": self.matched,
                "status": self.status, "instances": list(self.instances), "fulfillable": list(self.fulfillable)}


def match_slots(demands: Sequence[tuple[Sequence[str], int]]) -> list[list[str]]:
    """A maximum matching of slots to distinct instances: ``demands[i] = (candidate ids, n slots)``;
    returns the instances given to each demand. Slots are matched in order (Kuhn's augmenting
    paths), so a slot once filled stays filled: earlier commands keep their share."""
    slots = [(i, sorted(cands)) for i, (cands, n) in enumerate(demands) for _ in range(max(0, int(n)))]
    owner: dict[str, int] = {}  # instance -> slot index

    def augment(s: int, seen: set[str]) -> bool:
        for o in slots[s][1]:
            if o in seen:
                continue
            seen.add(o)
            if o not in owner or augment(owner[o], seen):
                owner[o] = s
                return True
        return False

    for s in range(len(slots)):
        augment(s, set())
    out: list[list[str]] = [[] for _ in demands]
    for o, s in sorted(owner.items()):
        out[slots[s][0]].append(o)
    return out


def supported_commands(scene: SceneGraph, n_objects: int, catalog: Catalog | None = None) -> list[str]:
    """Command ids whose targets exist in ``scene`` and that have >= n_objects valid objects."""
    cat = catalog or load_catalog()
    return [c.id for c in cat.commands
            if c.resolve_targets(scene) and len(c.valid_objects(scene)) >= n_objects]


def start_pose(scene: SceneGraph, furniture_id: str, grid, robot_radius: float,
               labels: np.ndarray | None = None, standable: np.ndarray | None = None
               ) -> tuple[float, float, float] | None:
    """A start pose (x [m], y [m], yaw [rad]) on a free cell of ``grid`` next to a furniture.

    The cell is in the largest free region, within ``robot_radius + REACH_MARGIN`` of the footprint,
    where the true footprint touches nothing if ``standable`` (bool [rows, cols]) says so for any
    such cell, the one closest to the footprint centre (ties: lowest row, col); yaw faces the centre.
    """
    if labels is None:
        labels, _ = free_components(grid)
    main = largest_component(labels)
    f = scene.furniture[furniture_id]
    cells = approach_cells_of(grid, f.boxes, robot_radius + REACH_MARGIN)
    if not len(cells):
        return None
    cells = cells[labels[cells[:, 0], cells[:, 1]] == main]
    if not len(cells):
        return None
    if standable is not None and standable[cells[:, 0], cells[:, 1]].any():
        cells = cells[standable[cells[:, 0], cells[:, 1]]]
    xy = grid.cell_to_world(cells)
    d = np.hypot(xy[:, 0] - f.center[0], xy[:, 1] - f.center[1])
    k = int(np.lexsort((cells[:, 1], cells[:, 0], np.round(d, 6)))[0])
    x, y = float(xy[k, 0]), float(xy[k, 1])
    return (r4(x), r4(y), r4(math.atan2(f.center[1] - y, f.center[0] - x)))


def standable_start(scene: SceneGraph, mission: Mission, grid, robot_radius: float,
                    footprint_radius: float | None = None, labels: np.ndarray | None = None,
                    standable: np.ndarray | None = None) -> tuple[float, float, float]:
    """``mission.start`` if the configured robot can stand there as the draw requires: its cell free
    on ``grid`` (the robot's true grid) and in the largest free region, and its true footprint
    (``footprint_radius`` [m]) clear of obstacles unless no start cell next to the start furniture
    is. Else the pose ``start_pose`` gives next to the same furniture (a frozen mission run with
    another robot). labels / standable: ``free_components(grid)`` and the footprint-clear mask, if
    already computed for the scene. MissionError when the furniture has no free start cell."""
    if labels is None:
        labels, _ = free_components(grid)
    if standable is None:
        extra = 0.0 if footprint_radius is None else float(footprint_radius) - robot_radius
        standable = clear_of_obstacles(grid.free, extra, grid.resolution)
    pose = start_pose(scene, mission.start_furniture, grid, robot_radius, labels, standable)
    if pose is None:
        raise MissionError(f"scene {scene.id!r} mission {mission.id}: no free start cell next to "
                           f"{mission.start_furniture!r} for this robot (sim.robot_radius={robot_radius} m)")
    r, c = (int(v) for v in grid.world_to_cell(np.asarray(mission.start[:2], dtype=float)))
    best = grid.world_to_cell(np.asarray(pose[:2], dtype=float))
    free = grid.is_free((r, c)) and labels[r, c] == largest_component(labels)
    return mission.start if free and (standable[r, c] or not standable[int(best[0]), int(best[1])]) else pose


def _more_objects_advice(scene: SceneGraph) -> str:
    """How to get a scene with more objects: a generated one can be generated larger; an imported one
    (scene.import_path) needs the objects in its file, or fewer per command."""
    if scene.meta.get("generator"):
        return "generate a larger scene"
    return ("add objects the commands use to the scene file (scene.import_path), or lower "
            "mission.objects_per_command")


def generate_missions(scene: SceneGraph, cfg: MissionConfig, robot_radius: float = 0.25,
                      grid_resolution: float | None = None, catalog: Catalog | None = None,
                      footprint_radius: float | None = None,
                      fulfillable: Fulfillable | None = None) -> list[Mission]:
    """``cfg.n_missions`` missions for ``scene`` (deterministic in scene id, cfg and the measurement):
    ``draw_missions`` without the per-command fill records."""
    return [m for m, _ in draw_missions(scene, cfg, robot_radius, grid_resolution, catalog, footprint_radius,
                                        fulfillable)]


def draw_missions(scene: SceneGraph, cfg: MissionConfig, robot_radius: float = 0.25,
                  grid_resolution: float | None = None, catalog: Catalog | None = None,
                  footprint_radius: float | None = None, fulfillable: Fulfillable | None = None
                  ) -> list[tuple[Mission, tuple[CommandFill, ...]]]:
    """``cfg.n_missions`` missions for ``scene``, each with how its drawn commands are filled.

    robot_radius: base radius [m] (grid inflation for the start pose).
    footprint_radius: [m] the base's true contact radius (``sim.footprint_radius``); a start pose
        keeps the whole footprint clear of obstacles where it can (None: the grid's radius will do).
    grid_resolution: [m] per cell; default ``scene.meta["grid_resolution"]`` or 0.05.
    fulfillable: the simulator's measurement (module doc); with ``cfg.feasibility == "measured"``
        the draw uses it; None: the unchecked draw (as ``mission.feasibility=off``).
    """
    cfg.validate()
    cat = catalog or load_catalog()
    k = cfg.objects_per_command
    measured = cfg.feasibility == "measured" and fulfillable is not None
    ok = _fillable_commands(scene, 1, cat, fulfillable) if measured else supported_commands(scene, k, cat)
    if not ok:
        raise MissionError(_no_command_message(scene, k, measured))
    starts = _start_poses(scene, robot_radius, grid_resolution, footprint_radius)
    out = []
    paper = [c.id for c in cat.paper_commands()]
    for i in range(cfg.n_missions):
        rng = np.random.default_rng(mission_seed(scene.id, cfg.seed, i))
        wanted = paper if i == 0 and cfg.include_paper_mission else []
        if measured:
            ids = _measured_commands(scene.id, i, ok, wanted, n=cfg.commands_per_mission, k=k, rng=rng,
                                     fulfillable=fulfillable)
        else:
            ids = _mission_commands(scene.id, i, ok, wanted, n=cfg.commands_per_mission, k=k, rng=rng)
        fills = _fills(scene.id, i, ids, k, fulfillable, measured)
        fids = sorted(starts)
        start_f = fids[int(rng.integers(len(fids)))]
        commands = tuple(_command(scene, cat, f.command, f.n_objects) for f in fills if f.n_objects > 0)
        out.append((Mission(id=f"m{i:03d}", scene_id=scene.id, start=starts[start_f], start_furniture=start_f,
                            commands=commands), fills))
    return out


def _no_command_message(scene: SceneGraph, k: int, measured: bool) -> str:
    if not measured:
        return (f"scene {scene.id!r} supports no command with {k} objects "
                f"(mission.objects_per_command); {_more_objects_advice(scene)}")
    return (f"scene {scene.id!r}: the simulator's measurement finds no command a planner can fill with even one "
            f"object: no instance of a command's categories can be picked up and placed on its targets; "
            f"{_more_objects_advice(scene)}, or use mission.feasibility=off for the unchecked draw")


def _start_poses(scene: SceneGraph, robot_radius: float, grid_resolution: float | None,
                 footprint_radius: float | None) -> dict[str, tuple[float, float, float]]:
    """furniture id -> start pose next to it, for every reachable furniture that has one."""
    res = grid_resolution or float(scene.meta.get("grid_resolution", 0.05))
    grid = rasterize(scene, res, robot_radius, doors="true")
    labels, _ = free_components(grid)
    extra = 0.0 if footprint_radius is None else float(footprint_radius) - robot_radius
    standable = clear_of_obstacles(grid.free, extra, res)
    starts = {}
    for fid in sorted(f.id for f in scene.furniture.values() if not f.unreachable):
        p = start_pose(scene, fid, grid, robot_radius, labels, standable)
        if p is not None:
            starts[fid] = p
    if not starts:
        raise MissionError(f"scene {scene.id!r}: no furniture has a free start cell on the true grid")
    return starts


def _command(scene: SceneGraph, cat: Catalog, cid: str, n_objects: int) -> Command:
    spec = cat.command(cid)
    return Command(cid, spec.text, Goal(spec.categories, spec.resolve_targets(scene), n_objects))


def _fillable_commands(scene: SceneGraph, k: int, cat: Catalog, fulfillable: Fulfillable) -> list[str]:
    """Command ids (catalog order) whose targets exist and that the measurement fills with >= k objects."""
    return [c.id for c in cat.commands if c.resolve_targets(scene) and fulfillable.fill(c.id, k) >= k]


def _demands(ids: Sequence[str], k: int, fulfillable: Fulfillable) -> list[tuple[tuple[str, ...], int]]:
    return [(tuple(fulfillable.objects.get(c, ())), min(k, int(fulfillable.capacity.get(c, 0)))) for c in ids]


def _fits(ids: Sequence[str], k: int, fulfillable: Fulfillable) -> bool:
    """True when every command of ``ids`` gets its k objects, all distinct."""
    demands = _demands(ids, k, fulfillable)
    return all(len(got) >= n for got, (_, n) in zip(match_slots(demands), demands, strict=True))


def _measured_commands(scene_id: str, index: int, ok: list[str], wanted: list[str], *, n: int, k: int,
                       rng: np.random.Generator, fulfillable: Fulfillable) -> list[str]:
    """The command ids of mission ``index`` under the measurement, among ``ok`` (those it fills with at
    least one object): the ``wanted`` ones (the paper's) it fills with k objects, the others replaced
    (one log line), then more up to ``n`` as below when ``n`` is more than the paper's; or commands in
    a random order, each kept when it and the mission's commands
    still all get k distinct objects (``_fits``). When fewer than ``n`` fit, the rest in the same
    order that still get an object, to be reduced (``_fills``); never the same command twice. Only
    the wanted ones can end up with no object (dropped)."""
    perm = [ok[int(j)] for j in rng.permutation(len(ok))]
    full = [c for c in perm if fulfillable.fill(c, k) >= k]
    ids = [c for c in wanted if c in full]
    missing = [c for c in wanted if c not in full]
    goal = max(len(wanted), n)  # the paper's commands first, then more to reach n
    for c in full:
        if len(ids) < goal and c not in ids and _fits(ids + [c], k, fulfillable):
            ids.append(c)
    for c in perm:  # too few fit in full: those that still get an object, reduced
        if len(ids) < goal and c not in ids and match_slots(_demands(ids + [c], k, fulfillable))[-1]:
            ids.append(c)
    if missing:
        log.warning("scene %s mission m%03d: the paper's command(s) %s cannot be filled with %d objects by "
                    "the simulator's measurement (target furniture, or instances a planner can pick up and "
                    "place, missing); replaced by %s", scene_id, index, missing, k,
                    [c for c in ids if c not in wanted] or "nothing")
    if len(ids) < n:
        log.warning("scene %s mission m%03d: only %d command(s) get objects distinct from each other's (of %s, "
                    "which the measurement gives at least one object each); the mission has %d, not %d "
                    "(mission.commands_per_mission)", scene_id, index, len(ids), ok, len(ids), n)
    return ids


def _fills(scene_id: str, index: int, ids: list[str], k: int, fulfillable: Fulfillable | None,
           measured: bool) -> list[CommandFill]:
    """How each command of ``ids`` is filled (``CommandFill``); measured: reduced or dropped to what
    the mission's matching fills, one log line each."""
    if fulfillable is None:
        return [CommandFill(c, k, k, k, "unchecked") for c in ids]
    demands = _demands(ids, k, fulfillable)
    matched = match_slots(demands)
    out = []
    for j, (c, got, (cands, cap)) in enumerate(zip(ids, matched, demands, strict=True)):
        m = len(got)
        if not measured:
            out.append(CommandFill(c, k, k, m, "ok" if m >= k else "short", tuple(got), cands))
            continue
        status = "ok" if m >= k else "reduced" if m else "dropped"
        if status != "ok":
            taken = sorted(set(cands) & {o for i, g in enumerate(matched) if i != j for o in g})
            log.warning("scene %s mission m%03d: command %s %s: %d of its %d objects can be delivered "
                        "(measured: %d fulfillable instance(s), its targets take %d; %s taken by the mission's "
                        "other commands)", scene_id, index, c,
                        f"reduced to {m} object(s)" if m else "dropped", m, k, len(cands), cap, taken or "none")
        out.append(CommandFill(c, k, m, m, status, tuple(got), cands))
    return out


def _mission_commands(scene_id: str, index: int, ok: list[str], wanted: list[str], *, n: int, k: int,
                      rng: np.random.Generator) -> list[str]:
    """The command ids of mission ``index``: the ``wanted`` ones (the paper's) the house can host, the
    others replaced by supported catalog commands (one log line says which and why), then drawn ones
    up to ``n`` when ``n`` is more than the paper's; or ``n`` drawn
    from the supported ones; never the same command twice, so fewer than ``n`` when the house
    supports fewer (said in one log line)."""
    if wanted:
        ids = [c for c in wanted if c in ok]
        missing = [c for c in wanted if c not in ok]
        repl = [ok[int(j)] for j in rng.permutation(len(ok)) if ok[int(j)] not in ids][:len(missing)] \
            if missing else []
        if missing:
            log.warning("scene %s mission m%03d: the paper's command(s) %s need target furniture or %d objects "
                        "the house lacks; replaced by %s", scene_id, index, missing, k, repl or "nothing")
        ids += repl
        if len(ids) < n:  # the paper's commands first, then more to reach n (no draw otherwise)
            ids += [c for c in (ok[int(j)] for j in rng.permutation(len(ok))) if c not in ids][:n - len(ids)]
    else:
        ids = [ok[int(j)] for j in rng.permutation(len(ok))[:n]]
    if len(ids) < n:
        log.warning("scene %s mission m%03d: only %d command(s) the house can host (%s); the mission has %d, "
                    "not %d (mission.commands_per_mission)", scene_id, index, len(ok), ok, len(ids), n)
    return ids


def save_missions(path: str | Path, missions: list[Mission]) -> None:
    """Write missions as canonical JSON ({"schema_version", "missions": [...]})."""
    write_json(path, {"schema_version": MISSIONS_SCHEMA_VERSION, "missions": [m.to_dict() for m in missions]})


def load_missions(path: str | Path) -> list[Mission]:
    """Read a missions file written by ``save_missions``; errors name the file and the key."""
    d = read_json(path)
    if not isinstance(d, dict) or "missions" not in d:
        raise MissionError(f"{path}: expected an object with key 'missions' (written by save_missions)")
    out = []
    for i, m in enumerate(d["missions"]):
        try:
            out.append(Mission.from_dict(m))
        except (KeyError, TypeError, ValueError) as e:
            raise MissionError(f"{path}: $.missions[{i}]: invalid mission ({type(e).__name__}: {e})") from None
    return out
