"""The paper's claims, each beside our figure with its CI and a verdict (holds / does not hold /
cannot tell), and the number of houses a 10% paired difference needs.

The judged planner (``metrics.judge``, Inter-LLM by default) makes the claims. Anchors
(``metrics.json`` planners flagged ``"anchor": true``: doing nothing, the optimal reference) are
shown beside the claims but are never claimants nor baselines.

- ``ordering``: Inter-LLM has the lowest m_overall per mission. Per baseline: holds when the
  paired improvement's CI lies above 0, does not hold when it lies below 0, else cannot tell; judged
  together with a **delivery check**: when the paired CI of the delivered difference (Inter-LLM −
  baseline, objects per mission, ``metrics.json`` "comparisons") lies below 0, a lower m_overall was
  bought by delivering fewer objects, and the verdict reads "does not hold: lower m_overall by
  delivering fewer objects" instead of "holds". Overall: holds when it holds against every
  baseline; does not hold when it does not against one; else cannot tell.
- ``improvement_30``: "improves the overall mission performance by 30%" over each baseline. Holds
  when 30% lies in the CI; does not hold when the CI lies below 30%; "exceeds" above it; the same
  delivery check turns "holds" / "exceeds" into "does not hold: ... by delivering fewer objects".
- ``self_improvement``: Inter-LLM improves along a mission. Measured as a difference in
  differences over the same missions: (judged − baseline) m_overall per object of the last
  command minus that of the first command; holds when its CI lies below 0 (the judged planner gains
  on the baseline as the mission goes on).
- ``sigma_rise``: Table II's accuracy rises with σ. The least-squares slope of
  accuracy-when-answered on σ, with a bootstrap CI that resamples houses, then missions within
  them, the same ones at every σ (the sweep runs every σ on the same missions); holds when the CI
  lies above 0; needs at least two temperatures.
- ``houses_needed``: per baseline, houses (at the runs' missions per house) for a paired 10%
  difference at 80% power and α = 0.05 (two-sided), from the between- and within-house spread of
  the per-mission differences (missions in one house are not independent draws).

Every CI resamples houses, then missions within them (``stats.resample_counts``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from interllm.core.seeding import bootstrap_seed
from interllm.metrics.stats import MIN_CI_SAMPLES, bootstrap_mean_ci, houses_of, resample_counts

PAPER_IMPROVEMENT = 30.0  # [%] the paper's headline
Z_ALPHA, Z_POWER = 1.959964, 0.841621  # two-sided 5% level, 80% power


def _num(v: Any) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


FEWER = "does not hold: lower m_overall by delivering fewer objects"


def anchors(metrics: Mapping) -> set[str]:
    """The planners ``metrics.json`` flags as anchors (never claimants, never baselines; a file written
    before the anchors had their name flags them "reference")."""
    return {p for p, d in metrics.get("planners", {}).items()
            if isinstance(d, Mapping) and d.get("anchor", d.get("reference"))}


def set_aside(metrics: Mapping) -> set[str]:
    """The planners the claims leave out: the anchors and the ablation variants (planners flagged
    "ablates": they are judged against the planner they ablate, in the mechanism table)."""
    return anchors(metrics) | {p for p, d in metrics.get("planners", {}).items()
                               if isinstance(d, Mapping) and d.get("ablates")}


def deliveries(metrics: Mapping) -> dict[str, tuple[float, float, float]]:
    """{baseline: (delivered difference, lo, hi)} [objects per mission, Inter-LLM − baseline] from
    ``metrics.json`` "comparisons" (empty when the file has none)."""
    return {v.get("baseline", k.split("_vs_", 1)[1]): (_num(v.get("delivered_diff")), _num(v.get("delivered_diff_ci_lo")),
                                                       _num(v.get("delivered_diff_ci_hi")))
            for k, v in metrics.get("comparisons", {}).items()}


def delivers_fewer(delivered: tuple[float, float, float] | None) -> bool:
    """Whether a paired delivered difference's CI lies below 0 (significantly fewer objects)."""
    return delivered is not None and math.isfinite(delivered[2]) and delivered[2] < 0


def ordering(metrics: Mapping) -> dict:
    """{verdict, improvements {baseline: (pct, lo, hi)}, deliveries {baseline: (diff, lo, hi)},
    verdicts {baseline: verdict}} over the baselines (anchors aside) (module doc)."""
    refs = set_aside(metrics)
    imp = {k.split("_vs_", 1)[1]: (_num(v.get("pct")), _num(v.get("ci_lo")), _num(v.get("ci_hi")))
           for k, v in metrics.get("improvement", {}).items()}
    imp = {b: v for b, v in imp.items() if b not in refs}
    dl = {b: v for b, v in deliveries(metrics).items() if b in imp}
    verdicts = {}
    for b, (_, lo, hi) in imp.items():
        if lo > 0:
            verdicts[b] = FEWER if delivers_fewer(dl.get(b)) else "holds"
        elif hi < 0:
            verdicts[b] = "does not hold"
        else:
            verdicts[b] = "cannot tell"
    if verdicts and all(v == "holds" for v in verdicts.values()):
        verdict = "holds"
    elif any(v == "does not hold" for v in verdicts.values()):
        verdict = "does not hold"
    elif FEWER in verdicts.values():
        verdict = FEWER
    else:
        verdict = "cannot tell"
    return {"verdict": verdict, "improvements": imp, "deliveries": dl, "verdicts": verdicts}


