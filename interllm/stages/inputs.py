"""What several stages read: the scene ids of a scenes folder, a scene with its missions and
grids, the LLM client of a stage."""

from __future__ import annotations

from pathlib import Path

from interllm.config import ExperimentConfig
from interllm.errors import MissingInputError
from interllm.llm.client import LLMClient, make_client
from interllm.scene.graph import Mission, SceneGraph
from interllm.scene.grid import OccupancyGrid
from interllm.scene.missions import load_missions

PROBE_FILE = "llm_probe.json"  # in the candidates folder: what the LLM server's conformance probe measured


def scene_ids(scenes_dir: Path) -> list[str]:
    ids = sorted(p.name for p in Path(scenes_dir).iterdir() if (p / "scene.json").is_file()) \
        if Path(scenes_dir).is_dir() else []
    if not ids:
        raise MissingInputError(f"no scenes in {scenes_dir}: run the 'scenes' stage first (dvc repro scenes)")
    return ids


def load_scene_and_missions(scenes_dir: Path, sid: str, cfg: ExperimentConfig) -> tuple[SceneGraph, list[Mission]]:
    """A scene of the scenes stage and its missions (the first ``mission.limit_missions``)."""
    d = Path(scenes_dir) / sid
    scene = SceneGraph.from_json((d / "scene.json").read_text(encoding="utf-8"))
    missions = load_missions(d / "missions.json")
    if cfg.mission.limit_missions:
        missions = missions[: cfg.mission.limit_missions]
    return scene, missions


def load_grids(scenes_dir: Path, sid: str, cfg: ExperimentConfig) -> dict[str, OccupancyGrid]:
    """The presumed and true occupancy grids the scenes stage wrote (``grid.npz``)."""
    path = Path(scenes_dir) / sid / "grid.npz"
    try:
        return OccupancyGrid.load_pair(path, cfg.scene.grid_resolution, cfg.sim.robot_radius)
    except (OSError, KeyError, ValueError) as e:
        raise MissingInputError(f"{path}: {e}") from None


def stage_client(cfg: ExperimentConfig, call_log: Path | None, stage: str,
                 probe: dict | None = None) -> LLMClient:
    """probe: the stage's recorded LLM conformance probe (PROBE_FILE), used instead of probing again."""
    return make_client(cfg.llm, call_log_path=call_log, probe=probe).with_context(stage=stage)
