"""Stage aggregate: per-object/command/mission metrics, CIs, paired comparisons (DVC metrics and
plots), the LLM requests and tokens per command by phase (llm_usage.json), and the environment the
runs were made in."""

from __future__ import annotations

from pathlib import Path

from interllm.config import ExperimentConfig
from interllm.io import read_json, write_json
from interllm.metrics.compute import aggregate, load_runs
from interllm.metrics.llm_usage import llm_usage
from interllm.numerics import environment_record


def run_aggregate(cfg: ExperimentConfig, runs_dir: Path, scenes_dir: Path, out_dir: Path,
                  candidates_dir: Path | None = None) -> dict:
    """metrics.json and the tidy tables; environment.json records the numerical environment, CPU
    and packages the runs were made with (from runs/provenance.json), so that a reproduction on
    another machine can say what differs (tests/test_reproduce.py, ``interllm results diff``)."""
    logs = {"missions": Path(runs_dir) / "llm_calls.jsonl"}
    if candidates_dir is not None:
        logs["candidates"] = Path(candidates_dir) / "llm_calls.jsonl"
    metrics = aggregate(Path(runs_dir), Path(scenes_dir), cfg, out_dir=Path(out_dir), call_logs=logs)
    commands: dict[str, int] = {}
    for rec in load_runs(runs_dir):
        commands[rec.planner] = commands.get(rec.planner, 0) + len(rec.commands)
    write_json(Path(out_dir) / "llm_usage.json", llm_usage(logs, commands))
    prov_path = Path(runs_dir) / "provenance.json"
    prov = read_json(prov_path) if prov_path.is_file() else {}
    write_json(Path(out_dir) / "environment.json", environment_record(prov))
    return metrics
