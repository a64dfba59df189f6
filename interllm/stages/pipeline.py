"""All five stages in order into one data folder (Hydra runs and multiruns; DVC runs them as
separate stages instead)."""

from __future__ import annotations

import shutil
from pathlib import Path

from interllm.config import ExperimentConfig
from interllm.llm.backend import preflight
from interllm.stages.aggregate import run_aggregate
from interllm.stages.candidates import run_candidates
from interllm.stages.missions import run_missions
from interllm.stages.report import run_report
from interllm.stages.scenes import run_scenes
from interllm.stages.shared_scenes import SharedScenes


def run_all(cfg: ExperimentConfig, data_dir: Path, resolved_config: dict | None = None,
            shared_scenes: SharedScenes | None = None) -> dict:
    """scenes -> candidates -> missions -> aggregate -> report into ``data_dir``; returns metrics.json.
    ``shared_scenes``: where the scenes stage's output of this scene setting may already be stored."""
    preflight(cfg.llm)  # a server that is down stops the run before any stage writes
    data_dir = Path(data_dir)
    scenes = data_dir / "scenes"
    if shared_scenes is None:
        run_scenes(cfg, scenes)
    else:
        shutil.rmtree(scenes, ignore_errors=True)  # this run's own folder, being made again
        if not shared_scenes.fetch(scenes):
            run_scenes(cfg, scenes)
            shared_scenes.store(scenes)
    run_candidates(cfg, data_dir / "scenes", data_dir / "candidates")
    run_missions(cfg, data_dir / "scenes", data_dir / "candidates", data_dir / "runs", resolved_config)
    metrics = run_aggregate(cfg, data_dir / "runs", data_dir / "scenes", data_dir / "metrics",
                            data_dir / "candidates")
    run_report(cfg, data_dir / "metrics", data_dir / "scenes", data_dir / "runs", data_dir / "report")
    return metrics
