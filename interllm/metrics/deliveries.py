"""Deliveries first: what a planner delivered, beside m_overall, and where it stands
between the two anchors: doing nothing (``nothing``) and the optimal reference (``optimal``).

m_overall charges an unfilled slot γ_man + γ_obj, so a planner that never acts scores
n_slots · (γ_man + γ_obj) per mission, and a planner can lower its m_overall by trying less. These
metrics keep that visible:

- **delivered**: objects delivered = Σ sr_obj (``compute``: distinct delivered goal objects, up to n
  per command), in all and per mission [objects / mission] with a bootstrap CI;
- **exec_cost_per_delivered**: execution cost per delivered object,
  Σ(γ_nav·cc + t_exe + d) / delivered [s / object] (γ_nav in s per collision, t_exe in simulated s,
  d in m counted as s, as in m_overall);
- **comparisons**: paired differences (judged planner − other) per mission of m_overall [s] and
  of delivered [objects], with paired bootstrap CIs (missions resampled jointly);
- **position** = (m_null − m) / (m_null − m_optimal) on the sums of m_overall over the missions all
  three ran, with a bootstrap CI resampling the missions jointly for the three planners: 0 = as
  good as doing nothing (the ``nothing`` anchor), 1 = as good as the ``optimal`` anchor,
  negative = worse than doing nothing [dimensionless];
- **m_minus_nothing**: the paired difference m − m_null per mission [s] and whether its CI lies
  below 0 (``below_nothing``: the planner is significantly better than doing nothing);
- **γ_obj sensitivity**: m_overall is linear in γ_obj, m(γ) = E + γ·U per mission with
  E = Σ_slots γ_nav·cc + t_exe + d + γ_man·(1 − sr_man) [s] and U = Σ_slots (1 − sr_obj)
  [undelivered slots]; each planner's mean m(γ) for the γ_obj values of
  ``metrics.gamma_obj_sensitivity``, the paired difference CIs at each, and the break-even
  γ* = −Δ_E / Δ_U [s per undelivered object] where the mean paired difference changes sign ("never",
  None, when it does not for γ ≥ 0);
- **candidate diversity**: per planner with candidates, the share of commands whose candidates
  take different objects (at least two distinct sets of picked-up objects).

Every CI is house-clustered (``stats.resample_counts``): it resamples the houses, then the missions
within each, since missions in one house share its layout and commands.

The judged planner (``metrics.judge``) is compared with every other planner. Anchors are the
planners the runs record as such (``planner_info``: registered with ``anchor=True``); they are
shown, never judged. The position needs exactly one of each kind: the runs named ``nothing`` and
``optimal``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, Optional

import numpy as np

from interllm.core.records import MissionRecord
from interllm.core.seeding import bootstrap_seed
from interllm.metrics import planner_info
from interllm.metrics.cluster_t import house_means
from interllm.metrics.stats import bootstrap_mean_ci, by_mission, houses_of, joint_bootstrap, paired_mean_diff

NOTHING, OPTIMAL = "nothing", "optimal"  # the two anchors of the normalised position
NAN = float("nan")


def is_anchor(planner: str) -> bool:
    """Whether the runs record ``planner`` as an anchor (``planner_info``); unknown: no."""
    return planner_info.current().is_anchor(planner)


def shown(planner: str) -> dict[str, Any]:
    """What metrics.json keeps of how the runs show ``planner``: "anchor", "label", "color", "order",
    and "ablates" for an ablation variant (the planner it removes one part of)."""
    t = planner_info.current()
    ablates = t.ablates(planner)
    return {"anchor": t.is_anchor(planner), **t.shown(planner), **({"ablates": ablates} if ablates else {})}


def anchor_planners(names: Iterable[str]) -> list[str]:
    """The anchors among ``names``, sorted."""
    return sorted(p for p in set(names) if is_anchor(p))


def exec_cost(row: Mapping, gamma_nav: float) -> float:
    """γ_nav·cc + t_exe + d [s] of a per-mission or per-object row (γ_nav [s / collision])."""
    return gamma_nav * float(row["cc"]) + float(row["t_exe"]) + float(row["d"])


def planner_deliveries(per_mission: Iterable[Mapping], gamma_nav: float, n_boot: int = 2000, ci: float = 0.95,
                       seed: int = 0, method: str = "cluster_bootstrap") -> dict[str, dict]:
    """Per planner: {"delivered" [objects, all missions], "delivered_per_mission" (mean, "_ci_lo",
    "_ci_hi") [objects / mission], "exec_cost" [s / mission, mean of γ_nav·cc + t_exe + d],
    "exec_cost_per_delivered" [s / object; NaN when nothing was delivered]}."""
    rows: dict[str, list[Mapping]] = {}
    for r in per_mission:
        rows.setdefault(str(r["planner"]), []).append(r)
    out = {}
    for p in sorted(rows):
        dl = [float(r["n_fulfilled"]) for r in rows[p]]
        ex = [exec_cost(r, gamma_nav) for r in rows[p]]
        m, lo, hi = bootstrap_mean_ci(dl, n_boot, ci, bootstrap_seed(seed, f"mission:delivered:{p}"),
                                      [str(r["scene"]) for r in rows[p]], method)
        total = int(round(sum(dl)))
        out[p] = {"delivered": total, "delivered_per_mission": m, "delivered_per_mission_ci_lo": lo,
                  "delivered_per_mission_ci_hi": hi, "exec_cost": sum(ex) / len(ex),
                  "exec_cost_per_delivered": sum(ex) / total if total else NAN}
    return out


def paired_comparisons(per_mission: Iterable[Mapping], judge: str, n_boot: int = 2000, ci: float = 0.95,
                       seed: int = 0, method: str = "cluster_bootstrap") -> dict[str, dict]:
    """{"<judge>_vs_<other>": {"baseline", "baseline_anchor" (bool), "n_pairs",
    "m_overall_diff" [s / mission], "delivered_diff" [objects / mission], each with "_ci_lo" and
    "_ci_hi" and "_by_house" ({house: the mean difference over its missions}, the per-house effects
    the interval generalises over)}} for every other planner: judged − other on the (scene,
    mission) pairs both ran, paired CIs (``method``). A negative m_overall_diff is better; a
    negative delivered_diff is fewer objects delivered."""
    rows = list(per_mission)
    m, dl = by_mission(rows, "m_overall"), by_mission(rows, "n_fulfilled")
    out: dict[str, dict] = {}
    if judge not in m:
        return out
    for b in sorted(set(m) - {judge}):
        keys = sorted(set(m[judge]) & set(m[b]))
        d: dict[str, Any] = {"baseline": b, "baseline_anchor": is_anchor(b), "n_pairs": len(keys)}
        for name, tab in (("m_overall", m), ("delivered", dl)):
            diffs = [tab[judge][k] - tab[b][k] for k in keys]
            v, lo, hi = paired_mean_diff([tab[judge][k] for k in keys], [tab[b][k] for k in keys], n_boot, ci,
                                         bootstrap_seed(seed, f"paired_diff:{name}:{judge}:{b}"), houses_of(keys), method)
            d.update({f"{name}_diff": v, f"{name}_diff_ci_lo": lo, f"{name}_diff_ci_hi": hi,
                      f"{name}_diff_by_house": house_means(diffs, houses_of(keys)) if keys else {}})
        out[f"{judge}_vs_{b}"] = d
    return out


def _position(m: Any, null: Any, opt: Any) -> Any:
    """(Σ null − Σ m) / (Σ null − Σ opt) from the three sums over the missions (floats or arrays)."""
    return (null - m) / (null - opt)


def position(m: Sequence[float], null: Sequence[float], opt: Sequence[float], n_boot: int = 2000,
             ci: float = 0.95, seed: int = 0, houses: Optional[Sequence[str]] = None,
             *, method: str = "cluster_bootstrap") -> tuple[float, float, float]:
    """(position, lo, hi) of a planner's per-mission m_overall ``m`` between the nothing anchor's
    ``null`` (0) and the optimal anchor's ``opt`` (1), the same missions in the same order; NaN
    when Σ null = Σ opt. The CI resamples the missions jointly for the three (by house, then
    mission, when ``houses`` names each mission's)."""
    return joint_bootstrap(_position, [m, null, opt], n_boot, ci, seed, houses, method)


def positions(per_mission: Iterable[Mapping], n_boot: int = 2000, ci: float = 0.95, seed: int = 0,
              method: str = "cluster_bootstrap") -> dict[str, dict]:
    """Per planner (anchors included: nothing is 0 and optimal 1 by construction):
    {"position", "position_ci_lo", "position_ci_hi", "position_n_missions"} when runs of both
    ``nothing`` and ``optimal`` exist, and {"m_minus_nothing" [s / mission], "_ci_lo", "_ci_hi",
    "below_nothing" (True when the CI lies below 0, False when not, None without an interval)} when
    ``nothing``'s exist."""
    m = by_mission(per_mission, "m_overall")
    out: dict[str, dict] = {p: {} for p in sorted(m)}
    if NOTHING not in m:
        return out
    for p in sorted(m):
        if OPTIMAL in m:
            keys = sorted(set(m[p]) & set(m[NOTHING]) & set(m[OPTIMAL]))
            v, lo, hi = position([m[p][k] for k in keys], [m[NOTHING][k] for k in keys],
                                 [m[OPTIMAL][k] for k in keys], n_boot, ci, bootstrap_seed(seed, f"position:{p}"),
                                 houses_of(keys), method=method)
            out[p].update({"position": v, "position_ci_lo": lo, "position_ci_hi": hi,
                           "position_n_missions": len(keys)})
        if p == NOTHING:
            continue
        keys = sorted(set(m[p]) & set(m[NOTHING]))
        v, lo, hi = paired_mean_diff([m[p][k] for k in keys], [m[NOTHING][k] for k in keys], n_boot, ci,
                                     bootstrap_seed(seed, f"paired_diff:m_overall:{p}:{NOTHING}"), houses_of(keys),
                                     method)
        out[p].update({"m_minus_nothing": v, "m_minus_nothing_ci_lo": lo, "m_minus_nothing_ci_hi": hi,
                       "below_nothing": (hi < 0) if math.isfinite(hi) else None})
    return out


def anchors_info(planners: Iterable[str]) -> dict:
    """{"flagged": the anchors among ``planners``, "missing": which of nothing / optimal
    have no runs (the position needs both)}."""
    ps = set(planners)
    return {"flagged": anchor_planners(ps), "missing": [r for r in (NOTHING, OPTIMAL) if r not in ps]}


# ---- γ_obj sensitivity -----------------------------------------------------------------------
def gamma_key(gamma: float) -> str:
    """The metrics.json key of a γ_obj value ("100", "2.5")."""
    return format(float(gamma), "g")


def break_even(exec_diff: float, undelivered_diff: float) -> float | None:
    """γ* [s per undelivered object] solving Δ(γ) = exec_diff + γ·undelivered_diff = 0, or None
    ("never") when Δ does not change sign for γ ≥ 0 (undelivered_diff = 0, or γ* < 0)."""
    if not (math.isfinite(exec_diff) and math.isfinite(undelivered_diff)) or abs(undelivered_diff) < 1e-12:
        return None
    g = -exec_diff / undelivered_diff
    return g if g >= 0 else None


def _exec_undelivered(per_object: Iterable[Mapping], gamma_nav: float, gamma_man: float
                      ) -> dict[str, dict[tuple[str, str], tuple[float, float]]]:
    """{planner: {(scene, mission): (E [s], U [undelivered slots])}} (module doc)."""
    out: dict[str, dict[tuple[str, str], list[float]]] = {}
    for r in per_object:
        e = exec_cost(r, gamma_nav) + gamma_man * (1.0 - float(r["sr_man"]))
        acc = out.setdefault(str(r["planner"]), {}).setdefault((str(r["scene"]), str(r["mission"])), [0.0, 0.0])
        acc[0] += e
        acc[1] += 1.0 - float(r["sr_obj"])
    return {p: {k: (v[0], v[1]) for k, v in d.items()} for p, d in out.items()}


def gamma_obj_sensitivity(per_object: Iterable[Mapping], *, gamma_nav: float, gamma_man: float,
                          gammas: Sequence[float], judge: str, n_boot: int = 2000, ci: float = 0.95,
                          seed: int = 0, method: str = "cluster_bootstrap") -> dict:
    """m_overall per mission recomputed from the per-slot rows at each γ_obj in ``gammas`` [s]
    (γ_nav [s / collision], γ_man [s]).

    Returns {"gammas": [...], "planners": {planner: {"exec" [E, s / mission], "undelivered"
    [U, slots / mission], "m_overall": {γ key: mean m(γ) [s / mission]}}}, "comparisons":
    {"<judge>_vs_<other>": {"baseline", "baseline_anchor", "n_pairs", "exec_diff" [s],
    "undelivered_diff" [slots], "break_even" [s or None = never], "judged_lower_above" (True:
    the judged planner is cheaper for γ_obj above the break-even, False: below it; None without one),
    "by_gamma": {γ key: {"diff", "ci_lo", "ci_hi"} [s / mission, judged − other]}}}}."""
    eu = _exec_undelivered(per_object, gamma_nav, gamma_man)
    gs = [float(g) for g in gammas]
    out: dict[str, Any] = {"gammas": gs, "planners": {}, "comparisons": {}}
    for p in sorted(eu):
        e = float(np.mean([v[0] for v in eu[p].values()]))
        u = float(np.mean([v[1] for v in eu[p].values()]))
        out["planners"][p] = {"exec": e, "undelivered": u, "m_overall": {gamma_key(g): e + g * u for g in gs}}
    if judge not in eu:
        return out
    for b in sorted(set(eu) - {judge}):
        keys = sorted(set(eu[judge]) & set(eu[b]))
        er, ur = np.array([eu[judge][k][0] for k in keys]), np.array([eu[judge][k][1] for k in keys])
        eb, ub = np.array([eu[b][k][0] for k in keys]), np.array([eu[b][k][1] for k in keys])
        de = float(np.mean(er - eb)) if keys else NAN
        du = float(np.mean(ur - ub)) if keys else NAN
        be = break_even(de, du)
        by = {}
        for g in gs:  # the same resamples at every γ (and as ``paired_comparisons``' m_overall difference)
            v, lo, hi = paired_mean_diff(er + g * ur, eb + g * ub, n_boot, ci,
                                         bootstrap_seed(seed, f"paired_diff:m_overall:{judge}:{b}"), houses_of(keys),
                                         method)
            by[gamma_key(g)] = {"diff": v, "ci_lo": lo, "ci_hi": hi}
        out["comparisons"][f"{judge}_vs_{b}"] = {
            "baseline": b, "baseline_anchor": is_anchor(b), "n_pairs": len(keys), "exec_diff": de,
            "undelivered_diff": du, "break_even": be, "judged_lower_above": None if be is None else du < 0,
            "by_gamma": by}
    return out


# ---- candidate diversity ---------------------------------------------------------------------
def candidate_diversity(records: Iterable[MissionRecord]) -> dict[str, dict]:
    """Per planner that recorded candidates: {"n_commands" (with candidates), "n_diverse" (whose
    candidates take at least two distinct sets of objects: a plan's objects are the ``obj`` of its
    pickup actions), "share" = n_diverse / n_commands, "candidates_per_command" (mean)}."""
    acc: dict[str, list[int]] = {}
    for rec in records:
        for c in rec.commands:
            cands = list(c.summary.candidates)
            if not cands:
                continue
            sets = {frozenset(a.obj for a in plan if a.kind == "pickup" and a.obj) for plan in cands}
            d = acc.setdefault(rec.planner, [0, 0, 0])
            d[0] += 1
            d[1] += int(len(sets) >= 2)
            d[2] += len(cands)
    return {p: {"n_commands": n, "n_diverse": k, "share": k / n, "candidates_per_command": c / n}
            for p, (n, k, c) in sorted(acc.items())}


# ---- everything the aggregate stage adds -------------------------------------------------------
def delivery_metrics(records: Sequence[MissionRecord], per_object: Sequence[Mapping], per_mission: Sequence[Mapping],
                     *, gamma_nav: float, gamma_man: float, gammas: Sequence[float], judge: str,
                     n_boot: int = 2000, ci: float = 0.95, seed: int = 0, method: str = "cluster_bootstrap") -> dict:
    """{"planners": {planner: fields to merge into metrics.json's planners (``planner_deliveries``,
    ``positions``, "anchor" and how tables show it: "label", "color", "order")}, "comparisons",
    "anchors", "gamma_obj_sensitivity",
    "candidate_diversity"} (module doc; γ_nav [s / collision], γ_man [s], ``gammas``: the γ_obj values
    of the sensitivity table [s])."""
    dl = planner_deliveries(per_mission, gamma_nav, n_boot, ci, seed, method)
    pos = positions(per_mission, n_boot, ci, seed, method)
    planners = {p: {**shown(p), **dl[p], **pos.get(p, {})} for p in sorted(dl)}
    return {"planners": planners,
            "comparisons": paired_comparisons(per_mission, judge, n_boot, ci, seed, method),
            "anchors": anchors_info(planners),
            "gamma_obj_sensitivity": gamma_obj_sensitivity(per_object, gamma_nav=gamma_nav, gamma_man=gamma_man,
                                                           gammas=gammas, judge=judge, n_boot=n_boot,
                                                           ci=ci, seed=seed, method=method),
            "candidate_diversity": candidate_diversity(records)}


def paired_runs(variant: Iterable[Mapping], base: Iterable[Mapping], planner: str, n_boot: int = 2000,
                ci: float = 0.95, seed: int = 0, method: str = "cluster_bootstrap") -> dict:
    """Two runs of the same missions (per_mission rows of each) that differ in one setting:
    {"n_pairs", "m_overall_diff" [s / mission], "delivered_diff" [objects / mission],
    "position_diff" [dimensionless; NaN without nothing and optimal runs in both], each with
    "_ci_lo" / "_ci_hi"}: ``planner`` in ``variant`` − in ``base``, paired over the (scene, mission)
    both ran; the position difference resamples the missions jointly for the six series (each run's
    planner, nothing and optimal)."""
    va, ba = list(variant), list(base)
    out: dict[str, Any] = {}
    mv, mb = by_mission(va, "m_overall"), by_mission(ba, "m_overall")
    dv, db = by_mission(va, "n_fulfilled"), by_mission(ba, "n_fulfilled")
    keys = sorted(set(mv.get(planner, {})) & set(mb.get(planner, {})))
    out["n_pairs"] = len(keys)
    for name, a, b in (("m_overall", mv, mb), ("delivered", dv, db)):
        v, lo, hi = paired_mean_diff([a[planner][k] for k in keys], [b[planner][k] for k in keys], n_boot, ci,
                                     bootstrap_seed(seed, f"runs:{name}:{planner}"), houses_of(keys), method)
        out.update({f"{name}_diff": v, f"{name}_diff_ci_lo": lo, f"{name}_diff_ci_hi": hi})
    names = (planner, NOTHING, OPTIMAL)
    if all(n in mv and n in mb for n in names):
        keys = sorted(set.intersection(*[set(t[n]) for t in (mv, mb) for n in names]))
        series = [[t[n][k] for k in keys] for t in (mv, mb) for n in names]
        v, lo, hi = joint_bootstrap(lambda a, an, ao, b, bn, bo: _position(a, an, ao) - _position(b, bn, bo),
                                    series, n_boot, ci, bootstrap_seed(seed, f"runs:position:{planner}"),
                                    houses_of(keys), method)
    else:
        v, lo, hi = NAN, NAN, NAN
    out.update({"position_diff": v, "position_diff_ci_lo": lo, "position_diff_ci_hi": hi})
    return out
