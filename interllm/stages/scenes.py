"""Stage scenes: scene graphs (generated or imported), occupancy grids, MuJoCo worlds, missions,
the measured feasibility of the missions' commands, the manipulation measurements behind it (for the
stages after: ``sim.measurements``) and top-down pictures (objects the robot cannot pick up crossed
out in red)."""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import logging
import multiprocessing
import os
import traceback
from pathlib import Path
from typing import Optional

from interllm.config import MAX_SCENES, ExperimentConfig
from interllm.errors import MissingInputError, StageError, UserError, output_error
from interllm.io import atomic_write_bytes, atomic_write_text, child_path, ensure_dir, read_json, write_json
from interllm.lifetime import die_with_parent
from interllm.progress import progress
from interllm.scene.benchmark import (
    Benchmark,
    benchmark_section,
    drawn_with,
    open_benchmark,
    pickups_changed,
    recheck,
)
from interllm.scene.catalog import Catalog, load_catalog
from interllm.scene.generator import generate_scene
from interllm.scene.graph import SceneGraph
from interllm.scene.grid import OccupancyGrid, clear_of_obstacles, free_components, rasterize
from interllm.scene.missions import draw_missions, save_missions, standable_start
from interllm.scene.open_commands import commands_for
from interllm.scene.render import render_topdown
from interllm.scene.validate import SceneValidationError, load_scene_file
from interllm.sim.build import build_world_spec
from interllm.sim.measurements import MEASUREMENTS_FILE
from interllm.stages.feasibility import SceneFeasibility, feasibility_record, measure_scene
from interllm.stages.workers import leave_ctrl_c_to_parent, usable_cores

log = logging.getLogger(__name__)


def open_configured_benchmark(cfg: ExperimentConfig) -> Optional[Benchmark]:
    """The benchmark the config names (``benchmark``), checked against the scene and mission config
    it was drawn with (``cfg`` as the stages run it: seeds offset by the replicate); None when the
    missions are drawn from this run's measurement."""
    if not cfg.benchmark:
        return None
    bench = open_benchmark(cfg.benchmark_dir, cfg.benchmark)
    bench.check_config(drawn_with(cfg.seed, cfg.scene, cfg.mission), scene_count(cfg, bench),
                       cfg.mission.n_missions)
    return bench


def imported_files(import_path: str) -> list[Path]:
    """The scene files ``scene.import_path`` names: the file itself, or, for a folder, every
    ``<folder>/<house>/scene.json`` (sorted by house folder: what ``interllm scene import-procthor
    house.json --out <folder>/<house>/`` writes), so several imported houses form one experiment."""
    p = Path(import_path)
    if not p.is_dir():
        return [p]  # a missing file is named by load_scene_file
    files = sorted(f for f in p.glob("*/scene.json") if f.is_file())
    if not files:
        hint = f"name it: scene.import_path={p / 'scene.json'}" if (p / "scene.json").is_file() else (
            f"import each house into a folder of its own (interllm scene import-procthor house.json --out "
            f"{p / 'house_1'}/), or name one scene.json")
        raise MissingInputError(f"scene.import_path={import_path} is a folder without <house>/scene.json files: {hint}")
    if len(files) > MAX_SCENES:
        raise MissingInputError(f"scene.import_path={import_path} holds {len(files)} houses, more than the {MAX_SCENES} "
                                f"an experiment accepts (as scene.n_scenes); split them over experiments")
    return files


def scene_count(cfg: ExperimentConfig, bench: Optional[Benchmark] = None) -> int:
    """Scenes of the experiment: scene.n_scenes generated houses (or the first of a benchmark's), or
    every imported house (of the import folder, or all those a benchmark froze from one)."""
    if not cfg.scene.import_path:
        return cfg.scene.n_scenes
    return len(bench.scenes_frozen) if bench is not None else len(imported_files(cfg.scene.import_path))


