"""Statistics over mission metrics: bootstrap CIs, paired planner comparison, LLM usage and the
semantic-similarity accuracy of manipulation-cost inferences (paper Table II).

Every random draw comes from a ``numpy.random.Generator`` seeded from ``MetricsConfig.seed`` and a
a seed derived from the group's label (``interllm.core.seeding.bootstrap_seed``), so a group's CI does not depend on which other groups
are present, and identical inputs give identical outputs.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Iterable, Mapping, Sequence
from typing import Any, Optional

import numpy as np

from interllm.config import INTERVAL_METHODS
from interllm.core.records import MissionRecord
from interllm.core.seeding import bootstrap_seed
from interllm.metrics.cluster_t import cr2_function_ci, cr2_mean_ci
from interllm.planning.costs import encode_cost

MIN_CI_SAMPLES = 5  # fewer samples (or pairs) give a mean but no interval: it would mean nothing

Clusters = Optional[Sequence[Hashable]]  # one label per sample: the house (scene) it was measured in

# How an interval is made (``metrics.interval``, one of INTERVAL_METHODS): "cluster_bootstrap", the
# percentile bootstrap over houses then missions (``resample_counts``), or "cr2", the CR2 t interval
# with Bell–McCaffrey degrees of freedom (``cluster_t``; docs/protocol.md, "Intervals").


def interval_method(metrics: Mapping) -> str:
    """The interval method a metrics.json was made with (``settings.interval``; metrics made before
    the key existed used the cluster bootstrap)."""
    return str(metrics.get("settings", {}).get("interval", "cluster_bootstrap"))


def check_method(method: str) -> None:
    """Raise ValueError naming the valid choices unless ``method`` is one of INTERVAL_METHODS."""
    if method not in INTERVAL_METHODS:
        raise ValueError(f"interval method {method!r} is not one of {', '.join(INTERVAL_METHODS)}")


def resample_counts(n: int, n_boot: int, seed: int, clusters: Clusters = None) -> np.ndarray:
    """(n_boot, n) int array: how often each of ``n`` samples appears in each bootstrap resample.

    With ``clusters`` naming two or more houses the resampling is two-stage (a cluster bootstrap:
    missions in one house share its layout, objects and commands, so they are not independent):
    draw as many houses as there are, with replacement; then, for every house drawn, as many of its
    samples as it holds, with replacement. With one house or ``clusters=None`` the samples are drawn
    i.i.d. Only integer draws are used, so the counts are the same on every CPU."""
    rng = np.random.default_rng(seed)
    labels = None if clusters is None else [str(c) for c in clusters]
    if labels is not None and len(labels) != n:
        raise ValueError(f"{len(labels)} cluster labels for {n} samples")
    houses = sorted(set(labels)) if labels is not None else []
    if len(houses) < 2:
        return _counts(rng.integers(0, n, size=(int(n_boot), n)), n)
    drawn = _counts(rng.integers(0, len(houses), size=(int(n_boot), len(houses))), len(houses))
    out = np.zeros((int(n_boot), n), dtype=np.int64)
    for h, house in enumerate(houses):
        members = np.array([i for i, c in enumerate(labels) if c == house])
        k = members.size
        draws = rng.integers(0, k, size=(int(n_boot), len(houses) * k))
        used = np.arange(len(houses) * k)[None, :] < (drawn[:, h] * k)[:, None]
        out[:, members] = _counts(np.where(used, draws, k), k)
    return out


def _counts(idx: np.ndarray, n: int) -> np.ndarray:
    """(B, n) occurrences of 0..n−1 in each row of the (B, m) index array ``idx``; the index ``n``
    marks an unused draw and is not counted."""
    b = idx.shape[0]
    flat = (idx + np.arange(b)[:, None] * (n + 1)).ravel()
    return np.bincount(flat, minlength=b * (n + 1)).reshape(b, n + 1)[:, :n]


def _interval(vals: np.ndarray, ci: float) -> tuple[float, float]:
    """The percentile interval at coverage ``ci`` of the finite bootstrap values (NaNs if none)."""
    vals = vals[np.isfinite(vals)]
    if vals.size == 0:
        return float("nan"), float("nan")
    alpha = (1.0 - ci) / 2.0
    lo, hi = np.quantile(vals, [alpha, 1.0 - alpha])
    return float(lo), float(hi)


def bootstrap_mean_ci(x: Sequence[float], n_boot: int = 2000, ci: float = 0.95, seed: int = 0,
                      clusters: Clusters = None, method: str = "cluster_bootstrap"
                      ) -> tuple[float, float, float]:
    """(mean, lo, hi): CI of the mean of ``x``, a percentile bootstrap by default.

    n_boot: resamples B; ci: coverage in (0, 1); seed: Generator seed; clusters: the house of each
    sample (``resample_counts``: houses, then samples within them); method: one of
    INTERVAL_METHODS ("cr2" ignores n_boot and seed). Fewer than ``MIN_CI_SAMPLES`` samples give
    the mean with NaN bounds (the report prints no interval); an empty sample NaNs.
    """
    check_method(method)
    a = np.asarray(list(x), dtype=float)
    if a.size == 0:
        return float("nan"), float("nan"), float("nan")
    m = float(a.mean())
    if a.size < MIN_CI_SAMPLES:
        return m, float("nan"), float("nan")
    if method == "cr2":
        return m, *cr2_mean_ci(a, ci, clusters)[1:]
    w = resample_counts(a.size, n_boot, seed, clusters)
    lo, hi = _interval((w * a).sum(axis=1) / w.sum(axis=1), ci)
    return m, lo, hi


def improvement_pct(ref: Sequence[float], base: Sequence[float]) -> float:
    """100 · (mean(base) − mean(ref)) / mean(base): how much lower ``ref``'s m_overall is, in % of
    the baseline's (positive = ``ref`` better). NaN if the baseline mean is 0."""
    mb = float(np.mean(base))
    return float("nan") if mb == 0 else 100.0 * (mb - float(np.mean(ref))) / mb


