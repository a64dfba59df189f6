"""The CR2 t interval (``interllm.metrics.cluster_t``) against independent computations: the t
interval over house means when houses are equal, the ordinary t interval without houses, and the
Bell–McCaffrey degrees of freedom from the matrix definition when houses are unequal."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats as sps

from interllm.config import ConfigError, MetricsConfig
from interllm.metrics import cluster_t, stats
from interllm.metrics.deliveries import paired_comparisons


def _sample(seed: int, houses: int, missions: int) -> tuple[np.ndarray, list[str]]:
    rng = np.random.default_rng(seed)
    x = np.repeat(rng.normal(0, 2, houses), missions) + rng.normal(0, 1, houses * missions)
    return x, [f"house{i // missions:02d}" for i in range(houses * missions)]


def test_equal_houses_give_the_t_interval_over_house_means():
    x, labels = _sample(0, 10, 3)
    means = x.reshape(10, 3).mean(axis=1)
    want = sps.t.interval(0.95, 9, loc=means.mean(), scale=means.std(ddof=1) / np.sqrt(10))
    _, lo, hi = cluster_t.cr2_mean_ci(x, 0.95, labels)
    assert (lo, hi) == pytest.approx(want, rel=1e-12)


def test_without_houses_it_is_the_ordinary_t_interval():
    x, _ = _sample(1, 6, 5)
    want = sps.t.interval(0.9, x.size - 1, loc=x.mean(), scale=x.std(ddof=1) / np.sqrt(x.size))
    for clusters in (None, ["one house"] * x.size):
        _, lo, hi = cluster_t.cr2_mean_ci(x, 0.9, clusters)
        assert (lo, hi) == pytest.approx(want, rel=1e-12)


def test_unequal_houses_take_the_bell_mccaffrey_df_of_the_matrix_definition():
    """df = (tr GᵀG)² / tr((GᵀG)²), G's columns (I − H)ᵀ A_g X_g (XᵀX)⁻¹ with A_g = (I − H_gg)^(−1/2)."""
    sizes = [1, 2, 2, 3, 5, 8]
    labels = [f"h{g}" for g, k in enumerate(sizes) for _ in range(k)]
    n = len(labels)
    x = np.ones((n, 1))
    hat = x @ np.linalg.inv(x.T @ x) @ x.T
    cols, start = [], 0
    for k in sizes:
        idx = np.arange(start, start + k)
        start += k
        w, v = np.linalg.eigh(np.eye(k) - hat[np.ix_(idx, idx)])
        a_g = v @ np.diag(w ** -0.5) @ v.T
        cols.append((np.eye(n) - hat)[idx].T @ a_g @ x[idx] @ np.linalg.inv(x.T @ x))
    gram = np.hstack(cols).T @ np.hstack(cols)
    want_df = np.trace(gram) ** 2 / np.trace(gram @ gram)
    z = np.random.default_rng(2).normal(size=n)
    resid = z - z.mean()
    want_var = sum((a.T @ resid).item() ** 2 for a in cols)  # Σ_g (c_gᵀ e)²: the CR2 variance
    groups = cluster_t.cluster_index(n, labels)
    assert [len(g) for g in groups] == sizes
    var, df = cluster_t.cr2_variance(z, groups)
    assert df == pytest.approx(want_df, rel=1e-10)
    assert var == pytest.approx(want_var, rel=1e-10)


def test_a_ratio_of_sums_is_linearised_at_the_means():
    """For a ratio of sums the interval is the mean's of the linearised values (delta method)."""
    x, labels = _sample(3, 10, 3)
    base = 100.0 + x
    ref = base - 5.0 + np.random.default_rng(4).normal(0, 1, x.size)
    pct, lo, hi = stats.paired_improvement(ref, base, clusters=labels, method="cr2")
    mb = base.mean()
    z = 100.0 * (ref.mean() * base / mb**2 - ref / mb)  # ∂/∂m_b, ∂/∂m_r of 100(m_b − m_r)/m_b
    _, zlo, zhi = cluster_t.cr2_mean_ci(z, 0.95, labels)
    half = (zhi - zlo) / 2
    assert pct == pytest.approx(100 * (base.sum() - ref.sum()) / base.sum())
    assert (lo, hi) == pytest.approx((pct - half, pct + half), rel=1e-9)


def test_cr2_ignores_the_bootstrap_seed_and_reproduces_bytes():
    x, labels = _sample(5, 10, 3)
    a = stats.bootstrap_mean_ci(x, 2000, 0.95, 1, labels, "cr2")
    b = stats.bootstrap_mean_ci(x.copy(), 100, 0.95, 99, labels, "cr2")
    assert a == b


def test_an_unknown_method_names_the_choices():
    with pytest.raises(ValueError, match="cluster_bootstrap, cr2"):
        stats.bootstrap_mean_ci([1.0] * 6, method="wild")
    cfg = MetricsConfig(interval="wild")
    with pytest.raises(ConfigError, match=r"metrics\.interval.*cluster_bootstrap"):
        cfg.validate()


def test_paired_comparisons_carry_the_per_house_effects():
    rows = []
    for h, shift in (("a", -3.0), ("b", 1.0), ("c", -1.0)):
        for m in range(2):
            rows.append({"planner": "judge", "scene": h, "mission": f"m{m}", "m_overall": 10.0 + shift + m,
                         "n_fulfilled": 2.0})
            rows.append({"planner": "other", "scene": h, "mission": f"m{m}", "m_overall": 10.0,
                         "n_fulfilled": 2.0})
    c = paired_comparisons(rows, "judge", method="cr2")["judge_vs_other"]
    assert c["m_overall_diff_by_house"] == {"a": -2.5, "b": 1.5, "c": -0.5}
    assert c["delivered_diff_by_house"] == {"a": 0.0, "b": 0.0, "c": 0.0}
    assert c["m_overall_diff"] == pytest.approx(-0.5)
