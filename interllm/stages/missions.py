"""Stage missions: every planner on every mission in MuJoCo, logged to MCAP, one typed mission
record per run.

Runs in ``jobs`` worker processes (0: one per usable core). Every run's files depend only on its
own inputs, so the outputs are the same for any number of workers; the LLM call log is merged in
job order. Workers die with the stage (``interllm.lifetime``), so a killed stage leaves nothing
running.
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import multiprocessing
import os
import traceback
from pathlib import Path

from interllm.config import ExperimentConfig
from interllm.core.records import PLANNERS_FILE, MissionRecord
from interllm.errors import StageError, UserError, output_error
from interllm.imports_log import log_loaded_modules
from interllm.io import check_name, child_path, ensure_dir, read_json, write_json
from interllm.lifetime import die_with_parent
from interllm.llm.health import check_failure_share
from interllm.planners.base import PLANNERS, shown_planners
from interllm.planners.runner import run_mission
from interllm.progress import progress
from interllm.record.recorder import McapRecorder
from interllm.record.topics import COMMAND_RESULTS_TOPIC
from interllm.scene.graph import SceneGraph
from interllm.sim.kinematics import RobotKinematics
from interllm.sim.measurements import MEASUREMENTS_FILE, MeasurementStore
from interllm.sim.world import World
from interllm.stages.inputs import PROBE_FILE, load_grids, load_scene_and_missions, scene_ids, stage_client
from interllm.stages.provenance import for_run_log, provenance
from interllm.stages.validate import check_registered, import_planner_modules
from interllm.stages.workers import Job, failed_message, leave_ctrl_c_to_parent, merge_call_logs, usable_cores


class MissionWorker:
    """What running missions needs once per process: the config, an LLM client, the robot model,
    and the scenes, grids, candidates and worlds already loaded (by scene id; ``run_mission`` resets
    the world to each mission's start, so results do not depend on which runs a worker did before)."""

    def __init__(self, cfg: ExperimentConfig, scenes_dir: Path, candidates_dir: Path, out_dir: Path,
                 prov: dict, call_log: Path) -> None:
        self.cfg, self.scenes_dir, self.candidates_dir, self.out_dir, self.prov = (
            cfg, Path(scenes_dir), Path(candidates_dir), Path(out_dir), for_run_log(prov))
        import_planner_modules(cfg)  # a worker process registers the planners defined outside the package too
        self.client = stage_client(cfg, call_log, "missions", probe=prov.get("llm_probe"))
        self.robot = RobotKinematics(cfg.sim)  # arm link frames on /tf, the robot's shape on /scene
        self._scenes: dict[str, tuple] = {}
        self._worlds: dict[str, World] = {}  # one per scene, reset for each mission run

    def scene(self, sid: str) -> tuple:
        if sid not in self._scenes:
            scene, missions = load_scene_and_missions(self.scenes_dir, sid, self.cfg)
            self._scenes[sid] = (scene, {m.id: m for m in missions}, load_grids(self.scenes_dir, sid, self.cfg),
                                 read_json(self.candidates_dir / f"{sid}.json"))
        return self._scenes[sid]

    def run(self, planner: str, sid: str, mission_id: str) -> None:
        scene, missions, grids, cands = self.scene(sid)
        mission = missions[mission_id]
        if mission_id not in cands:
            raise StageError(f"{self.candidates_dir / (sid + '.json')} has no candidates for mission {mission_id!r} "
                             f"(it has {sorted(cands)}): rerun the candidates stage (dvc repro candidates)")
        check_name(mission_id, f"the mission id (in {self.scenes_dir / sid / 'missions.json'})")
        d = ensure_dir(child_path(self.out_dir, planner, sid, what="a planner or scene id"))
        meta = {"planner": planner, "scene": sid, "mission": mission_id, **self.prov}
        if sid not in self._worlds:  # built once per scene: its IK models, path fields and measurements serve every run
            self._worlds[sid] = World(scene, self.cfg.sim, self.cfg.scene.grid_resolution, grids=grids,
                                      measurements=load_measurements(self.scenes_dir, sid, self.cfg, scene))
        world = self._worlds[sid]
        with McapRecorder(d / f"{mission_id}.mcap", scene, meta, grids=grids, robot=self.robot) as rec:
            hook = command_results_logger(rec)
            record = run_mission(planner, world, mission, cands[mission_id], self.client, self.cfg, recorder=rec,
                                 on_command_end=hook)
        write_json(d / f"{mission_id}.json", record.to_dict())


def load_measurements(scenes_dir: Path, sid: str, cfg: ExperimentConfig, scene: SceneGraph) -> MeasurementStore:
    """The manipulation measurements the scenes stage made on the initial map of ``scene`` (the
    scene ``sid``; ``measurements.json``): an empty store when the file is absent, or was made for
    another scene or simulator config (``sim.measurements``)."""
    store = MeasurementStore(cfg.sim, cfg.scene.grid_resolution, scene)
    path = Path(scenes_dir) / sid / MEASUREMENTS_FILE
    if path.is_file():
        store.read(path)
    return store


def command_results_logger(recorder):
    """A ``run_mission`` hook that logs each command's executed result on ``/results/command`` when it
    ends: its record without the actions (those are on /actions) and how many actions it had. The
    metrics are computed from results later, by the aggregate stage and by a replay."""

    def on_command_end(record: MissionRecord, t: float) -> None:
        c = record.commands[-1]
        payload = {k: v for k, v in c.to_dict().items() if k != "actions"}
        recorder.event(COMMAND_RESULTS_TOPIC, t, {**payload, "n_actions": len(c.actions)})
    return on_command_end


_WORKER: MissionWorker | None = None  # the worker process's state (see _init_worker)



def _init_worker(parent: int, ids, cfg, scenes_dir, candidates_dir, out_dir, prov) -> None:
    """Worker initializer: die with the parent (a killed stage leaves no worker behind), leave a
    Ctrl-C to the parent (which says what it stopped; a worker's traceback would only repeat it),
    take a call-log file of its own, then set up the worker state."""
    global _WORKER
    die_with_parent(parent)
    leave_ctrl_c_to_parent()
    _WORKER = MissionWorker(cfg, scenes_dir, candidates_dir, out_dir, prov, ids.get(timeout=60))


def _run_in_worker(job: Job) -> None:
    """Run one job in a worker; a failure comes back naming the job: a user-fixable one as its
    message, any other with the worker's traceback (the original may not survive pickling)."""
    assert _WORKER is not None, "_init_worker did not run in this process"
    try:
        _WORKER.run(*job)
    except UserError as e:
        raise StageError(failed_message(job, e, _WORKER.out_dir)) from None
    except Exception as e:
        if (unwritable := output_error(e)) is not None:  # a full disk, a read-only folder
            raise StageError(failed_message(job, unwritable, _WORKER.out_dir)) from None
        raise RuntimeError(failed_message(job, e, _WORKER.out_dir) + "\n" + traceback.format_exc()) from None
    log_loaded_modules("missions")


def run_missions(cfg: ExperimentConfig, scenes_dir: Path, candidates_dir: Path, out_dir: Path,
                 resolved_config: dict | None = None, *, record_commit: bool = True) -> None:
    """Every planner on every mission: mission records, MCAP run logs, the call log, provenance.
    ``record_commit=False`` (the DVC stage) keeps the git commit out of the outputs (see
    ``provenance.DVC_CHECKOUT``)."""
    check_registered(cfg)  # an unknown planner, backend or mode fails before any output
    out_dir = ensure_dir(out_dir)
    prov = provenance(cfg, resolved_config, record_commit=record_commit)
    probe_path = Path(candidates_dir) / PROBE_FILE
    if probe_path.is_file():  # the LLM server's conformance probe, made by the candidates stage
        prov["llm_probe"] = read_json(probe_path)
    write_json(out_dir / "provenance.json", prov)
    write_json(out_dir / PLANNERS_FILE, shown_planners(cfg.planner.names))
    jobs = [(p, sid, m.id) for sid in scene_ids(scenes_dir)
            for m in load_scene_and_missions(scenes_dir, sid, cfg)[1] for p in cfg.planner.names]
    n_workers = min(cfg.jobs or usable_cores(), len(jobs))
    call_log = out_dir / "llm_calls.jsonl"
    for f in (call_log, *out_dir.glob(".llm_calls.worker*.jsonl")):  # whatever a killed run left here
        f.unlink(missing_ok=True)
    files = {"scenes_dir": scenes_dir, "candidates_dir": candidates_dir, "out_dir": out_dir, "prov": prov,
             "call_log": call_log}
    if n_workers <= 1:
        _run_in_process(cfg, jobs, **files)
    else:
        _run_in_workers(cfg, jobs, n_workers=n_workers, **files)
    check_failure_share(call_log, cfg.llm, "missions stage")


def _run_in_process(cfg: ExperimentConfig, jobs: list[Job], *, scenes_dir: Path, candidates_dir: Path, out_dir: Path,
                    prov: dict, call_log: Path) -> None:
    worker = MissionWorker(cfg, scenes_dir, candidates_dir, out_dir, prov, call_log)
    try:
        for job in progress(jobs, "missions", total=len(jobs)):
            try:
                worker.run(*job)
            except UserError as e:
                raise StageError(failed_message(job, e, out_dir)) from e
            except Exception as e:
                if (unwritable := output_error(e)) is not None:  # a full disk, a read-only folder
                    raise StageError(failed_message(job, unwritable, out_dir)) from None
                raise RuntimeError(failed_message(job, e, out_dir)) from e
    finally:
        worker.client.close()


def submission_order(jobs: list[Job]) -> list[Job]:
    """The jobs of planners registered with ``long_running=True`` first, so the workers run the
    others beside them instead of leaving one alone at the end (the outputs do not depend on the
    order: the call logs are merged in ``jobs`` order)."""
    return sorted(jobs, key=lambda j: not (j[0] in PLANNERS and PLANNERS.entry(j[0]).meta.get("long_running", False)))


def _run_in_workers(cfg: ExperimentConfig, jobs: list[Job], *, n_workers: int, scenes_dir: Path, candidates_dir: Path,
                    out_dir: Path, prov: dict, call_log: Path) -> None:
    # each worker's model gets its share of the LLM threads (llama.cpp's results do not depend on
    # the thread count; oversubscribed threads only spin)
    wcfg = dataclasses.replace(cfg, llm=dataclasses.replace(cfg.llm, n_threads=max(1, cfg.llm.n_threads // n_workers)))
    parts = [out_dir / f".llm_calls.worker{k}.jsonl" for k in range(n_workers)]
    ctx = multiprocessing.get_context("spawn")  # no fork of a parent with threads (progress bar)
    ids = ctx.Queue()
    for part in parts:
        ids.put(part)
    with cf.ProcessPoolExecutor(n_workers, mp_context=ctx, initializer=_init_worker,
                                initargs=(os.getpid(), ids, wcfg, scenes_dir, candidates_dir, out_dir, prov)) as pool:
        futures = {pool.submit(_run_in_worker, job): job for job in submission_order(jobs)}
        try:
            wait_for_jobs(futures, n_workers)
        except BaseException:
            pool.shutdown(cancel_futures=True)
            raise
        finally:
            merge_call_logs(parts, call_log, jobs)  # also after a failure: the calls made so far


def wait_for_jobs(futures: dict, n_workers: int) -> None:
    """Each job's result as it completes (re-raising its failure); a worker process that died is a
    :class:`StageError` (every pending job sees it, not only the one whose worker died: it names none)."""
    for fut in progress(cf.as_completed(futures), f"missions ({n_workers} workers)", total=len(futures)):
        try:
            fut.result()
        except cf.process.BrokenProcessPool:
            raise StageError(f"missions stage: a worker process died (killed, out of memory?) while running "
                             f"{len(futures)} jobs in {n_workers} workers; rerun with jobs=1 to run them in "
                             f"one process and see which one fails (the finished runs are kept)") from None