def _improvement_of_sums(base: Any, ref: Any) -> Any:
    """100 · (Σ base − Σ ref) / Σ base from the two sums (``improvement_pct`` of the means)."""
    return 100.0 * (base - ref) / base


def paired_improvement(ref: Sequence[float], base: Sequence[float], n_boot: int = 2000,
                       ci: float = 0.95, seed: int = 0, clusters: Clusters = None,
                       method: str = "cluster_bootstrap") -> tuple[float, float, float]:
    """(pct, lo, hi): ``improvement_pct`` of paired samples (same scene and mission at the same
    position) with a paired CI: a percentile bootstrap (pairs resampled jointly, clustered by house
    when ``clusters`` names the houses) or, with ``method="cr2"``, the CR2 t interval of the ratio
    by the delta method; NaN bounds from fewer than ``MIN_CI_SAMPLES`` pairs."""
    check_method(method)
    r = np.asarray(list(ref), dtype=float)
    b = np.asarray(list(base), dtype=float)
    if r.shape != b.shape:
        raise ValueError(f"paired samples differ in length: {r.size} vs {b.size}")
    if r.size == 0:
        return float("nan"), float("nan"), float("nan")
    pct = improvement_pct(r, b)
    if r.size < MIN_CI_SAMPLES:
        return pct, float("nan"), float("nan")
    if method == "cr2":
        return pct, *cr2_function_ci(_improvement_of_sums, [b, r], ci, clusters)[1:]
    w = resample_counts(r.size, n_boot, seed, clusters)
    sb, sr = (w * b).sum(axis=1), (w * r).sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        lo, hi = _interval(100.0 * (sb - sr) / sb, ci)
    return pct, lo, hi


def paired_mean_diff(x: Sequence[float], y: Sequence[float], n_boot: int = 2000, ci: float = 0.95,
                     seed: int = 0, clusters: Clusters = None, method: str = "cluster_bootstrap"
                     ) -> tuple[float, float, float]:
    """(mean(x − y), lo, hi): the mean paired difference (same scene and mission at the same
    position, in the unit of x and y) with a paired percentile bootstrap CI (pairs resampled
    jointly, clustered by house when ``clusters`` names the houses); NaN bounds from fewer than
    ``MIN_CI_SAMPLES`` pairs, NaNs from none. ``method``: one of INTERVAL_METHODS."""
    a = np.asarray(list(x), dtype=float)
    b = np.asarray(list(y), dtype=float)
    if a.shape != b.shape:
        raise ValueError(f"paired samples differ in length: {a.size} vs {b.size}")
    return bootstrap_mean_ci(a - b, n_boot, ci, seed, clusters, method)


