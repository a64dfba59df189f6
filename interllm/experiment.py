"""The experiment's stages as plain library functions (no hydra, no dvc).

Each function reads its inputs from folders, calls the subpackages and writes its outputs
atomically. ``pipeline/*.py`` are the thin DVC stage entry points around them;
``pipeline/run.py`` chains all of them for Hydra single runs and multiruns.

Layout under ``data_dir`` (see DESIGN.md):
  scenes/<scene_id>/{scene.json, grid.npz, scene.xml, missions.json, topdown.png}
  candidates/<scene_id>.json
  runs/<planner>/<scene_id>/<mission_id>.{json,mcap} + runs/llm_calls.jsonl + runs/provenance.json
  metrics/{metrics.json, per_object.csv, cumulative.csv, ...}
  report/{report.md, report.html, figures/*.png}
"""

from __future__ import annotations

import json
import logging
from collections.abc import Iterable
from pathlib import Path

from interllm.config import ExperimentConfig
from interllm.errors import MissingInputError, StageError, UserError
from interllm.io import atomic_write_bytes, atomic_write_text, read_json, write_json
from interllm.progress import progress
from interllm.provenance import for_run_log, provenance

log = logging.getLogger(__name__)


def scene_ids(scenes_dir: Path) -> list[str]:
    ids = sorted(p.name for p in Path(scenes_dir).iterdir() if (p / "scene.json").is_file())
    if not ids:
        raise MissingInputError(f"no scenes in {scenes_dir}: run the 'scenes' stage first "
                                f"(dvc repro scenes)")
    return ids


# --------------------------------------------------------------------------------------------
def run_scenes(cfg: ExperimentConfig, out_dir: Path) -> list[str]:
    """Generate (or import) the experiment's scenes with their grids, MuJoCo world and missions."""
    from interllm.scene import (
        generate_missions,
        generate_scene,
        load_scene_file,
        render_topdown,
        save_missions,
    )
    from interllm.scene.grid import rasterize
    from interllm.sim.build import build_world_spec

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    ids = []
    n = 1 if cfg.scene.import_path else cfg.scene.n_scenes
    for i in progress(range(n), "scenes", total=n):
        scene = load_scene_file(cfg.scene.import_path) if cfg.scene.import_path else generate_scene(
            cfg.scene, i, robot_radius=cfg.sim.robot_radius)
        d = out_dir / scene.id
        d.mkdir(parents=True, exist_ok=True)
        atomic_write_text(d / "scene.json", scene.to_json())
        presumed = rasterize(scene, cfg.scene.grid_resolution, cfg.sim.robot_radius, doors="presumed")
        true = rasterize(scene, cfg.scene.grid_resolution, cfg.sim.robot_radius, doors="true")
        atomic_write_bytes(d / "grid.npz", presumed.to_npz_bytes(true_occupied=true.occupied))
        spec = build_world_spec(scene, robot=False, sim_cfg=cfg.sim)
        atomic_write_text(d / "scene.xml", spec.to_xml())
        missions = generate_missions(scene, cfg.mission, cfg.sim.robot_radius, cfg.scene.grid_resolution)
        save_missions(d / "missions.json", missions)
        render_topdown(scene, d / "topdown.png", grid=presumed)
        ids.append(scene.id)
    return ids


def _load_scene_and_missions(scenes_dir: Path, sid: str, cfg: ExperimentConfig):
    from interllm.scene import load_missions
    from interllm.scene.graph import SceneGraph

    d = Path(scenes_dir) / sid
    scene = SceneGraph.from_json((d / "scene.json").read_text())
    missions = load_missions(d / "missions.json")
    if cfg.mission.limit_missions:
        missions = missions[: cfg.mission.limit_missions]
    return scene, missions


def _client(cfg: ExperimentConfig, call_log: Path | None, stage: str):
    from interllm.llm import make_client

    return make_client(cfg.llm, call_log_path=call_log).with_context(stage=stage)


