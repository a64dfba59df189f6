"""Bootstrap CIs, paired comparison, f_en thresholds, LLM usage."""

from __future__ import annotations

import numpy as np
import pytest

from interllm.core.seeding import bootstrap_seed
from interllm.metrics.stats import (
    bootstrap_mean_ci,
    compare_planners,
    fulfilment_counts,
    group_mean_ci,
    improvement_pct,
    joint_bootstrap,
    llm_usage,
    paired_improvement,
    paired_mean_diff,
    resample_counts,
)
from interllm.planning.costs import encode_cost


def test_bootstrap_deterministic_by_seed():
    x = np.random.default_rng(1).normal(10, 3, 25)
    a = bootstrap_mean_ci(x, 500, 0.95, 7)
    assert a == bootstrap_mean_ci(list(x), 500, 0.95, 7)
    assert a != bootstrap_mean_ci(x, 500, 0.95, 8)
    m, lo, hi = a
    assert m == pytest.approx(float(np.mean(x))) and lo < m < hi


def test_bootstrap_edge_cases():
    m, lo, hi = bootstrap_mean_ci([4.0, 5.0, 6.0, 7.0], 100)  # fewer than five: a mean, no interval
    assert m == 5.5 and np.isnan(lo) and np.isnan(hi)
    assert not np.isnan(bootstrap_mean_ci([4.0, 5.0, 6.0, 7.0, 8.0], 100)[1])
    assert all(np.isnan(v) for v in bootstrap_mean_ci([], 100))
    assert bootstrap_mean_ci([2.0] * 10, 100) == (2.0, 2.0, 2.0)


def test_bootstrap_coverage_near_nominal():
    rng = np.random.default_rng(123)
    hits = 0
    reps = 200
    for i in range(reps):
        x = rng.normal(5.0, 2.0, 30)
        _, lo, hi = bootstrap_mean_ci(x, 1000, 0.95, bootstrap_seed(0, f"rep{i}"))
        hits += lo <= 5.0 <= hi
    assert 0.90 <= hits / reps <= 0.98


def test_ci_width_shrinks_with_level():
    x = np.random.default_rng(2).exponential(3.0, 40)
    _, lo90, hi90 = bootstrap_mean_ci(x, 2000, 0.90, 0)
    _, lo99, hi99 = bootstrap_mean_ci(x, 2000, 0.99, 0)
    assert lo99 < lo90 and hi90 < hi99


def test_paired_improvement_by_hand():
    assert improvement_pct([80, 90], [100, 100]) == pytest.approx(15.0)
    # the judged planner is exactly half of every baseline: every resample gives 50 %
    base = [100.0, 220.0, 340.0, 90.0, 150.0]
    pct, lo, hi = paired_improvement([b / 2 for b in base], base, 500, 0.95, 3)
    assert (pct, lo, hi) == pytest.approx((50.0, 50.0, 50.0))
    pct, lo, hi = paired_improvement([b / 2 for b in base[:4]], base[:4], 500, 0.95, 3)  # four pairs
    assert pct == pytest.approx(50.0) and np.isnan(lo) and np.isnan(hi)
    with pytest.raises(ValueError, match="length"):
        paired_improvement([1.0], [1.0, 2.0])


def test_compare_planners_uses_common_pairs_only():
    rows = [{"planner": "inter_llm", "scene": "s0", "mission": "m0", "m_overall": 80.0},
            {"planner": "inter_llm", "scene": "s0", "mission": "m1", "m_overall": 60.0},
            {"planner": "sayplan", "scene": "s0", "mission": "m0", "m_overall": 100.0},
            {"planner": "sayplan", "scene": "s1", "mission": "m0", "m_overall": 1000.0},
            {"planner": "moma_llm", "scene": "s0", "mission": "m1", "m_overall": 50.0}]
    out = compare_planners(rows, "inter_llm", n_boot=200)
    assert out["sayplan"]["n_pairs"] == 1 and out["sayplan"]["pct"] == pytest.approx(20.0)
    assert out["moma_llm"]["pct"] == pytest.approx(-20.0)  # worse than the baseline
    assert compare_planners(rows, "nobody") == {}


