"""The experiment report: ``report.md`` and a self-contained ``report.html`` (images inlined as
base64) built from the files the aggregate stage wrote (``metrics.json``, ``per_object.csv``,
``per_command.csv``, ``cumulative.csv``, ``per_object_summary.csv``, ``semantic_accuracy.csv``).

``build_report`` puts the sections in order; each part of the report is one module of this package:

- ``headline``: the headline table (objects delivered, m_overall, the position between the
  anchors, doing nothing and the optimal reference, cost per delivered object), the paired
  differences with their per-house effects, and the summary per planner with whether the
  paper's ordering (the judged planner, Inter-LLM by default, lowest m_overall) holds;
- ``verdicts``: the paper's claims with the delivery check and their verdicts;
- ``costs``: the γ_obj sensitivity, candidate diversity, the LLM requests per command, the
  measured manipulation costs;
- ``paper_tables``: the paper's Table III layout with our means beside the paper's numbers, and
  Table II (semantic accuracy per temperature);
- ``figures``: the cumulative overall-metric figure, per-object bars, the path-similarity
  illustration, scene pictures, trajectories, run MCAPs with the replay command (``plots`` draws);
- ``mechanism``: the ablation variants against the full planner;
- ``sweeps``: the M ablation, the cost-estimate variants, the oracle sweep and the cost
  encodings when multirun result folders are given.

The document model and cell formatters are in ``document``. Every statistic is computed by
``interllm.metrics`` (the sweep and claim sections call it on the committed per-mission tables);
this package only formats and draws.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from interllm.errors import MissingInputError
from interllm.io import atomic_write_text, ensure_dir, read_json
from interllm.metrics import planner_info
from interllm.metrics.compute import read_csv
from interllm.metrics.stats import interval_method
from interllm.report import costs, figures, headline, mechanism, paper_tables, sweeps, verdicts
from interllm.report.benchmark import benchmark_sentence
from interllm.report.document import Doc

TITLE = "Inter-LLM experiment report"


def build_report(metrics_dir: str | os.PathLike, scenes_dir: str | os.PathLike, runs_dir: str | os.PathLike,
                 out_dir: str | os.PathLike, cfg: Any = None, *,
                 temperature_results: Sequence[tuple[str, str | os.PathLike]] = (),
                 m_results: Sequence[tuple[str, str | os.PathLike]] = (),
                 estimate_results: Sequence[tuple[str, str | os.PathLike]] = (),
                 oracle_results: Sequence[tuple[float, str | os.PathLike]] = (),
                 encoding_results: Sequence[tuple[str, str, str | os.PathLike]] = ()) -> dict[str, Path]:
    """Write ``out_dir/report.md``, ``out_dir/report.html`` and ``out_dir/figures/*.png``.

    metrics_dir: output of the aggregate stage; scenes_dir: ``data/scenes`` (topdown.png pictures);
    runs_dir: ``data/runs`` (MCAP links); cfg: ExperimentConfig or None (ε of the path-similarity
    figure = ``cfg.planner.inter_llm.epsilon_d``); temperature_results / m_results: (label, metrics_dir)
    pairs of other runs (labels like "0.2" / "M=3"); folders without metrics.json are skipped;
    estimate_results: (planner.inter_llm.nav_estimate, metrics_dir) pairs; oracle_results:
    (llm.oracle_error, metrics_dir) pairs of an oracle sweep on the same missions;
    encoding_results: (group, variant, metrics_dir) of runs differing only in llm.oracle_costs and/or
    planner.inter_llm.cost_encoding (``sweeps.encoding_section``).
    The judged planner and how each planner is shown (label, colour, order, anchor) come from
    metrics.json (``settings.judge``, ``planners``): the report reads results, not planner code.
    Returns {"markdown", "html", "figures"} paths.
    """
    metrics_dir, out_dir = Path(metrics_dir), Path(out_dir)
    mpath = metrics_dir / "metrics.json"
    if not mpath.is_file():
        raise MissingInputError(f"{mpath} is missing; run the 'aggregate' stage (interllm.stages.aggregate) "
                                f"first or pass the folder holding metrics.json")
    metrics = read_json(mpath)
    sweep_dirs = [r[-1] for r in (*temperature_results, *m_results, *estimate_results, *oracle_results,
                                  *encoding_results)]
    sweeps.check_one_benchmark(metrics, mpath, sweep_dirs)
    settings = metrics.get("settings", {})
    judge = str(settings.get("judge", settings.get("reference", "")))  # "reference": before metrics.judge
    with planner_info.shown(planner_info.PlannerTable.from_json(metrics.get("planners", {}), str(mpath))):
        return _write_report(metrics, judge, metrics_dir, Path(scenes_dir), Path(runs_dir), out_dir, cfg,
                             temperature_results=temperature_results, m_results=m_results,
                             estimate_results=estimate_results, oracle_results=oracle_results,
                             encoding_results=encoding_results)


def _write_report(metrics: dict, judge: str, metrics_dir: Path, scenes_dir: Path, runs_dir: Path, out_dir: Path,
                  cfg: Any, *, temperature_results, m_results, estimate_results, oracle_results,
                  encoding_results) -> dict[str, Path]:
    """``build_report``'s body, with the planner table in use."""
    per_object = read_csv(metrics_dir / "per_object.csv")
    per_command = read_csv(metrics_dir / "per_command.csv")
    cumulative = read_csv(metrics_dir / "cumulative.csv")
    summary = read_csv(metrics_dir / "per_object_summary.csv")
    fig_dir = out_dir / "figures"
    scene_ids = sorted({str(r["scene"]) for r in per_object})
    doc = Doc()
    _title(doc, metrics.get("settings", {}))
    doc.p(benchmark_sentence(metrics.get("benchmark", {})))

    headline.headline_section(doc, metrics, Path(scenes_dir), scene_ids, judge)
    verdicts.claims_section(doc, metrics, metrics_dir, [Path(d) for _, d in temperature_results], judge)
    headline.summary_section(doc, metrics, judge)
    costs.gamma_obj_section(doc, metrics, judge)
    costs.diversity_section(doc, metrics)
    if (metrics_dir / "llm_usage.json").is_file():
        costs.llm_usage_section(doc, read_json(metrics_dir / "llm_usage.json"))
    paper_tables.table_iii_section(doc, per_object, per_command)
    costs.manipulation_section(doc, metrics.get("manipulation", {}),
                                          metrics_dir / "manipulation_attributes.csv")

    eps = float(cfg.planner.inter_llm.epsilon_d) if cfg is not None else 1.0
    made = figures.metric_figures(doc, cumulative, summary, fig_dir, eps)
    figures.scenes_section(doc, scenes_dir, scene_ids)
    made += figures.trajectories_section(doc, runs_dir, scene_ids, fig_dir)
    figures.run_logs_section(doc, runs_dir, out_dir)

    per_mission = read_csv(metrics_dir / "per_mission.csv") if (metrics_dir / "per_mission.csv").is_file() else []
    f = mechanism.mechanism_section(doc, metrics, per_mission, fig_dir)
    if f is not None:
        made.append(f)
    paper_tables.table_ii_section(doc, metrics_dir, temperature_results)
    sweeps.m_ablation_section(doc, m_results, judge)
    sweeps.estimates_section(doc, metrics_dir, [(lab, Path(d)) for lab, d in estimate_results], judge,
                                     cfg.planner.inter_llm.nav_estimate if cfg is not None else "this run's estimate")
    f = sweeps.capability_section(doc, metrics, [(float(e), Path(d)) for e, d in oracle_results], fig_dir,
                                          judge)
    if f is not None:
        made.append(f)
    sweeps.encoding_section(doc, [(g, v, Path(d)) for g, v, d in encoding_results], metrics, judge)

    ensure_dir(out_dir)
    md, ht = out_dir / "report.md", out_dir / "report.html"
    atomic_write_text(md, doc.markdown(out_dir))
    atomic_write_text(ht, doc.html(TITLE))
    return {"markdown": md, "html": ht, "figures": made}  # type: ignore[dict-item]


def _title(doc: Doc, s: Mapping) -> None:
    """The title and the settings of the runs (metrics.json's ``settings``)."""
    doc.h(1, TITLE)
    doc.p(f"Input source: **{s.get('source', '?')}**. {s.get('n_runs', '?')} mission runs; γ_nav = {s.get('gamma_nav')}, γ_man = {s.get('gamma_man')}, "
          f"γ_obj = {s.get('gamma_obj')}; LLM temperature {s.get('temperature')}; "
          f"{_interval_text(s)} All times are simulated seconds.")


def _interval_text(s: Mapping) -> str:
    """How the report's intervals were made (``settings.interval``; runs made before the key
    existed used the cluster bootstrap)."""
    pct = int(100 * float(s.get("ci", 0.95)))
    why = "because missions in one house share its layout, objects and commands"
    if interval_method({"settings": s}) == "cr2":
        return (f"{pct}% CR2 t intervals with Bell–McCaffrey degrees of freedom, clustered by house ({why}): "
                "they generalise to houses like these, and their coverage at this cluster structure is checked "
                "by simulation (docs/protocol.md, Intervals).")
    return (f"{pct}% percentile bootstrap CIs with B = {s.get('bootstrap_samples')} (seed {s.get('seed')}), "
            f"clustered by house: each resample draws the houses with replacement, then the missions within each "
            f"drawn house, {why}. With few houses these intervals speak for these houses, not for houses like them.")
