"""Stage aggregate: per-object/command/mission metrics, CIs, paired comparisons (DVC metrics and
plots), the LLM requests and tokens per command by phase (llm_usage.json), and the environment the
runs were made in.

The metric definitions are in ``interllm.metrics`` (``compute``: the per-slot tables; ``summary``:
means and CIs per planner; ``deliveries``: objects delivered, positions, γ_obj sensitivity;
``manipulation``, ``stats``, ``capability``); this module reads the runs, calls them in order and
writes their results.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional

from interllm.config import ExperimentConfig
from interllm.core.records import MissionRecord
from interllm.io import read_json, write_json
from interllm.metrics import capability, deliveries, manipulation, mechanism, planner_info, stats, summary
from interllm.metrics.benchmark_check import benchmark_summary
from interllm.metrics.compute import (
    PER_COMMAND_FIELDS,
    PER_MISSION_FIELDS,
    PER_OBJECT_FIELDS,
    Gammas,
    MetricsInputError,
    call_log_counts,
    compute_tables,
    load_runs,
    load_scene_categories,
    write_csv,
)
from interllm.metrics.llm_usage import llm_usage
from interllm.numerics import environment_record

SEMANTIC_ACCURACY_FIELDS = (
    "temperature", "planner", "n_inferences", "n_judged", "n_unjudged", "n_correct", "n_unknown", "accuracy",
    "accuracy_ci_lo", "accuracy_ci_hi", "unknown_share", "coverage", "accuracy_known", "accuracy_known_ci_lo",
    "accuracy_known_ci_hi", "chance", "majority", "verdict", "confusion", "n_executed", "truth_agreement")
SEMANTIC_INFERENCE_FIELDS = ("planner", "scene", "mission", "temperature", "command_index", "action", "predicted",
                             "estimate", "judged", "truth", "truth_cost", "correct", "executed_truth")
# (file, table, columns) of every CSV the stage writes, in the order it writes them
CSV_FILES = (
    ("per_object.csv", "per_object", PER_OBJECT_FIELDS),
    ("per_command.csv", "per_command", PER_COMMAND_FIELDS),
    ("per_mission.csv", "per_mission", PER_MISSION_FIELDS),
    ("cumulative.csv", "cumulative", ("planner", "object_index", "m_overall_cum", "ci_lo", "ci_hi", "n")),
    ("per_object_summary.csv", "per_object_summary", ("planner", "object_index", "metric", "mean", "ci_lo",
                                                      "ci_hi", "n")),
    ("per_manipulation.csv", "per_manipulation", manipulation.FIELDS),
    ("manipulation_attributes.csv", "manipulation_attributes", ("attribute", "bin", "n", "c_man", "ci_lo", "ci_hi",
                                                                "sr_man", "hard_share")),
    ("semantic_accuracy.csv", "semantic_accuracy", SEMANTIC_ACCURACY_FIELDS),
    ("semantic_inferences.csv", "semantic_inferences", SEMANTIC_INFERENCE_FIELDS),
)


@dataclass(frozen=True)
class AggregateSettings:
    """What the metrics depend on besides the runs: the γ factors of m_overall, the bootstrap
    (``n_boot`` resamples, coverage ``ci``, ``seed``), the LLM temperature of the runs (Table II),
    the judged planner (``metrics.judge``: its paired differences against every other planner are
    reported), the γ_obj values of the sensitivity table [s] and the label of the input source."""

    gammas: Gammas
    n_boot: int
    ci: float
    seed: int
    temperature: float
    judge: str
    gamma_obj_values: tuple[float, ...]
    source: str
    interval: str = "cluster_bootstrap"

    @classmethod
    def from_config(cls, cfg: Any, temperature: Optional[float] = None) -> AggregateSettings:
        """From an ExperimentConfig (``sim.gamma_nav``, ``sim.gamma_man``, ``metrics.*``,
        ``llm.temperature`` unless ``temperature`` is given, ``llm.source_label``)."""
        mc = cfg.metrics
        return cls(gammas=Gammas.from_config(cfg), n_boot=int(mc.bootstrap_samples), ci=float(mc.ci),
                   seed=int(mc.seed), temperature=float(cfg.llm.temperature if temperature is None else temperature),
                   judge=str(mc.judge), gamma_obj_values=tuple(mc.gamma_obj_sensitivity),
                   source=cfg.llm.source_label, interval=str(mc.interval))

    def as_json(self, n_runs: int) -> dict:
        """metrics.json's ``settings``."""
        g = self.gammas
        return {"gamma_nav": g.nav, "gamma_man": g.man, "gamma_obj": g.obj, "bootstrap_samples": self.n_boot,
                "ci": self.ci, "seed": self.seed, "temperature": self.temperature, "judge": self.judge,
                "n_runs": n_runs, "source": self.source, "interval": self.interval}