@pytest.mark.parametrize("cost, cls", [(0.0, "easy"), (4.999, "easy"), (5.0, "medium"), (10.0, "medium"),
                                       (15.0, "medium"), (15.001, "hard"), (120.0, "hard")])
def test_cost_class_thresholds(cost, cls):
    assert encode_cost(cost) == cls  # the one f_en Table II's truth and the prompts use


def test_group_mean_ci_and_counts():
    rows = [{"planner": p, "object_index": i, "v": float(i * k), "filled": 1, "sr_obj": float(i % 2),
             "llm_calls": 2, "llm_tokens_in": 10, "llm_tokens_out": 3}
            for p in ("a", "b") for i in (1, 2) for k in (1, 3)]
    g = group_mean_ci(rows, ("planner", "object_index"), "v", 200, 0.95, 0)
    assert [(r["planner"], r["object_index"], r["mean"], r["n"]) for r in g] == [
        ("a", 1, 2.0, 2), ("a", 2, 4.0, 2), ("b", 1, 2.0, 2), ("b", 2, 4.0, 2)]
    assert fulfilment_counts(rows)["a"] == {"n_objects": 4, "n_filled": 4, "n_fulfilled": 2}
    u = llm_usage(rows)["b"]
    assert u["llm_calls"] == 8 and u["llm_calls_per_mission"] == 2.0 and u["llm_tokens_in"] == 40


def test_bootstrap_seed_stable():
    assert bootstrap_seed(0, "x") == bootstrap_seed(0, "x") != bootstrap_seed(1, "x")
    # SHA-256 of b'["bootstrap",0,"inter_llm"]', 4 bytes big-endian, top bit cleared: same in every process
    assert bootstrap_seed(0, "inter_llm") == 2022904059


def _inferences(pairs: list[tuple[str, str]]) -> list[dict]:
    """Hand-made judged inferences: (truth, predicted), dealt in turn to 20 missions in 4 houses."""
    return [{"temperature": 0.8, "planner": "inter_llm", "scene": f"house{i % 20 // 5}", "mission": f"m{i % 20}",
             "judged": 1, "truth": t, "predicted": p, "correct": int(t == p)} for i, (t, p) in enumerate(pairs)]


def test_table_ii_against_chance_and_the_majority_class():
    from interllm.metrics.stats import semantic_accuracy

    classes = ("easy", "medium", "hard")
    # a model that guesses uniformly: each truth meets each prediction equally often (1/3 correct)
    guess = [(t, p) for t in classes for p in classes] * 6
    (row,) = semantic_accuracy(_inferences(guess + [("hard", "unknown")] * 6), 500, 0.95, 0)
    assert row["accuracy_known"] == pytest.approx(1 / 3) and row["coverage"] == pytest.approx(54 / 60)
    assert row["chance"] == pytest.approx(1 / 3) and row["majority"] == pytest.approx(1 / 3)
    assert row["verdict"] == "cannot tell"
    assert row["accuracy"] == pytest.approx(18 / 60)  # 'unknown' counts as wrong here
    assert "hard>unknown:6" in row["confusion"] and "easy>easy:6" in row["confusion"]
    # always answering "hard" when 80% of the truths are hard: 80% correct, but no better than the majority
    lazy = [("hard", "hard")] * 40 + [("easy", "hard")] * 10
    (row,) = semantic_accuracy(_inferences(lazy), 500, 0.95, 0)
    assert row["majority"] == pytest.approx(0.8) and row["verdict"] == "cannot tell"
    # a model that is right 45 times in 50 on balanced truths: above both baselines
    good = [(c, c) for c in classes] * 15 + [("easy", "hard")] * 5
    (row,) = semantic_accuracy(_inferences(good), 500, 0.95, 0)
    assert row["verdict"] == "holds" and row["accuracy_known_ci_lo"] > max(row["chance"], row["majority"])
    # guessing uniformly when 80% of the truths are hard: a third right, far below always answering "hard"
    skewed = [("hard", p) for p in classes] * 40 + [(t, p) for t in ("easy", "medium") for p in classes] * 5
    (row,) = semantic_accuracy(_inferences(skewed), 500, 0.95, 0)
    assert row["majority"] == pytest.approx(0.8) and row["accuracy_known_ci_hi"] < 0.8
    assert row["verdict"] == "does not hold: below the majority class"
    # always wrong: below chance too
    (row,) = semantic_accuracy(_inferences([("easy", "hard"), ("hard", "easy")] * 30), 500, 0.95, 0)
    assert row["verdict"] == "does not hold: below chance"