def joint_bootstrap(stat: Callable[..., Any], arrays: Sequence[Sequence[float]], n_boot: int = 2000,
                    ci: float = 0.95, seed: int = 0, clusters: Clusters = None,
                    method: str = "cluster_bootstrap") -> tuple[float, float, float]:
    """(stat(*sums), lo, hi): a statistic of the sums of several paired samples (one value per
    mission each, the same missions in the same order) with a percentile bootstrap CI that resamples
    the missions jointly for every array (clustered by house when ``clusters`` names the houses).
    ``stat`` gets one sum per array: floats for the point, (n_boot,) arrays for the resamples, so
    it must be a function of sums that does not depend on their scale (a ratio of sums or
    differences of such ratios); resamples where it is not finite are dropped. NaN bounds from
    fewer than ``MIN_CI_SAMPLES`` missions, NaNs from none. With ``method="cr2"`` the interval is
    ``cluster_t.cr2_function_ci``'s (the delta method; ``stat`` must then be arithmetic)."""
    check_method(method)
    arrs = [np.asarray(list(a), dtype=float) for a in arrays]
    n = arrs[0].size if arrs else 0
    if any(a.size != n for a in arrs):
        raise ValueError(f"paired samples differ in length: {[a.size for a in arrs]}")
    if n == 0:
        return float("nan"), float("nan"), float("nan")
    with np.errstate(divide="ignore", invalid="ignore"):
        point = float(stat(*[float(a.sum()) for a in arrs]))
        if n < MIN_CI_SAMPLES:
            return point, float("nan"), float("nan")
        if method == "cr2":
            return point, *cr2_function_ci(stat, arrs, ci, clusters)[1:]
        w = resample_counts(n, n_boot, seed, clusters)
        vals = np.asarray(stat(*[(w * a).sum(axis=1) for a in arrs]), dtype=float)
    lo, hi = _interval(vals, ci)
    return point, lo, hi


def houses_of(keys: Iterable[tuple]) -> list[str]:
    """The house (scene) of each (scene, mission) key, the clusters of a paired comparison."""
    return [str(k[0]) for k in keys]


def by_mission(per_mission: Iterable[Mapping], metric: str) -> dict[str, dict[tuple[str, str], float]]:
    """{planner: {(scene, mission): float(row[metric])}} of per-mission rows (for pairing)."""
    out: dict[str, dict[tuple[str, str], float]] = {}
    for r in per_mission:
        out.setdefault(str(r["planner"]), {})[(str(r["scene"]), str(r["mission"]))] = float(r[metric])
    return out


def compare_planners(per_mission: Iterable[Mapping], judge: str, metric: str = "m_overall",
                     n_boot: int = 2000, ci: float = 0.95, seed: int = 0,
                     method: str = "cluster_bootstrap") -> dict[str, dict]:
    """Paired improvement of ``judge`` over every other planner on the (scene, mission) pairs
    both ran. Returns {baseline: {"pct", "ci_lo", "ci_hi", "n_pairs", "ref_mean", "base_mean"}}."""
    by: dict[str, dict[tuple[str, str], float]] = {}
    for r in per_mission:
        by.setdefault(str(r["planner"]), {})[(str(r["scene"]), str(r["mission"]))] = float(r[metric])
    out: dict[str, dict] = {}
    if judge not in by:
        return out
    for base in sorted(by):
        if base == judge:
            continue
        keys = sorted(set(by[judge]) & set(by[base]))
        x = [by[judge][k] for k in keys]
        y = [by[base][k] for k in keys]
        pct, lo, hi = paired_improvement(x, y, n_boot, ci, bootstrap_seed(seed, f"paired:{judge}:{base}"),
                                         houses_of(keys), method)
        out[base] = {"pct": pct, "ci_lo": lo, "ci_hi": hi, "n_pairs": len(keys),
                     "ref_mean": float(np.mean(x)) if x else float("nan"),
                     "base_mean": float(np.mean(y)) if y else float("nan")}
    return out


def group_mean_ci(rows: Iterable[Mapping], keys: Sequence[str], value: str, n_boot: int = 2000,
                  ci: float = 0.95, seed: int = 0, cluster: str = "scene",
                  *, method: str = "cluster_bootstrap") -> list[dict]:
    """Mean and bootstrap CI of ``value`` per group of ``keys``: rows {keys..., mean, ci_lo, ci_hi, n},
    sorted by the group key. The CI is clustered by each row's ``cluster`` field (the house)."""
    groups: dict[tuple, list[float]] = {}
    houses: dict[tuple, list[str]] = {}
    for r in rows:
        g = tuple(r[k] for k in keys)
        groups.setdefault(g, []).append(float(r[value]))
        houses.setdefault(g, []).append(str(r.get(cluster, "")))
    out = []
    for g in sorted(groups):
        m, lo, hi = bootstrap_mean_ci(groups[g], n_boot, ci, bootstrap_seed(seed, f"{value}:{g!r}"), houses[g],
                                     method)
        out.append({**dict(zip(keys, g, strict=True)), "mean": m, "ci_lo": lo, "ci_hi": hi, "n": len(groups[g])})
    return out


