"""Missions: sequences of household commands with ground-truth goals resolved in one scene.

Mission 0 is the paper's three commands (breakfast, meeting, reading) when
``MissionConfig.include_paper_mission``; the others draw ``commands_per_mission`` distinct commands
among those the scene supports (target furniture present and enough valid objects), seeded by
``core.seeding.mission_seed`` of (scene id, mission seed, mission index) so the result never depends on the
process. The robot starts on a free cell of the TRUE grid (hence also of the presumed one) in the
largest free region, next to a start furniture, facing it.
"""

from __future__ import annotations

import logging
import math
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
    approach_cells,
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
    cells = approach_cells(grid, f.footprint, robot_radius + REACH_MARGIN)
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


def _more_objects_advice(scene: SceneGraph) -> str:
    """How to get a scene with more objects: a generated one can be generated larger; an imported one
    (scene.import_path) needs the objects in its file, or fewer per command."""
    if scene.meta.get("generator"):
        return "generate a larger scene"
    return ("add objects the commands use to the scene file (scene.import_path), or lower "
            "mission.objects_per_command")


def generate_missions(scene: SceneGraph, cfg: MissionConfig, robot_radius: float = 0.25,
                      grid_resolution: float | None = None, catalog: Catalog | None = None,
                      footprint_radius: float | None = None) -> list[Mission]:
    """``cfg.n_missions`` missions for ``scene`` (deterministic in scene id and cfg.seed).

    robot_radius: base radius [m] (grid inflation for the start pose).
    footprint_radius: [m] the base's true contact radius (``sim.footprint_radius``); a start pose
        keeps the whole footprint clear of obstacles where it can (None: the grid's radius will do).
    grid_resolution: [m] per cell; default ``scene.meta["grid_resolution"]`` or 0.05.
    """
    cfg.validate()
    cat = catalog or load_catalog()
    k = cfg.objects_per_command
    ok = supported_commands(scene, k, cat)
    if not ok:
        raise MissionError(f"scene {scene.id!r} supports no command with {k} objects "
                           f"(mission.objects_per_command); {_more_objects_advice(scene)}")
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

    def command(cid: str) -> Command:
        spec = cat.command(cid)
        return Command(cid, spec.text, Goal(spec.categories, spec.resolve_targets(scene), k))

    out = []
    paper = [c.id for c in cat.paper_commands()]
    for i in range(cfg.n_missions):
        rng = np.random.default_rng(mission_seed(scene.id, cfg.seed, i))
        ids = _mission_commands(scene.id, i, ok, paper if i == 0 and cfg.include_paper_mission else [],
                                cfg.commands_per_mission, k, rng)
        fids = sorted(starts)
        start_f = fids[int(rng.integers(len(fids)))]
        out.append(Mission(id=f"m{i:03d}", scene_id=scene.id, start=starts[start_f], start_furniture=start_f,
                           commands=tuple(command(c) for c in ids)))
    return out


def _mission_commands(scene_id: str, index: int, ok: list[str], wanted: list[str], n: int, k: int,
                      rng: np.random.Generator) -> list[str]:
    """The command ids of mission ``index``: the ``wanted`` ones (the paper's) the house can host, the
    others replaced by supported catalog commands (one log line says which and why), or ``n`` drawn
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
