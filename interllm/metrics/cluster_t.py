"""Cluster-robust t intervals: CR2 standard errors with Bell–McCaffrey degrees of freedom.

The samples of an experiment are missions, and missions in one house share its layout, objects and
commands, so houses are the independent units. A percentile bootstrap that resamples houses needs
many houses to cover; with the 10 houses of a benchmark it is still optimistic. The interval here
is the small-sample one of Bell & McCaffrey (2002, "Bias reduction in standard errors for linear
regression with multi-stage samples", Survey Methodology 28(2)) as recommended by Imbens & Kolesár
(2016, "Robust standard errors in small samples", REStat 98(4)) and Pustejovsky & Tipton (2018,
JBES 36(4)):

- the statistic is a mean (an intercept-only regression) of per-sample values z, or a smooth
  function of several per-sample sums, linearised at the point (the delta method);
- its variance is the CR2 ("bias-reduced linearisation") estimate. For a mean it reduces to
  ``Σ_g S_g² / (n² (1 − p_g))`` with S_g the sum of the residuals z − z̄ in house g and
  p_g = n_g / n its share of the samples;
- the t quantile takes the Bell–McCaffrey (Satterthwaite) degrees of freedom of that estimate under
  independent, equal-variance errors: ``df = 1 / Σ_gh M_gh²`` with
  ``M_gh = (δ_gh p_g − p_g p_h) / √((1 − p_g)(1 − p_h))`` (trace M = 1).

With equal houses (p_g = 1/G) the variance is the variance of the mean of the G house means and
df = G − 1: the interval is the t interval over house means, exact when house means are normal.
With unequal houses it weighs missions equally and lowers df for the imbalance. One house, or no
labels, makes every sample its own cluster (HC2; the ordinary t interval, df = n − 1).

Every sum is ``math.fsum`` (exactly rounded), so the same inputs give the same bytes on any CPU.
``tests/test_interval_coverage.py`` checks the coverage at the benchmark's cluster structure.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Sequence
from typing import Any, Optional

from scipy.stats import t as student_t

COMPLEX_STEP = 1e-20  # the step of the complex-step derivative (exact to rounding for analytic stats)


def cluster_index(n: int, clusters: Optional[Sequence[Hashable]]) -> list[list[int]]:
    """The sample indices of each cluster, clusters in sorted label order. Fewer than two distinct
    labels (or none) make every sample its own cluster."""
    if clusters is None:
        return [[i] for i in range(n)]
    labels = [str(c) for c in clusters]
    if len(labels) != n:
        raise ValueError(f"{len(labels)} cluster labels for {n} samples")
    houses = sorted(set(labels))
    if len(houses) < 2:
        return [[i] for i in range(n)]
    return [[i for i, c in enumerate(labels) if c == h] for h in houses]


def cr2_variance(z: Sequence[float], groups: Sequence[Sequence[int]]) -> tuple[float, float]:
    """(variance of the mean of ``z``, Bell–McCaffrey df) for the clusters ``groups`` (index lists
    covering 0..n−1). The variance is in the squared unit of z; df is NaN with one cluster."""
    a = [float(v) for v in z]
    n = len(a)
    mean = math.fsum(a) / n
    shares = [len(g) / n for g in groups]
    if len(groups) < 2 or max(shares) >= 1.0:
        return float("nan"), float("nan")
    var = math.fsum(math.fsum(a[i] - mean for i in g) ** 2 / (1.0 - p) for g, p in zip(groups, shares, strict=True)) / n**2
    scale = [1.0 / math.sqrt(1.0 - p) for p in shares]
    m_sq = math.fsum(((p if g == h else 0.0) - p * q) ** 2 * (scale[g] * scale[h]) ** 2
                     for g, p in enumerate(shares) for h, q in enumerate(shares))
    return var, 1.0 / m_sq


def _t_interval(point: float, var: float, df: float, ci: float) -> tuple[float, float, float]:
    """(point, lo, hi): point ± t_{df, (1+ci)/2} · √var; NaN bounds when the variance is not finite."""
    if not (math.isfinite(point) and math.isfinite(var) and math.isfinite(df)):
        return point, float("nan"), float("nan")
    half = float(student_t.ppf(0.5 + ci / 2.0, df)) * math.sqrt(var)
    return point, point - half, point + half


def cr2_mean_ci(x: Sequence[float], ci: float = 0.95, clusters: Optional[Sequence[Hashable]] = None
                ) -> tuple[float, float, float]:
    """(mean, lo, hi): the CR2 t interval at coverage ``ci`` of the mean of ``x`` (any unit),
    clustered by ``clusters`` (the house of each sample). The caller handles tiny samples."""
    a = [float(v) for v in x]
    var, df = cr2_variance(a, cluster_index(len(a), clusters))
    return _t_interval(math.fsum(a) / len(a), var, df, ci)


def gradient(stat: Callable[..., Any], point: Sequence[float]) -> list[float]:
    """∂stat/∂s_j at ``point`` by the complex step (Im stat(s + i h e_j) / h): no cancellation, so
    it is exact to rounding. ``stat`` must be arithmetic (sums, differences, products, ratios)."""
    out = []
    for j in range(len(point)):
        s = [complex(v) for v in point]
        s[j] += complex(0.0, COMPLEX_STEP)
        out.append(float(complex(stat(*s)).imag / COMPLEX_STEP))
    return out


def cr2_function_ci(stat: Callable[..., Any], arrays: Sequence[Sequence[float]], ci: float = 0.95,
                    clusters: Optional[Sequence[Hashable]] = None) -> tuple[float, float, float]:
    """(stat(*sums), lo, hi) for a smooth statistic of the sums of several paired samples (one value
    per mission each, the same missions in the same order), e.g. a ratio of sums. ``stat`` must not
    depend on the sums' scale (``stats.joint_bootstrap``'s contract), so stat(sums) = stat(means)
    and the delta method applies: each mission's linearised value is z_i = Σ_j ∂stat/∂m_j · x_ij at
    the means, and the interval is ``cr2_mean_ci``'s for the mean of z, centred on the point."""
    arrs = [[float(v) for v in a] for a in arrays]
    n = len(arrs[0])
    means = [math.fsum(a) / n for a in arrs]
    point = float(stat(*[math.fsum(a) for a in arrs]))
    if not math.isfinite(point):
        return point, float("nan"), float("nan")
    grad = gradient(stat, means)
    z = [math.fsum(gj * a[i] for gj, a in zip(grad, arrs, strict=True)) for i in range(n)]
    var, df = cr2_variance(z, cluster_index(n, clusters))
    return _t_interval(point, var, df, ci)


def house_means(x: Sequence[float], clusters: Sequence[Hashable]) -> dict[str, float]:
    """{house: mean of its samples} of ``x`` (the per-house effects printed beside a comparison)."""
    out: dict[str, list[float]] = {}
    for v, c in zip(x, clusters, strict=True):
        out.setdefault(str(c), []).append(float(v))
    return {h: math.fsum(v) / len(v) for h, v in sorted(out.items())}