def llm_usage(per_mission: Iterable[Mapping]) -> dict[str, dict]:
    """Per planner: missions, total and per-mission LLM calls and tokens."""
    out: dict[str, dict] = {}
    for r in per_mission:
        d = out.setdefault(str(r["planner"]), {"n_missions": 0, "llm_calls": 0, "llm_tokens_in": 0,
                                               "llm_tokens_out": 0})
        d["n_missions"] += 1
        for k in ("llm_calls", "llm_tokens_in", "llm_tokens_out"):
            d[k] += int(r[k])
    for d in out.values():
        n = max(1, d["n_missions"])
        for k in ("llm_calls", "llm_tokens_in", "llm_tokens_out"):
            d[f"{k}_per_mission"] = d[k] / n
    return out


def fulfilment_counts(per_object: Iterable[Mapping]) -> dict[str, dict]:
    """Per planner: objects asked for, slots filled, objects fulfilled (sr_obj = 1)."""
    out: dict[str, dict] = {}
    for r in per_object:
        d = out.setdefault(str(r["planner"]), {"n_objects": 0, "n_filled": 0, "n_fulfilled": 0})
        d["n_objects"] += 1
        d["n_filled"] += int(r["filled"])
        d["n_fulfilled"] += int(float(r["sr_obj"]) >= 0.5)
    return out


# ---- semantic similarity accuracy (Table II) ---------------------------------------------------
def _norm(s: str) -> str:
    return "".join(str(s).split())


def inference_rows(rec: MissionRecord, temperature: Optional[float]) -> list[dict]:
    """One row per cost inference of a MissionRecord, with its ground truth.

    ``truth`` is the class of the simulator's scratch measurement of the same action when the
    inference was made (every inference that could be tried is judged: ``judged`` 1). As a check
    of that measurement, ``executed_truth`` is f_en of the cost of the first execution of the same
    action string at or after the inferring command, when there was one ("" otherwise).

    Rows: planner, scene, mission, temperature, command_index, action, predicted, estimate, judged,
    truth, truth_cost, correct (0/1; 'unknown' is never correct), executed_truth."""
    executed: list[list[tuple[str, float]]] = [[(_norm(str(a.action)), float(a.cost)) for a in c.actions]
                                               for c in rec.commands]
    out = []
    for ci, c in enumerate(rec.commands):
        for inf in c.summary.cost_inferences:
            act = _norm(inf.action)
            pred = inf.predicted.lower()
            hit = next((cost for later in executed[ci:] for s, cost in later if s == act), None)
            out.append({"planner": rec.planner, "scene": rec.scene_id, "mission": rec.mission_id,
                        "temperature": "" if temperature is None else float(temperature),
                        "command_index": ci + 1, "action": inf.action, "predicted": pred,
                        "estimate": float(inf.estimate), "judged": int(bool(inf.truth)), "truth": inf.truth,
                        "truth_cost": "" if inf.truth_cost is None else float(inf.truth_cost),
                        "correct": int(bool(inf.truth) and pred == inf.truth),
                        "executed_truth": encode_cost(hit) if hit is not None else ""})
    return out


CLASSES = ("easy", "medium", "hard")
LABELS = CLASSES + ("unknown",)
CHANCE = 1.0 / len(CLASSES)  # uniform guessing over the three cost classes


def confusion_matrix(rows: Iterable[Mapping]) -> dict[str, dict[str, int]]:
    """{truth: {predicted: count}} over judged inference rows (truth easy / medium / hard;
    predicted easy / medium / hard / unknown)."""
    m = {t: {p: 0 for p in LABELS} for t in CLASSES}
    for r in rows:
        if int(r.get("judged", 0)) and str(r["truth"]) in m and str(r["predicted"]) in LABELS:
            m[str(r["truth"])][str(r["predicted"])] += 1
    return m


