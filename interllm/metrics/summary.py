"""The summaries the aggregate stage writes: per planner means with bootstrap CIs (metrics.json's
``planners``), the mean curves along the mission (``cumulative.csv``, ``per_object_summary.csv``),
the semantic-accuracy summary, and the rounding that keeps metrics.json byte-stable.

Every CI is a house-clustered percentile bootstrap (``stats.resample_counts``: houses, then the
missions or objects within each) with ``n_boot`` resamples at coverage ``ci``; each group's
resampling is seeded from ``seed`` and the group's label (``interllm.core.seeding.bootstrap_seed``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from interllm.core.seeding import bootstrap_seed
from interllm.metrics import stats

SUMMARY_METRICS = ("m_overall", "cc", "d", "t_exe", "sr_man", "sr_obj")
SEMANTIC_SUMMARY_KEYS = ("accuracy", "accuracy_ci_lo", "accuracy_ci_hi", "unknown_share", "coverage",
                         "accuracy_known", "accuracy_known_ci_lo", "accuracy_known_ci_hi", "chance", "majority",
                         "verdict", "n_judged", "n_inferences", "truth_agreement")


def clean(v: Any, ndigits: int = 6) -> Any:
    """Round floats to ``ndigits``, NaN/inf -> None, recursively (byte-stable JSON)."""
    if isinstance(v, float):
        if v != v or v in (float("inf"), float("-inf")):
            return None
        r = round(v, ndigits)
        return 0.0 if r == 0 else r
    if isinstance(v, Mapping):
        return {str(k): clean(x, ndigits) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [clean(x, ndigits) for x in v]
    return v


def cumulative_rows(per_object: Sequence[Mapping], n_boot: int, ci: float, seed: int,
                    method: str = "cluster_bootstrap") -> list[dict]:
    """Mean running m_overall [s] per (planner, object_index) with its CI: rows {planner, object_index,
    m_overall_cum, ci_lo, ci_hi, n} (``cumulative.csv``)."""
    return [{"planner": r["planner"], "object_index": r["object_index"], "m_overall_cum": r["mean"],
             "ci_lo": r["ci_lo"], "ci_hi": r["ci_hi"], "n": r["n"]}
            for r in stats.group_mean_ci(per_object, ("planner", "object_index"), "m_overall_cum", n_boot, ci, seed,
                                             method=method)]


def per_object_summary(per_object: Sequence[Mapping], n_boot: int, ci: float, seed: int,
                       method: str = "cluster_bootstrap") -> list[dict]:
    """Mean and CI of each of ``SUMMARY_METRICS`` per (planner, object_index): rows {planner,
    object_index, metric, mean, ci_lo, ci_hi, n} (``per_object_summary.csv``)."""
    out = []
    for metric in SUMMARY_METRICS:
        for r in stats.group_mean_ci(per_object, ("planner", "object_index"), metric, n_boot, ci, seed,
                                     method=method):
            out.append({"planner": r["planner"], "object_index": r["object_index"], "metric": metric,
                        "mean": r["mean"], "ci_lo": r["ci_lo"], "ci_hi": r["ci_hi"], "n": r["n"]})
    return out


def semantic_summary(semantic_rows: Sequence[Mapping]) -> dict[str, dict]:
    """{"<planner>@<temperature>": the accuracy figures of ``stats.semantic_accuracy``'s row}."""
    return {f"{r['planner']}@{r['temperature']}": {k: r[k] for k in SEMANTIC_SUMMARY_KEYS} for r in semantic_rows}


def planner_summaries(per_mission: Sequence[Mapping], per_object: Sequence[Mapping], *,
                      failed_calls: Mapping[str, int], deliveries: Mapping[str, Mapping], n_boot: int, ci: float,
                      seed: int, method: str = "cluster_bootstrap") -> dict[str, dict]:
    """Per planner: missions and objects (``stats.fulfilment_counts``), m_overall per mission and per
    object [s] with CIs, cc [collisions], d [m], t_exe [s] per mission, sr_man and sr_obj per object,
    LLM calls and tokens (``stats.llm_usage``), ``llm_failed_calls`` (from ``failed_calls``:
    {planner: failed calls of the missions stage}) and the planner's ``deliveries`` fields
    (``deliveries.delivery_metrics``' "planners")."""
    usage = stats.llm_usage(per_mission)
    counts = stats.fulfilment_counts(per_object)
    planners: dict[str, dict] = {}
    for p in sorted({r["planner"] for r in per_mission}):
        rows_m = [r for r in per_mission if r["planner"] == p]
        rows_o = [r for r in per_object if r["planner"] == p]
        d: dict[str, Any] = {"n_missions": len(rows_m), **counts[p]}
        m, lo, hi = stats.bootstrap_mean_ci([r["m_overall"] for r in rows_m], n_boot, ci,
                                            bootstrap_seed(seed, f"mission:m_overall:{p}"),
                                            [str(r["scene"]) for r in rows_m], method)
        d.update({"m_overall": m, "m_overall_ci_lo": lo, "m_overall_ci_hi": hi})
        m, lo, hi = stats.bootstrap_mean_ci([r["m_overall"] for r in rows_o], n_boot, ci,
                                            bootstrap_seed(seed, f"object:m_overall:{p}"),
                                            [str(r["scene"]) for r in rows_o], method)
        d.update({"m_overall_per_object": m, "m_overall_per_object_ci_lo": lo,
                  "m_overall_per_object_ci_hi": hi})
        for k in ("cc", "d", "t_exe"):  # per mission (sums over its objects)
            d[k] = sum(r[k] for r in rows_m) / len(rows_m)
        for k in ("sr_man", "sr_obj"):  # per object
            d[k] = sum(r[k] for r in rows_o) / max(1, len(rows_o))
        d.update(usage[p])
        d["llm_failed_calls"] = failed_calls.get(p, 0)
        d.update(deliveries[p])
        planners[p] = d
    return planners
