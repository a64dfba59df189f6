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

import logging
from collections.abc import Iterable
from pathlib import Path

from interllm.config import ExperimentConfig
from interllm.io import atomic_write_bytes, atomic_write_text, read_json, write_json
from interllm.progress import progress
from interllm.provenance import provenance

log = logging.getLogger(__name__)


def scene_ids(scenes_dir: Path) -> list[str]:
    ids = sorted(p.name for p in Path(scenes_dir).iterdir() if (p / "scene.json").is_file())
    if not ids:
        raise FileNotFoundError(f"no scenes in {scenes_dir}: run the 'scenes' stage first "
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
    from interllm.planners.candidates import generate_initial_candidates

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    client = _client(cfg, out_dir / "llm_calls.jsonl", "candidates")
    try:
        jobs = [(sid, m) for sid in scene_ids(scenes_dir)
                for m in _load_scene_and_missions(scenes_dir, sid, cfg)[1]]
        by_scene: dict[str, dict] = {}
        scenes = {sid: _load_scene_and_missions(scenes_dir, sid, cfg)[0] for sid in scene_ids(scenes_dir)}
        for sid, mission in progress(jobs, "candidates", total=len(jobs)):
            c = client.with_context(scene=sid, mission=mission.id)
            by_scene.setdefault(sid, {})[mission.id] = generate_initial_candidates(
                scenes[sid], mission, c, cfg)
        for sid, cands in by_scene.items():
            write_json(out_dir / f"{sid}.json", cands)
    finally:
        client.close()


# --------------------------------------------------------------------------------------------
def run_missions(cfg: ExperimentConfig, scenes_dir: Path, candidates_dir: Path, out_dir: Path,
                 resolved_config: dict | None = None) -> None:
    """Every planner on every mission: MuJoCo execution, MCAP logs and mission records."""
    from interllm.planners.runner import run_mission
    from interllm.record import McapRecorder
    from interllm.scene.grid import rasterize
    from interllm.sim.kinematics import RobotKinematics

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    prov = provenance(cfg, resolved_config)
    write_json(out_dir / "provenance.json", prov)
    client = _client(cfg, out_dir / "llm_calls.jsonl", "missions")
    robot = RobotKinematics(cfg.sim)  # arm link frames on /tf, the robot's shape on /scene
    try:
        jobs = []
        for sid in scene_ids(scenes_dir):
            scene, missions = _load_scene_and_missions(scenes_dir, sid, cfg)
            cands = read_json(Path(candidates_dir) / f"{sid}.json")
            for m in missions:
                for p in cfg.planner.names:
                    jobs.append((p, sid, scene, m, cands[m.id]))
        for planner, sid, scene, mission, cands in progress(jobs, "missions", total=len(jobs)):
            d = out_dir / planner / sid
            d.mkdir(parents=True, exist_ok=True)
            grids = {"presumed": rasterize(scene, cfg.scene.grid_resolution, cfg.sim.robot_radius, "presumed"),
                     "true": rasterize(scene, cfg.scene.grid_resolution, cfg.sim.robot_radius, "true")}
            meta = {"planner": planner, "scene": sid, "mission": mission.id, **prov}
            c = client.with_context(planner=planner, scene=sid, mission=mission.id)
            with McapRecorder(d / f"{mission.id}.mcap", scene, meta, grids=grids, robot=robot) as rec:
                record = run_mission(planner, scene, mission, cands, c, cfg, rec)
            write_json(d / f"{mission.id}.json", record)
    finally:
        client.close()


# --------------------------------------------------------------------------------------------
def run_aggregate(cfg: ExperimentConfig, runs_dir: Path, scenes_dir: Path, out_dir: Path) -> dict:
    from interllm.metrics import aggregate

    return aggregate(Path(runs_dir), Path(scenes_dir), cfg, out_dir=Path(out_dir))


def run_report(cfg: ExperimentConfig, metrics_dir: Path, scenes_dir: Path, runs_dir: Path,
               out_dir: Path, temperature_results: Iterable[tuple[str, Path]] = (),
               m_results: Iterable[tuple[str, Path]] = ()) -> None:
    """The report; ablation results are (label, metrics_dir) pairs, gathered where they exist."""
    from interllm.metrics.report import build_report

    build_report(Path(metrics_dir), Path(scenes_dir), Path(runs_dir), Path(out_dir), cfg,
                 temperature_results=list(temperature_results), m_results=list(m_results))


def run_all(cfg: ExperimentConfig, data_dir: Path, resolved_config: dict | None = None) -> dict:
    """All five stages in order into ``data_dir`` (Hydra runs and multiruns)."""
    data_dir = Path(data_dir)
    run_scenes(cfg, data_dir / "scenes")
    run_candidates(cfg, data_dir / "scenes", data_dir / "candidates")
    run_missions(cfg, data_dir / "scenes", data_dir / "candidates", data_dir / "runs", resolved_config)
    metrics = run_aggregate(cfg, data_dir / "runs", data_dir / "scenes", data_dir / "metrics")
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