def check_distinct_ids(files: list[Path]) -> None:
    """SceneValidationError naming both files when two imported houses have one ``$.id`` (checked
    before any is written: two houses would write one folder)."""
    seen: dict[str, Path] = {}
    for f in files:
        sid = read_json(f).get("id") if f.is_file() else None
        if isinstance(sid, str) and sid in seen:
            raise SceneValidationError(str(f), "$.id", f"{sid!r} is also the id of {seen[sid]}: each house of an "
                                                       f"experiment needs its own; change one")
        if isinstance(sid, str):
            seen[sid] = f


def make_scene(cfg: ExperimentConfig, index: int, bench: Optional[Benchmark] = None) -> SceneGraph:
    """Scene ``index`` of the experiment: the benchmark's frozen house, imported house ``index``
    (scene.import_path) or a generated one."""
    if bench is not None:  # reachability judged for the configured robot, as for an imported house
        return load_scene_file(bench.path(bench.scenes_frozen[index], "scene.json"), robot_radius=cfg.sim.robot_radius,
                               resolution=cfg.scene.grid_resolution)
    if cfg.scene.import_path:  # reachability judged for the configured robot, as `scene import-procthor` does
        return load_scene_file(imported_files(cfg.scene.import_path)[index], robot_radius=cfg.sim.robot_radius,
                               resolution=cfg.scene.grid_resolution)
    return generate_scene(cfg.scene, index, robot_radius=cfg.sim.robot_radius,
                          objects_per_command=cfg.mission.objects_per_command,
                          footprint_radius=cfg.sim.footprint_radius)


def scene_commands(cfg: ExperimentConfig, scene: SceneGraph) -> Catalog:
    """The catalog whose commands the scene's missions draw from (``mission.commands``: the catalog's,
    and commands generated from what the house holds; ``scene.open_commands``)."""
    return commands_for(scene, load_catalog(), cfg.mission.commands, cfg.mission.objects_per_command)


def measure(cfg: ExperimentConfig, scene: SceneGraph, grids: dict[str, OccupancyGrid], cat: Catalog | None = None):
    """The simulator's measurement of a scene's commands (``stages.feasibility.measure_scene``; those
    of ``cat``, default ``scene_commands``), as much as a mission of the config can use."""
    k = cfg.mission.objects_per_command
    return measure_scene(scene, cfg.sim, cfg.scene.grid_resolution, k, grids,
                         need=k * cfg.mission.commands_per_mission, all_pickups=cfg.scene.reach_report,
                         catalog=cat if cat is not None else scene_commands(cfg, scene))


def object_design(scene: SceneGraph) -> str:
    """feasibility.json's ``object_design``: the generator's, or "imported"."""
    return scene.meta.get("object_design", "legacy") if scene.meta.get("generator") else "imported"


def scene_missions(cfg: ExperimentConfig, scene: SceneGraph, grids: dict[str, OccupancyGrid],
                   meas: SceneFeasibility | None = None, cat: Catalog | None = None) -> tuple[list, dict]:
    """The missions of a scene and its ``feasibility.json`` document: the simulator measures which
    instances each command of ``cat`` (default ``scene_commands``) can get (``stages.feasibility``;
    ``meas`` when already measured), the draw uses that with mission.feasibility=measured (and records
    it either way)."""
    cat = cat if cat is not None else scene_commands(cfg, scene)
    meas = meas if meas is not None else measure(cfg, scene, grids, cat)
    drawn = draw_missions(scene, cfg.mission, cfg.sim.robot_radius, cfg.scene.grid_resolution, catalog=cat,
                          footprint_radius=cfg.sim.footprint_radius, fulfillable=meas.fulfillable())
    record = feasibility_record(meas, drawn, cfg.mission.feasibility, object_design(scene),
                                cfg.mission.commands_per_mission)
    return [m for m, _ in drawn], record


