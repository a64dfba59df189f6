"""Stage report: the paper's tables and figures from our runs (Markdown + self-contained HTML), with
the ablation results of Hydra multiruns where they exist."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import yaml

from interllm.config import ExperimentConfig
from interllm.metrics.report import build_report


def run_report(cfg: ExperimentConfig, metrics_dir: Path, scenes_dir: Path, runs_dir: Path,
               out_dir: Path, temperature_results: Iterable[tuple[str, Path]] = (),
               m_results: Iterable[tuple[str, Path]] = (),
               estimate_results: Iterable[tuple[str, Path]] = (),
               oracle_results: Iterable[tuple[float, Path]] = ()) -> None:
    """The report; ablation results are (label, metrics_dir) pairs (``find_sweep_results``,
    ``find_estimate_results``), oracle results (llm.oracle_error, metrics_dir) pairs
    (``find_oracle_results``)."""
    build_report(Path(metrics_dir), Path(scenes_dir), Path(runs_dir), Path(out_dir), cfg,
                 temperature_results=list(temperature_results), m_results=list(m_results),
                 estimate_results=list(estimate_results), oracle_results=list(oracle_results))


def _jobs(roots: Iterable[Path], experiment: str) -> list[tuple[dict, Path]]:
    """(the job's .hydra/config.yaml, its metrics dir) of every ``experiment`` job under ``roots``
    that produced metrics.json."""
    out = []
    for root in roots:
        for cfg_file in sorted(Path(root).rglob(".hydra/config.yaml")):
            metrics = cfg_file.parent.parent / "data" / "metrics"
            c = yaml.safe_load(cfg_file.read_text()) or {}
            if c.get("experiment") == experiment and (metrics / "metrics.json").is_file():
                out.append((c, metrics))
    return out


def find_oracle_results(*roots: Path) -> list[tuple[float, Path]]:
    """Jobs of ``experiment=oracle_sweep`` multiruns under ``roots`` with metrics:
    [(llm.oracle_error, metrics_dir)], sorted by the error."""
    return sorted((float(c["llm"]["oracle_error"]), m) for c, m in _jobs(roots, "oracle_sweep"))


def find_estimate_results(*roots: Path) -> list[tuple[str, Path]]:
    """Jobs of ``experiment=estimate_comparison`` multiruns under ``roots`` with metrics:
    [(planner.nav_estimate, metrics_dir)], sorted by the variant's name."""
    return sorted((str(c["planner"]["nav_estimate"]), m) for c, m in _jobs(roots, "estimate_comparison"))


def find_sweep_results(*roots: Path) -> tuple[list[tuple[str, Path]], list[tuple[str, Path]]]:
    """Ablation results of Hydra multiruns under ``roots``: jobs whose ``.hydra/config.yaml`` says
    experiment=temperature_ablation or m_ablation and that produced ``data/metrics/metrics.json``.

    Returns (temperature_results, m_results) as (label, metrics_dir) pairs, sorted by value.
    """
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