# --------------------------------------------------------------------------------------------
def run_candidates(cfg: ExperimentConfig, scenes_dir: Path, out_dir: Path) -> None:
    """The M initial plan candidates of every command, shared by every planner."""
    from interllm.llm.client import check_failure_share
    from interllm.planners.candidates import generate_initial_candidates

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    call_log = out_dir / "llm_calls.jsonl"
    call_log.unlink(missing_ok=True)  # what an earlier (killed) run left here
    client = _client(cfg, call_log, "candidates")
    try:
        jobs = [(sid, m) for sid in scene_ids(scenes_dir)
                for m in _load_scene_and_missions(scenes_dir, sid, cfg)[1]]
        by_scene: dict[str, dict] = {}
        scenes = {sid: _load_scene_and_missions(scenes_dir, sid, cfg)[0] for sid in scene_ids(scenes_dir)}
        for sid, mission in progress(jobs, "candidates", total=len(jobs)):
            c = client.with_context(scene=sid, mission=mission.id)
            by_scene.setdefault(sid, {})[mission.id] = generate_initial_candidates(
                scenes[sid], mission, c, cfg)
        check_failure_share(call_log, cfg.llm, "candidates stage")  # before any candidates are written
        for sid, cands in by_scene.items():
            write_json(out_dir / f"{sid}.json", cands)
    finally:
        client.close()


# --------------------------------------------------------------------------------------------
class _MissionWorker:
    """What running missions needs once per process: the config, an LLM client, the robot model,
    and the scenes, grids and candidates already loaded (by scene id)."""

    def __init__(self, cfg: ExperimentConfig, scenes_dir: Path, candidates_dir: Path, out_dir: Path,
                 prov: dict, call_log: Path) -> None:
        from interllm.sim.kinematics import RobotKinematics

        self.cfg, self.scenes_dir, self.candidates_dir, self.out_dir, self.prov = (
            cfg, Path(scenes_dir), Path(candidates_dir), Path(out_dir), for_run_log(prov))
        self.client = _client(cfg, call_log, "missions")
        self.robot = RobotKinematics(cfg.sim)  # arm link frames on /tf, the robot's shape on /scene
        self._scenes: dict[str, tuple] = {}

    def scene(self, sid: str) -> tuple:
        if sid not in self._scenes:
            from interllm.scene.grid import rasterize

            scene, missions = _load_scene_and_missions(self.scenes_dir, sid, self.cfg)
            g = self.cfg.scene.grid_resolution, self.cfg.sim.robot_radius
            grids = {"presumed": rasterize(scene, *g, "presumed"), "true": rasterize(scene, *g, "true")}
            self._scenes[sid] = (scene, {m.id: m for m in missions}, grids,
                                 read_json(self.candidates_dir / f"{sid}.json"))
        return self._scenes[sid]

    def run(self, planner: str, sid: str, mission_id: str) -> None:
        from interllm.planners.runner import run_mission
        from interllm.record import McapRecorder

        scene, missions, grids, cands = self.scene(sid)
        mission = missions[mission_id]
        if mission_id not in cands:
            raise KeyError(f"{self.candidates_dir / (sid + '.json')} has no candidates for mission {mission_id!r} "
                           f"(it has {sorted(cands)}): rerun the candidates stage (dvc repro candidates)")
        d = self.out_dir / planner / sid
        d.mkdir(parents=True, exist_ok=True)
        meta = {"planner": planner, "scene": sid, "mission": mission_id, **self.prov}
        c = self.client.with_context(planner=planner, scene=sid, mission=mission_id)
        with McapRecorder(d / f"{mission_id}.mcap", scene, meta, grids=grids, robot=self.robot) as rec:
            record = run_mission(planner, scene, mission, cands[mission_id], c, self.cfg, rec)
        write_json(d / f"{mission_id}.json", record)


_WORKER: _MissionWorker | None = None  # the worker process's state (see _init_worker)


def _init_worker(*args) -> None:
    global _WORKER
    _WORKER = _MissionWorker(*args)


def _run_in_worker(job: tuple[str, str, str]) -> None:
    """Run one job in a worker; a failure comes back as a RuntimeError naming the job, with the
    worker's traceback (the original exception may not survive pickling to the parent)."""
    import traceback

    from interllm.provenance import log_loaded_modules

    assert _WORKER is not None, "_init_worker did not run in this process"
    try:
        _WORKER.run(*job)
    except UserError as e:  # a fixable problem: its message is enough (and pickles)
        raise StageError(_failed(job, e, _WORKER.out_dir)) from None
    except Exception as e:
        raise RuntimeError(_failed(job, e, _WORKER.out_dir) + "\n" + traceback.format_exc()) from None
    log_loaded_modules("missions")