def benchmark_missions(cfg: ExperimentConfig, bench: Benchmark, scene: SceneGraph,
                       grids: dict[str, OccupancyGrid], meas: SceneFeasibility | None = None) -> tuple[list, dict]:
    """The benchmark's frozen missions of a scene and its ``feasibility.json`` document: measured as
    ``scene_missions`` does, the frozen missions re-filled by that measurement (``recheck``), starts
    that the current robot cannot stand on moved (``moved_starts``), and a ``benchmark`` section
    naming what changed since freezing (one warning line per change)."""
    meas = meas if meas is not None else measure(cfg, scene, grids)
    frozen = bench.feasibility(scene.id)
    missions = bench.missions(scene.id)[:cfg.mission.n_missions]
    drawn, changes = recheck(missions, frozen, meas.fulfillable(), cfg.mission.objects_per_command,
                             str(bench.root / scene.id / "feasibility.json"))
    moved = moved_starts(cfg, scene, drawn, grids["true"])
    record = feasibility_record(meas, drawn, cfg.mission.feasibility, object_design(scene),
                                cfg.mission.commands_per_mission)
    record["benchmark"] = benchmark_section(bench, changes, pickups_changed(frozen, record["objects"]), moved,
                                            slots=sum(f.n_objects for _, fs in drawn for f in fs))
    for c in changes:
        log.warning("benchmark %s, scene %s mission %s: command %s measures differently than when frozen: %d of its "
                    "slots fillable then, %d now (instances no longer fulfillable: %s; newly: %s)", bench.name, scene.id,
                    c.mission, c.command, c.slots_then, c.slots_now, list(c.lost) or "none", list(c.gained) or "none")
    for mid in moved:
        log.warning("benchmark %s, scene %s mission %s: this robot cannot stand at the frozen start (sim.robot_radius, "
                    "sim.footprint_radius); moved where the draw would put it, by the same furniture", bench.name,
                    scene.id, mid)
    return [m for m, _ in drawn], record


def moved_starts(cfg: ExperimentConfig, scene: SceneGraph, drawn: list, grid: OccupancyGrid) -> list[str]:
    """Replace in ``drawn`` ((mission, fills) pairs) each start the configured robot cannot stand on
    (``missions.standable_start``); returns the ids of the missions whose start moved."""
    labels, _ = free_components(grid)
    standable = clear_of_obstacles(grid.free, cfg.sim.footprint_radius - cfg.sim.robot_radius, grid.resolution)
    moved = []
    for j, (mission, fills) in enumerate(drawn):
        start = standable_start(scene, mission, grid, cfg.sim.robot_radius, cfg.sim.footprint_radius, labels, standable)
        if start != mission.start:
            moved.append(mission.id)
            drawn[j] = (dataclasses.replace(mission, start=start), fills)
    return moved


UNPICKABLE_MARKER = ("x", "#d62828")  # topdown.png: an object the robot cannot pick up (matplotlib marker, colour)


def unpickable_markers(scene: SceneGraph, record: dict) -> list[tuple[float, float, str, str]]:
    """topdown.png markers on the objects whose measured pickup never succeeded (feasibility.json)."""
    return [(scene.objects[o].position[0], scene.objects[o].position[1], *UNPICKABLE_MARKER)
            for o, e in sorted(record["objects"].items()) if e["pickup_sr"] <= 0]


def run_scenes(cfg: ExperimentConfig, out_dir: Path) -> list[str]:
    """Write every scene of the experiment into ``out_dir/<scene_id>/``; returns the scene ids.

    The houses are independent, so they are written in ``jobs`` worker processes (default: one per
    usable core; ``jobs=1`` writes them in this process); each house's files are a function of the
    config and its index alone, the same bytes however many workers write them."""
    bench = open_configured_benchmark(cfg)  # a config it was not drawn with fails before anything is written
    out_dir = ensure_dir(out_dir)
    n = scene_count(cfg, bench)
    if cfg.scene.import_path and bench is None:
        check_distinct_ids(imported_files(cfg.scene.import_path))
    n_workers = min(cfg.jobs or usable_cores(), n)
    if n_workers <= 1:
        return [write_scene(cfg, i, bench, out_dir) for i in progress(range(n), "scenes", total=n)]
    return _write_in_workers(cfg, n, out_dir, n_workers)


