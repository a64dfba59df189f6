"""What each part of the judged planner's mechanism is worth: every ablation variant (a planner
registered with ``ablates=<planner>``, e.g. ``inter_llm_no_learning``) paired against the planner
it removes one part of, on the (scene, mission) pairs both ran.

- **mechanism table** (``metrics.json`` "mechanism"): per variant, full − variant of objects
  delivered [objects / mission] and of m_overall [s / mission], each with a house-clustered paired
  bootstrap CI (``stats.paired_mean_diff``). A positive delivered difference and a negative
  m_overall difference mean the removed part helps.
- **learning curve** ("by_command"): the same per command index k (missions that reached it),
  with the cost per delivered object of each, Σ(γ_nav·cc + t_exe + d) / Σ delivered [s / object]
  over the pairs, and its paired difference full − variant (a ratio of sums, missions resampled by
  house jointly for the four sums, ``stats.joint_bootstrap``). Learning shows as a difference that
  grows along the mission.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from interllm.core.seeding import bootstrap_seed
from interllm.metrics.deliveries import exec_cost
from interllm.metrics.stats import houses_of, joint_bootstrap, paired_mean_diff


def ablations(planners: Mapping[str, Mapping]) -> dict[str, str]:
    """{variant: the planner it ablates} of the planners (metrics.json's) whose ablated planner ran too."""
    return {p: str(d["ablates"]) for p, d in sorted(planners.items())
            if isinstance(d, Mapping) and d.get("ablates") and str(d["ablates"]) in planners}


def _by_key(rows: Iterable[Mapping], planner: str, key: tuple[str, ...]) -> dict[tuple, Mapping]:
    return {tuple(str(r[k]) for k in key): r for r in rows if str(r["planner"]) == planner}


def _diff(full: dict[tuple, Mapping], variant: dict[tuple, Mapping], field: str, n_boot: int, ci: float,
          seed: int, method: str) -> dict[str, Any]:
    """{"<field>_diff", "_ci_lo", "_ci_hi"}: full − variant of ``field`` over the keys both have."""
    keys = sorted(set(full) & set(variant))
    v, lo, hi = paired_mean_diff([float(full[k][field]) for k in keys], [float(variant[k][field]) for k in keys],
                                 n_boot, ci, seed, houses_of(keys), method)
    return {f"{field}_diff": v, f"{field}_diff_ci_lo": lo, f"{field}_diff_ci_hi": hi}


def _cost_per_delivered(full: dict[tuple, Mapping], variant: dict[tuple, Mapping], gamma_nav: float,
                        n_boot: int, ci: float, seed: int, method: str) -> dict[str, Any]:
    """Cost per delivered object [s / object] of each and full − variant with its CI."""
    keys = sorted(set(full) & set(variant))
    series = [[exec_cost(t[k], gamma_nav) for k in keys] for t in (full, variant)]
    dl = [[float(t[k]["n_fulfilled"]) for k in keys] for t in (full, variant)]
    v, lo, hi = joint_bootstrap(lambda ef, df, ev, dv: ef / df - ev / dv,
                                [series[0], dl[0], series[1], dl[1]], n_boot, ci, seed, houses_of(keys),
                                method)
    nan = float("nan")
    return {"cost_per_delivered_full": sum(series[0]) / sum(dl[0]) if sum(dl[0]) else nan,
            "cost_per_delivered_variant": sum(series[1]) / sum(dl[1]) if sum(dl[1]) else nan,
            "cost_per_delivered_diff": v, "cost_per_delivered_diff_ci_lo": lo, "cost_per_delivered_diff_ci_hi": hi}


def learning_curve(per_command: Iterable[Mapping], full: str, variant: str, gamma_nav: float, n_boot: int = 2000,
                   ci: float = 0.95, seed: int = 0, *, method: str = "cluster_bootstrap") -> list[dict]:
    """Per command index: {"command_index", "n_pairs", delivered (n_fulfilled) and m_overall
    differences full − variant with CIs, cost per delivered object of each and their difference}."""
    rows = list(per_command)
    f = _by_key(rows, full, ("scene", "mission", "command_index"))
    v = _by_key(rows, variant, ("scene", "mission", "command_index"))
    out = []
    for k in sorted({int(key[2]) for key in set(f) & set(v)}):
        fk = {key[:2]: r for key, r in f.items() if int(key[2]) == k}
        vk = {key[:2]: r for key, r in v.items() if int(key[2]) == k}
        s = bootstrap_seed(seed, f"mechanism:{variant}:{k}")
        out.append({"command_index": k, "n_pairs": len(set(fk) & set(vk)),
                    **_diff(fk, vk, "n_fulfilled", n_boot, ci, s, method),
                    **_diff(fk, vk, "m_overall", n_boot, ci, s, method),
                    **_cost_per_delivered(fk, vk, gamma_nav, n_boot, ci, s, method)})
    return out


def mechanism_table(per_mission: Iterable[Mapping], per_command: Iterable[Mapping], planners: Mapping[str, Mapping],
                    gamma_nav: float, n_boot: int = 2000, ci: float = 0.95, seed: int = 0,
                    *, method: str = "cluster_bootstrap") -> dict[str, dict]:
    """{variant: {"ablates", "n_pairs", "n_fulfilled_diff", "m_overall_diff" (with CIs),
    "cost_per_delivered_*", "by_command": ``learning_curve``}} for every ablation variant of
    ``planners`` (metrics.json's), full − variant per mission."""
    pm, pc = list(per_mission), list(per_command)
    out = {}
    for variant, full in ablations(planners).items():
        f, v = _by_key(pm, full, ("scene", "mission")), _by_key(pm, variant, ("scene", "mission"))
        s = bootstrap_seed(seed, f"mechanism:{variant}")
        out[variant] = {"ablates": full, "n_pairs": len(set(f) & set(v)),
                        **_diff(f, v, "n_fulfilled", n_boot, ci, s, method),
                        **_diff(f, v, "m_overall", n_boot, ci, s, method),
                        **_cost_per_delivered(f, v, gamma_nav, n_boot, ci, s, method),
                        "by_command": learning_curve(pc, full, variant, gamma_nav, n_boot, ci, seed, method=method)}
    return out