def _merge_call_logs(parts: list[Path], out: Path, jobs: list[tuple[str, str, str]]) -> None:
    """Join the workers' call logs into one, in job order (then each worker's own order)."""
    order = {(p, s, m): k for k, (p, s, m) in enumerate(jobs)}
    rows = []
    for part in parts:
        if not part.is_file():
            continue
        for n, line in enumerate(part.read_text(encoding="utf-8").splitlines()):
            if line.strip():
                r = json.loads(line)
                key = order.get((r.get("planner"), r.get("scene"), r.get("mission")), len(jobs))
                rows.append((key, n, line))
    atomic_write_text(out, "".join(line + "\n" for _, _, line in sorted(rows)))
    for part in parts:
        part.unlink(missing_ok=True)


def run_missions(cfg: ExperimentConfig, scenes_dir: Path, candidates_dir: Path, out_dir: Path,
                 resolved_config: dict | None = None) -> None:
    """Every planner on every mission: MuJoCo execution, MCAP logs and mission records.

    Runs in ``cfg.jobs`` worker processes (0: one per CPU core). Every run's files depend only on
    its own inputs, so the outputs are the same for any number of workers; the LLM call log is
    merged in job order.
    """
    import concurrent.futures as cf
    import dataclasses
    import multiprocessing
    import os

    from interllm.llm.client import check_failure_share

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    prov = provenance(cfg, resolved_config)
    write_json(out_dir / "provenance.json", prov)
    jobs = [(p, sid, m.id) for sid in scene_ids(scenes_dir)
            for m in _load_scene_and_missions(scenes_dir, sid, cfg)[1] for p in cfg.planner.names]
    n_workers = min(cfg.jobs or usable_cores(), len(jobs))
    call_log = out_dir / "llm_calls.jsonl"
    parts = [out_dir / f".llm_calls.worker{k}.jsonl" for k in range(max(n_workers, 1))]
    for f in (call_log, *out_dir.glob(".llm_calls.worker*.jsonl")):  # whatever a killed run left here
        f.unlink(missing_ok=True)
    if n_workers <= 1:
        worker = _MissionWorker(cfg, scenes_dir, candidates_dir, out_dir, prov, call_log)
        try:
            for job in progress(jobs, "missions", total=len(jobs)):
                try:
                    worker.run(*job)
                except UserError as e:
                    raise StageError(_failed(job, e, out_dir)) from e
                except Exception as e:
                    raise RuntimeError(_failed(job, e, out_dir)) from e
        finally:
            worker.client.close()
        check_failure_share(call_log, cfg.llm, "missions stage")
        return
    # each worker's model gets its share of the LLM threads (llama.cpp's results do not depend on
    # the thread count; oversubscribed threads only spin)
    wcfg = dataclasses.replace(cfg, llm=dataclasses.replace(cfg.llm, n_threads=max(1, cfg.llm.n_threads // n_workers)))
    ctx = multiprocessing.get_context("spawn")  # no fork of a parent with threads (progress bar)
    ids = ctx.Queue()
    for part in parts:
        ids.put(part)
    with cf.ProcessPoolExecutor(n_workers, mp_context=ctx, initializer=_init_worker_part,
                                initargs=(os.getpid(), ids, wcfg, scenes_dir, candidates_dir, out_dir, prov)) as pool:
        futures = {pool.submit(_run_in_worker, job): job for job in jobs}
        try:
            for fut in progress(cf.as_completed(futures), f"missions ({n_workers} workers)", total=len(jobs)):
                try:
                    fut.result()
                except cf.process.BrokenProcessPool as e:  # every pending job sees this, not only the
                    raise RuntimeError(                      # one whose worker died: name none of them
                        f"missions stage: a worker process died (killed, out of memory?) while running "
                        f"{len(jobs)} jobs in {n_workers} workers; rerun with jobs=1 to run them in one "
                        f"process and see which one fails") from e
        except BaseException:
            pool.shutdown(cancel_futures=True)
            raise
        finally:
            _merge_call_logs(parts, call_log, jobs)  # also after a failure: the calls made so far
    check_failure_share(call_log, cfg.llm, "missions stage")


def usable_cores() -> int:
    """The cores this process may run on (CPU affinity: taskset, SLURM, containers), not the machine's."""
    import os

    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _failed(job: tuple[str, str, str], e: BaseException, out_dir: Path) -> str:
    log = Path(out_dir) / job[0] / job[1] / f"{job[2]}.mcap"
    return (f"missions stage: planner {job[0]!r} on scene {job[1]!r} mission {job[2]!r} failed: "
            f"{type(e).__name__}: {e} (its run log, if any: {log} or {log}.partial)")


def _init_worker_part(parent: int, ids, cfg, scenes_dir, candidates_dir, out_dir, prov) -> None:
    """Worker initializer: die with the parent (a killed stage leaves no worker behind), take a
    call-log file of its own, then set up the worker state."""
    from interllm.lifetime import die_with_parent

    die_with_parent(parent)
    _init_worker(cfg, scenes_dir, candidates_dir, out_dir, prov, ids.get(timeout=60))


# --------------------------------------------------------------------------------------------
def run_aggregate(cfg: ExperimentConfig, runs_dir: Path, scenes_dir: Path, out_dir: Path,
                  candidates_dir: Path | None = None) -> dict:
    """metrics.json and the tidy tables; environment.json records the numerical environment, CPU
    and packages the runs were made with (from runs/provenance.json), so that a reproduction on
    another machine can say what differs (tests/test_reproduce.py, ``interllm results diff``)."""
    from interllm.metrics import aggregate
    from interllm.numerics import environment_record

    logs = {"missions": Path(runs_dir) / "llm_calls.jsonl"}
    if candidates_dir is not None:
        logs["candidates"] = Path(candidates_dir) / "llm_calls.jsonl"
    metrics = aggregate(Path(runs_dir), Path(scenes_dir), cfg, out_dir=Path(out_dir), call_logs=logs)
    prov_path = Path(runs_dir) / "provenance.json"
    prov = read_json(prov_path) if prov_path.is_file() else {}
    write_json(Path(out_dir) / "environment.json", environment_record(prov))
    return metrics


def run_report(cfg: ExperimentConfig, metrics_dir: Path, scenes_dir: Path, runs_dir: Path,
               out_dir: Path, temperature_results: Iterable[tuple[str, Path]] = (),
               m_results: Iterable[tuple[str, Path]] = ()) -> None:
    """The report; ablation results are (label, metrics_dir) pairs, gathered where they exist."""
    from interllm.metrics.report import build_report

    build_report(Path(metrics_dir), Path(scenes_dir), Path(runs_dir), Path(out_dir), cfg,
                 temperature_results=list(temperature_results), m_results=list(m_results))


def run_all(cfg: ExperimentConfig, data_dir: Path, resolved_config: dict | None = None) -> dict:
    """All five stages in order into ``data_dir`` (Hydra runs and multiruns)."""
    from interllm.llm.client import preflight

    preflight(cfg.llm)  # a server that is down stops the run before any stage writes
    data_dir = Path(data_dir)
    run_scenes(cfg, data_dir / "scenes")
    run_candidates(cfg, data_dir / "scenes", data_dir / "candidates")
    run_missions(cfg, data_dir / "scenes", data_dir / "candidates", data_dir / "runs", resolved_config)
    metrics = run_aggregate(cfg, data_dir / "runs", data_dir / "scenes", data_dir / "metrics",
                            data_dir / "candidates")
    run_report(cfg, data_dir / "metrics", data_dir / "scenes", data_dir / "runs", data_dir / "report")
    return metrics


__all__ = ["run_scenes", "run_candidates", "run_missions", "run_aggregate", "run_report", "run_all",
           "scene_ids"]


def find_sweep_results(*roots: Path) -> tuple[list[tuple[str, Path]], list[tuple[str, Path]]]:
    """Ablation results of Hydra multiruns under ``roots``: jobs whose ``.hydra/config.yaml`` says
    experiment=temperature_ablation or m_ablation and that produced ``data/metrics/metrics.json``.

    Returns (temperature_results, m_results) as (label, metrics_dir) pairs, sorted by value.
    """
    import yaml

    temps: list[tuple[float, Path]] = []
    ms: list[tuple[int, Path]] = []
    for root in roots:
        for cfg_file in sorted(Path(root).rglob(".hydra/config.yaml")):
            job = cfg_file.parent.parent
            metrics = job / "data" / "metrics"
            if not (metrics / "metrics.json").is_file():
                continue
            c = yaml.safe_load(cfg_file.read_text()) or {}
            if c.get("experiment") == "temperature_ablation":
                temps.append((float(c["llm"]["temperature"]), metrics))
            elif c.get("experiment") == "m_ablation":
                ms.append((int(c["planner"]["M"]), metrics))
    return ([(f"{t:.1f}", p) for t, p in sorted(temps)], [(f"M={m}", p) for m, p in sorted(ms)])