def write_scene(cfg: ExperimentConfig, index: int, bench: Optional[Benchmark], out_dir: Path) -> str:
    """Scene ``index``: its graph, grids, MuJoCo world, measurement, missions and top-down picture in
    ``out_dir/<scene_id>/``; returns the scene id."""
    scene = make_scene(cfg, index, bench)
    d = ensure_dir(child_path(out_dir, scene.id, what="the scene id ($.id of the scene)"))
    atomic_write_text(d / "scene.json", scene.to_json())
    presumed = rasterize(scene, cfg.scene.grid_resolution, cfg.sim.robot_radius, doors="presumed")
    true = rasterize(scene, cfg.scene.grid_resolution, cfg.sim.robot_radius, doors="true")
    atomic_write_bytes(d / "grid.npz", OccupancyGrid.pair_npz_bytes(presumed, true, cfg.sim.robot_radius))
    atomic_write_text(d / "scene.xml", build_world_spec(scene, robot=False, sim_cfg=cfg.sim).to_xml())
    grids = {"presumed": presumed, "true": true}
    cat = scene_commands(cfg, scene)
    meas = measure(cfg, scene, grids, cat)
    missions, record = benchmark_missions(cfg, bench, scene, grids, meas) if bench else \
        scene_missions(cfg, scene, grids, meas, cat)
    save_missions(d / "missions.json", missions)
    write_json(d / "feasibility.json", record)
    meas.measurements.write(d / MEASUREMENTS_FILE)  # what the stages after need not measure again
    render_topdown(scene, d / "topdown.png", grid=presumed, markers=unpickable_markers(scene, record))
    return scene.id


def _write_in_workers(cfg: ExperimentConfig, n: int, out_dir: Path, n_workers: int) -> list[str]:
    ctx = multiprocessing.get_context("spawn")  # no fork of a parent with threads (progress bar)
    with cf.ProcessPoolExecutor(n_workers, mp_context=ctx, initializer=_init_worker, initargs=(os.getpid(),)) as pool:
        futures = {pool.submit(_write_in_worker, cfg, i, out_dir): i for i in range(n)}
        try:
            for fut in progress(cf.as_completed(futures), f"scenes ({n_workers} workers)", total=n):
                fut.result()
        except cf.process.BrokenProcessPool:
            raise StageError(f"scenes stage: a worker process died (killed, out of memory?) while writing {n} "
                             f"scenes in {n_workers} workers; rerun with jobs=1 to write them in one process and "
                             f"see which one fails (the finished scenes are kept)") from None
        except BaseException:
            pool.shutdown(cancel_futures=True)
            raise
    return [f.result() for f in sorted(futures, key=futures.get)]  # in scene order


def _init_worker(parent: int) -> None:
    """Worker initializer: die with the parent, leave a Ctrl-C to it (``workers.leave_ctrl_c_to_parent``) and
    log warnings as the stage's own process does."""
    die_with_parent(parent)
    leave_ctrl_c_to_parent()
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")


def _write_in_worker(cfg: ExperimentConfig, index: int, out_dir: Path) -> str:
    """:func:`write_scene` in a worker; a failure comes back naming the scene (a user-fixable one as its
    message, any other with the worker's traceback: the original may not survive pickling)."""
    try:
        return write_scene(cfg, index, open_configured_benchmark(cfg), out_dir)
    except UserError as e:
        raise StageError(f"scenes stage: scene {index} failed: {e}") from None
    except Exception as e:
        if (unwritable := output_error(e)) is not None:  # a full disk, a read-only folder
            raise StageError(f"scenes stage: scene {index} failed: {unwritable}") from None
        raise RuntimeError(f"scenes stage: scene {index} failed: {type(e).__name__}: {e}\n"
                           f"{traceback.format_exc()}") from None