def semantic_accuracy(rows: Iterable[Mapping], n_boot: int = 2000, ci: float = 0.95, seed: int = 0,
                      method: str = "cluster_bootstrap") -> list[dict]:
    """Table II per (temperature, planner), over every judged inference (ground truth measured):

    - accuracy = correct / judged ('unknown' counts as wrong), with its bootstrap CI;
    - coverage = answered (not 'unknown') / judged; accuracy_known = correct / answered, with its CI;
    - the baselines for accuracy_known: chance (1/3, uniform over easy / medium / hard) and the
      majority class (always answering the commonest true class of the answered inferences);
    - verdict on the claim "the classes are right more often than a guess": "holds" when the CI of
      accuracy_known lies above both baselines, "does not hold" when it lies below either (below
      the majority class: always answering the commonest class does better; below chance: worse
      than guessing), "cannot tell" only when it straddles the higher baseline;
    - every CI resamples the missions (an inference's errors are shared with its mission's), by
      house then mission within it (``resample_counts``);
    - confusion: "truth>predicted:count" pairs of the judged inferences;
    - truth_agreement: over judged inferences whose action also ran later, the share whose
      executed class equals the measured truth (how well the scratch measurement predicts the run).
    Inferences whose action could not be tried are counted as ``n_unjudged``."""
    groups: dict[tuple, list[Mapping]] = {}
    for r in rows:
        groups.setdefault((str(r["temperature"]), str(r["planner"])), []).append(r)
    out = []
    for (t, p) in sorted(groups):
        g = groups[(t, p)]
        m = [r for r in g if int(r["judged"])]
        known = [r for r in m if r["predicted"] != "unknown"]
        nc = sum(int(r["correct"]) for r in m)
        _, acc_lo, acc_hi = share_ci(m, n_boot, ci, bootstrap_seed(seed, f"semantic:{t}:{p}"), method)
        ak, ak_lo, ak_hi = share_ci(known, n_boot, ci, bootstrap_seed(seed, f"semantic_known:{t}:{p}"), method)
        truths = [str(r["truth"]) for r in known]
        majority = max((truths.count(c) for c in CLASSES), default=0) / len(truths) if truths else float("nan")
        conf: dict[str, int] = {}
        for r in m:
            k = f"{r['truth']}>{r['predicted']}"
            conf[k] = conf.get(k, 0) + 1
        ran = [r for r in m if r.get("executed_truth")]
        out.append({"temperature": t, "planner": p, "n_inferences": len(g), "n_judged": len(m),
                    "n_unjudged": len(g) - len(m), "n_correct": nc,
                    "n_unknown": len(m) - len(known),
                    "accuracy": nc / len(m) if m else float("nan"), "accuracy_ci_lo": acc_lo,
                    "accuracy_ci_hi": acc_hi,
                    "unknown_share": (len(m) - len(known)) / len(m) if m else float("nan"),
                    "coverage": len(known) / len(m) if m else float("nan"),
                    "accuracy_known": ak if known else float("nan"), "accuracy_known_ci_lo": ak_lo,
                    "accuracy_known_ci_hi": ak_hi, "chance": CHANCE, "majority": majority,
                    "verdict": _verdict(ak_lo, ak_hi, max(CHANCE, majority)),
                    "confusion": " ".join(f"{k}:{v}" for k, v in sorted(conf.items())),
                    "n_executed": len(ran),
                    "truth_agreement": (sum(r["executed_truth"] == r["truth"] for r in ran) / len(ran)
                                        if ran else float("nan"))})
    return out


def share_ci(rows: Sequence[Mapping], n_boot: int, ci: float, seed: int,
             method: str = "cluster_bootstrap") -> tuple[float, float, float]:
    """(share, lo, hi) of ``rows`` whose "correct" is 1, with a CI that resamples the missions
    (scene, mission) by house: the share is a ratio of per-mission sums (``joint_bootstrap``)."""
    per: dict[tuple[str, str], list[int]] = {}
    for r in rows:
        c = per.setdefault((str(r["scene"]), str(r["mission"])), [0, 0])
        c[0] += int(r["correct"])
        c[1] += 1
    keys = sorted(per)
    return joint_bootstrap(lambda hits, n: hits / n, [[per[k][0] for k in keys], [per[k][1] for k in keys]],
                           n_boot, ci, seed, houses_of(keys), method)


def _verdict(lo: float, hi: float, baseline: float) -> str:
    """Table II's verdict from accuracy_known's CI [lo, hi] against max(chance, majority)."""
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return "cannot tell"
    if lo > baseline:
        return "holds"
    if hi < CHANCE:
        return "does not hold: below chance"
    if hi < baseline:
        return "does not hold: below the majority class"
    return "cannot tell"