def improvement_30(metrics: Mapping) -> dict[str, dict]:
    """Per baseline (anchors aside): {pct, lo, hi, verdict} against the paper's 30%, with the
    delivery check (module doc)."""
    o = ordering(metrics)
    out = {}
    for base, (pct, lo, hi) in o["improvements"].items():
        if not (math.isfinite(lo) and math.isfinite(hi)):
            verdict = "cannot tell"
        elif lo <= PAPER_IMPROVEMENT <= hi:
            verdict = "holds"
        else:
            verdict = "does not hold" if hi < PAPER_IMPROVEMENT else "exceeds"
        if verdict in ("holds", "exceeds") and delivers_fewer(o["deliveries"].get(base)):
            verdict = FEWER
        out[base] = {"pct": pct, "lo": lo, "hi": hi, "verdict": verdict}
    return out


def _per_object(per_command: Iterable[Mapping]) -> dict[tuple, dict[int, float]]:
    """{(planner, scene, mission): {command index: m_overall per object}}."""
    out: dict[tuple, dict[int, float]] = {}
    for r in per_command:
        n = max(1, int(r["n_objects"]))
        out.setdefault((str(r["planner"]), str(r["scene"]), str(r["mission"])), {})[int(r["command_index"])] = \
            float(r["m_overall"]) / n
    return out


def self_improvement(per_command: Iterable[Mapping], judge: str, n_boot: int = 2000,
                     ci: float = 0.95, seed: int = 0, exclude: Iterable[str] = (),
                     method: str = "cluster_bootstrap") -> dict[str, dict]:
    """Per baseline (planners in ``exclude``, the anchors, left out): {did, lo, hi, n, verdict}:
    the difference in differences (module doc) [m_overall per object]."""
    po = _per_object(per_command)
    out = {}
    for base in sorted({k[0] for k in po} - {judge} - set(exclude)):
        d, houses = [], []
        for (p, s, m), cmds in sorted(po.items()):
            if p != judge or (base, s, m) not in po or len(cmds) < 2:
                continue
            other = po[(base, s, m)]
            first, last = min(cmds), max(cmds)
            if first in other and last in other:
                d.append((cmds[last] - other[last]) - (cmds[first] - other[first]))
                houses.append(s)
        mean, lo, hi = bootstrap_mean_ci(d, n_boot, ci, bootstrap_seed(seed, f"self_improvement:{judge}:{base}"),
                                         houses, method)
        verdict = "cannot tell" if not (math.isfinite(lo) and math.isfinite(hi)) else \
            "holds" if hi < 0 else "does not hold" if lo > 0 else "cannot tell"
        out[base] = {"did": mean, "lo": lo, "hi": hi, "n": len(d), "verdict": verdict}
    return out