def run_aggregate(cfg: ExperimentConfig, runs_dir: Path, scenes_dir: Path, out_dir: Path,
                  candidates_dir: Path | None = None) -> dict:
    """metrics.json and the tidy tables (``write_metrics``), llm_usage.json, and environment.json: the
    numerical environment, CPU and packages the runs were made with (from runs/provenance.json), so
    that a reproduction on another machine can say what differs (tests/test_reproduce.py,
    ``interllm results diff``)."""
    logs = {"missions": Path(runs_dir) / "llm_calls.jsonl"}
    if candidates_dir is not None:
        logs["candidates"] = Path(candidates_dir) / "llm_calls.jsonl"
    metrics = write_metrics(Path(runs_dir), Path(scenes_dir), cfg, out_dir=Path(out_dir), call_logs=logs)
    commands: dict[str, int] = {}
    for rec in load_runs(runs_dir):
        commands[rec.planner] = commands.get(rec.planner, 0) + len(rec.commands)
    write_json(Path(out_dir) / "llm_usage.json", llm_usage(logs, commands))
    prov_path = Path(runs_dir) / "provenance.json"
    prov = read_json(prov_path) if prov_path.is_file() else {}
    write_json(Path(out_dir) / "environment.json", environment_record(prov))
    return metrics


def write_metrics(runs_dir: str | os.PathLike, scenes_dir: str | os.PathLike, cfg: Any,
                  out_dir: str | os.PathLike | None = None, *, temperature: Optional[float] = None,
                  call_logs: Optional[Mapping[str, os.PathLike]] = None) -> dict:
    """Compute every table of the runs under ``runs_dir`` and write them to ``out_dir``.

    cfg: ExperimentConfig (``AggregateSettings.from_config``); out_dir: default
    ``<cfg.data_dir>/metrics``; temperature: the LLM temperature of these runs for Table II
    (default ``cfg.llm.temperature``); call_logs: {stage: llm_calls.jsonl} whose calls and failed calls are counted into
    ``llm_calls`` (default: the missions stage's, in runs_dir).

    metrics.json holds per planner the m_overall and delivery figures (``interllm.metrics.summary``,
    ``interllm.metrics.deliveries``: delivered, delivered_per_mission, exec_cost_per_delivered,
    position, m_minus_nothing, below_nothing; anchor, label, color, order: how the runs show it,
    ``planner_info``), ``improvement`` (the judged planner's paired % improvement over every other
    planner, anchors aside), ``comparisons`` (paired m_overall and delivered differences against
    every other planner), ``anchors``, ``gamma_obj_sensitivity``, ``candidate_diversity`` and
    ``benchmark`` (the versioned benchmark the missions come from and what changed since it was
    frozen: ``interllm.metrics.benchmark_check``).

    Writes (atomically): ``metrics.json`` (DVC metrics, rounded floats, sorted keys) and the CSVs of
    ``CSV_FILES``: ``cumulative.csv`` has x = object_index, y = m_overall_cum;
    ``per_object_summary.csv`` the mean + CI per planner and object_index of each metric;
    ``per_manipulation.csv`` and ``manipulation_attributes.csv`` come from
    ``interllm.metrics.manipulation``. Returns the metrics.json dict.
    """
    s = AggregateSettings.from_config(cfg, temperature)
    out = Path(out_dir) if out_dir is not None else Path(cfg.data_dir) / "metrics"
    records = load_runs(runs_dir)
    if not records:
        raise MetricsInputError(f"no MissionRecord (<planner>/<scene>/<mission>.json) under {runs_dir}; "
                                f"run the 'missions' stage first")
    scenes = load_scene_categories(scenes_dir, (r.scene_id for r in records))
    tables = _tables(records, scenes, Path(scenes_dir), s)
    logs = dict(call_logs) if call_logs is not None else {"missions": Path(runs_dir) / "llm_calls.jsonl"}
    with planner_info.shown(planner_info.load(runs_dir)):
        result = summary.clean({**_metrics_json(records, scenes, tables, logs, s),
                                "benchmark": benchmark_summary(Path(scenes_dir), scenes)})
    write_json(out / "metrics.json", result)
    for name, table, fields in CSV_FILES:
        write_csv(out / name, tables[table], fields)
    return result