def _houses(effects: list[float], per_house: int, spread: float, seed: int) -> tuple[list[float], list[str]]:
    """Per-mission values: a house effect plus mission noise; and the house of each."""
    rng = np.random.default_rng(seed)
    x, h = [], []
    for i, e in enumerate(effects):
        x += list(e + rng.normal(0.0, spread, per_house))
        h += [f"house{i}"] * per_house
    return x, h


def test_the_house_clustered_interval_is_wider_when_houses_differ():
    # five houses whose missions differ little within a house but a lot between houses: the missions
    # are not 50 independent draws, and an interval that treats them so is too narrow
    x, houses = _houses([0.0, 40.0, -30.0, 10.0, 60.0], 10, 2.0, 4)
    _, lo_iid, hi_iid = bootstrap_mean_ci(x, 2000, 0.95, 1)
    _, lo, hi = bootstrap_mean_ci(x, 2000, 0.95, 1, houses)
    assert hi - lo > 3 * (hi_iid - lo_iid)
    # the same holds for paired differences and ratios of sums
    y = [v + 5.0 for v in x]
    assert np.diff(paired_mean_diff(y, x, 2000, 0.95, 1, houses)[1:]) == pytest.approx(0.0)  # constant gap
    shifted = [v + 100.0 for v in x]
    w_iid = np.diff(joint_bootstrap(lambda a, b: a / b, [shifted, [1.0] * 50], 2000, 0.95, 1)[1:])[0]
    w_h = np.diff(joint_bootstrap(lambda a, b: a / b, [shifted, [1.0] * 50], 2000, 0.95, 1, houses)[1:])[0]
    assert w_h > 3 * w_iid


def test_without_a_house_effect_clustering_changes_little():
    x, houses = _houses([0.0] * 6, 10, 5.0, 5)
    _, lo_iid, hi_iid = bootstrap_mean_ci(x, 4000, 0.95, 2)
    _, lo, hi = bootstrap_mean_ci(x, 4000, 0.95, 2, houses)
    assert 0.7 < (hi - lo) / (hi_iid - lo_iid) < 1.6


def test_resample_counts_draw_whole_houses_then_missions_within_them():
    houses = ["a"] * 3 + ["b"] * 5 + ["c"] * 2
    w = resample_counts(10, 400, 9, houses)
    assert w.shape == (400, 10) and w.dtype.kind == "i"
    size = {"a": 3, "b": 5, "c": 2}
    for row in w:
        per = {h: int(row[[i for i, x in enumerate(houses) if x == h]].sum()) for h in size}
        # each house contributes a multiple of its size: it was drawn that many times
        assert all(per[h] % size[h] == 0 for h in size) and sum(per[h] // size[h] for h in size) == 3
    assert (w == resample_counts(10, 400, 9, houses)).all()
    # one house (or none named) is the ordinary bootstrap: every row holds n draws
    assert (resample_counts(10, 50, 9, ["a"] * 10).sum(axis=1) == 10).all()
    assert (resample_counts(10, 50, 9) == resample_counts(10, 50, 9, ["a"] * 10)).all()
    with pytest.raises(ValueError, match="cluster labels"):
        resample_counts(10, 50, 9, ["a"] * 9)