def sigma_rise(inferences: Sequence[Mapping], planner: str = "inter_llm", n_boot: int = 2000, ci: float = 0.95,
               seed: int = 0) -> dict:
    """{slope [accuracy per unit σ], lo, hi, n_sigma, n_missions, verdict} of accuracy-when-answered on σ.

    inferences: semantic_inferences.csv rows (planner, scene, mission, temperature, judged,
    predicted, correct) of the runs at every σ. Each σ's accuracy is its correct answers over its
    answered ones; a bootstrap replicate draws houses, then missions within them
    (``stats.resample_counts``), and recomputes every σ's accuracy over the missions drawn, so the
    interval carries what missions share (their house, their commands) and pairs the σ values.
    """
    cells: dict[float, dict[tuple[str, str], list[int]]] = {}  # σ -> (scene, mission) -> [correct, answered]
    for r in inferences:
        if str(r.get("planner")) != planner or not int(r.get("judged", 0)) or r.get("predicted") == "unknown":
            continue
        t = _num(r.get("temperature"))
        if math.isfinite(t):
            c = cells.setdefault(t, {}).setdefault((str(r.get("scene", "")), str(r.get("mission", ""))), [0, 0])
            c[0] += int(r["correct"])
            c[1] += 1
    sig = sorted(cells)
    units = sorted(set().union(*(cells[s] for s in sig))) if sig else []
    nothing = {"slope": float("nan"), "lo": float("nan"), "hi": float("nan"), "n_sigma": len(sig),
               "n_missions": len(units), "verdict": "cannot tell"}
    if len(sig) < 2 or len(units) < MIN_CI_SAMPLES or \
            any(sum(c[1] for c in cells[s].values()) < MIN_CI_SAMPLES for s in sig):
        return nothing  # too few missions to resample: an interval would mean nothing
    correct = np.array([[cells[s].get(u, [0, 0])[0] for u in units] for s in sig], dtype=np.int64)  # (σ, missions)
    answered = np.array([[cells[s].get(u, [0, 0])[1] for u in units] for s in sig], dtype=np.int64)
    x = np.array(sig, dtype=float)
    point = float(_slopes(x, (correct.sum(axis=1) / answered.sum(axis=1))[None, :])[0])
    counts = resample_counts(len(units), n_boot, bootstrap_seed(seed, f"sigma_rise:{planner}"), houses_of(units))
    with np.errstate(invalid="ignore", divide="ignore"):  # a replicate whose missions answered nothing at a σ
        acc = (counts @ correct.T) / (counts @ answered.T)  # integer products: the same on every CPU
    boots = _slopes(x, acc)
    boots = boots[np.isfinite(boots)]
    if boots.size == 0:
        return {**nothing, "slope": point}
    lo, hi = (float(v) for v in np.quantile(boots, [(1 - ci) / 2, 1 - (1 - ci) / 2]))
    verdict = "holds" if lo > 0 else "does not hold" if hi < 0 else "cannot tell"
    return {"slope": point, "lo": lo, "hi": hi, "n_sigma": len(sig), "n_missions": len(units), "verdict": verdict}


def _slopes(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Least-squares slope of each row of ``y`` (B, len(x)) on ``x``, by elementwise sums (no BLAS)."""
    xc = x - x.mean()
    return ((y - y.mean(axis=1, keepdims=True)) * xc).sum(axis=1) / float((xc * xc).sum())


def houses_needed(per_mission: Iterable[Mapping], judge: str, effect: float = 0.10,
                  exclude: Iterable[str] = ()) -> dict:
    """Per baseline (planners in ``exclude``, the anchors, left out): the houses a paired ``effect``
    (share of the baseline's mean m_overall) needs at 80% power, α = 0.05 two-sided, with the runs'
    missions per house m. The paired differences d are split into a between-house variance σ_b²
    (of the house means, less the within part, at least 0) and a pooled within-house variance σ_w²,
    so the mean of H houses × m missions has variance (σ_b² + σ_w² / m) / H and
    H = ⌈(z_0.975 + z_0.8)² (σ_b² + σ_w² / m) / (effect · mean(baseline))²⌉.
    {houses_needed (NaN from one house), missions_needed = H·m, missions_per_house, sd_between,
    sd_within, n_houses, n_pairs, base_mean}."""
    by: dict[str, dict[tuple, float]] = {}
    for r in per_mission:
        by.setdefault(str(r["planner"]), {})[(str(r["scene"]), str(r["mission"]))] = float(r["m_overall"])
    out = {}
    for base in sorted(set(by) - {judge} - set(exclude)):
        keys = sorted(set(by.get(judge, {})) & set(by[base]))
        if len(keys) < MIN_CI_SAMPLES:
            continue
        per_house: dict[str, list[float]] = {}
        for k in keys:
            per_house.setdefault(k[0], []).append(by[base][k] - by[judge][k])
        base_mean = float(np.mean([by[base][k] for k in keys]))
        out[base] = {**_design(list(per_house.values()), effect * base_mean), "base_mean": base_mean,
                     "n_pairs": len(keys)}
    return out


def _design(houses: Sequence[Sequence[float]], delta: float) -> dict:
    """Variance components of per-house samples of paired differences and the houses H (at the mean
    missions per house m) whose mean detects ``delta`` at 80% power (``houses_needed``)."""
    m = float(np.mean([len(h) for h in houses]))
    dof = sum(len(h) - 1 for h in houses)
    var_w = sum(float(np.sum((np.asarray(h) - np.mean(h)) ** 2)) for h in houses) / dof if dof > 0 else 0.0
    nan = float("nan")
    if len(houses) < 2 or delta <= 0:
        return {"houses_needed": nan, "missions_needed": nan, "missions_per_house": m, "sd_between": nan,
                "sd_within": math.sqrt(var_w), "n_houses": len(houses)}
    var_b = max(0.0, float(np.var([np.mean(h) for h in houses], ddof=1)) - var_w / m)
    h_needed = max(2, math.ceil((Z_ALPHA + Z_POWER) ** 2 * (var_b + var_w / m) / delta ** 2))
    return {"houses_needed": h_needed, "missions_needed": math.ceil(h_needed * m), "missions_per_house": m,
            "sd_between": math.sqrt(var_b), "sd_within": math.sqrt(var_w), "n_houses": len(houses)}