def _tables(records: Sequence[MissionRecord], scenes: Mapping[str, Mapping], scenes_dir: Path,
            s: AggregateSettings) -> dict[str, list[dict]]:
    """Every table of ``CSV_FILES``, by table name."""
    t = compute_tables(records, scenes, s.gammas)
    po = t["per_object"]
    t["cumulative"] = summary.cumulative_rows(po, s.n_boot, s.ci, s.seed, s.interval)
    t["per_object_summary"] = summary.per_object_summary(po, s.n_boot, s.ci, s.seed, s.interval)
    man_rows = manipulation.manipulation_rows(records, manipulation.load_scenes(scenes_dir, (r.scene_id for r in records)))
    t["per_manipulation"] = man_rows
    t["manipulation_attributes"] = manipulation.attribute_table(man_rows, s.n_boot, s.ci, s.seed, s.interval)
    inf_rows = [row for rec in records for row in stats.inference_rows(rec, s.temperature)]
    t["semantic_accuracy"] = stats.semantic_accuracy(inf_rows, s.n_boot, s.ci, s.seed, s.interval)
    t["semantic_inferences"] = inf_rows
    return t


def _metrics_json(records: Sequence[MissionRecord], scenes: Mapping[str, Mapping], tables: Mapping[str, list],
                  logs: Mapping[str, os.PathLike], s: AggregateSettings) -> dict:
    """metrics.json before rounding (``write_metrics``' doc)."""
    po, pm = tables["per_object"], tables["per_mission"]
    g = s.gammas
    dl = deliveries.delivery_metrics(records, po, pm, gamma_nav=g.nav, gamma_man=g.man,
                                     gammas=list(s.gamma_obj_values), judge=s.judge, n_boot=s.n_boot,
                                     ci=s.ci, seed=s.seed, method=s.interval)
    aside = {p for p, d in dl["planners"].items() if d["anchor"] or d.get("ablates")}
    claimants = [r for r in pm if r["planner"] not in aside]  # anchors and ablation variants are not judged
    calls = {stage: call_log_counts(path) for stage, path in sorted(logs.items())}
    planners = summary.planner_summaries(pm, po, failed_calls=calls.get("missions", {}).get("failed_by_planner", {}),
                                         deliveries=dl["planners"], n_boot=s.n_boot, ci=s.ci, seed=s.seed,
                                         method=s.interval)
    improvement = stats.compare_planners(claimants, s.judge, "m_overall", s.n_boot, s.ci, s.seed, s.interval)
    return {
        "planners": planners,
        "improvement": {f"{s.judge}_vs_{b}": v for b, v in improvement.items()},
        "comparisons": dl["comparisons"],
        "anchors": dl["anchors"],
        "gamma_obj_sensitivity": dl["gamma_obj_sensitivity"],
        "candidate_diversity": dl["candidate_diversity"],
        "mechanism": mechanism.mechanism_table(pm, tables["per_command"], dl["planners"], g.nav, s.n_boot, s.ci,
                                               s.seed, method=s.interval),
        "semantic_accuracy": summary.semantic_summary(tables["semantic_accuracy"]),
        "manipulation": manipulation.manipulation_summary(tables["per_manipulation"]),
        "answers": capability.answer_accuracy(records, scenes),
        "llm_calls": {stage: {k: c[k] for k in ("calls", "failed")} for stage, c in calls.items()},
        "settings": s.as_json(len(records)),
    }
