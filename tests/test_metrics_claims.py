"""The paper's claims judged from hand-made rows (interllm/metrics/claims.py), worked out by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from interllm.metrics import claims


def _imp(lo, hi, pct=None):
    return {"improvement": {"inter_llm_vs_sayplan": {"pct": pct if pct is not None else (lo + hi) / 2,
                                                     "ci_lo": lo, "ci_hi": hi}}}


@pytest.mark.parametrize("lo, hi, verdict", [(20, 40, "holds"), (5, 15, "does not hold"), (35, 50, "exceeds"),
                                             (float("nan"), float("nan"), "cannot tell")])
def test_the_30_percent_claim(lo, hi, verdict):
    assert claims.improvement_30(_imp(lo, hi, 10.0))["sayplan"]["verdict"] == verdict


def _commands(gain_per_object: float, n_missions: int = 6) -> list[dict]:
    """Two-command missions; the baseline costs 100 per object in both commands, the judged planner 90
    in the first and 90 - gain in the last (±1 of mission-to-mission noise)."""
    rows = []
    for i in range(n_missions):
        noise = (-1) ** i
        for ci, (ref, base) in enumerate(((90 + noise, 100), (90 - gain_per_object - noise, 100)), start=1):
            rows.append({"planner": "inter_llm", "scene": "s", "mission": f"m{i}", "command_index": ci,
                         "n_objects": 3, "m_overall": 3 * ref})
            rows.append({"planner": "sayplan", "scene": "s", "mission": f"m{i}", "command_index": ci,
                         "n_objects": 3, "m_overall": 3 * base})
    return rows


def test_self_improvement_is_a_difference_in_differences():
    v = claims.self_improvement(_commands(10.0), "inter_llm", n_boot=500)["sayplan"]
    assert v["did"] == pytest.approx(-10.0) and v["n"] == 6 and v["verdict"] == "holds"
    assert claims.self_improvement(_commands(0.0), "inter_llm", n_boot=500)["sayplan"]["verdict"] == "cannot tell"


def _inferences(acc_by_sigma: dict[float, float], n: int = 30, houses: int = 3, missions: int = 5) -> list[dict]:
    """n judged inferences per σ, spread round-robin over houses × missions, the first acc·n correct."""
    rows = []
    for s, acc in acc_by_sigma.items():
        k = round(acc * n)
        rows += [{"planner": "inter_llm", "scene": f"h{j % houses}", "mission": f"m{j % missions}", "temperature": s,
                  "judged": 1, "predicted": "easy", "correct": int(j < k)} for j in range(n)]
    return rows


def test_the_rise_of_accuracy_with_sigma():
    up = claims.sigma_rise(_inferences({0.2: 0.2, 0.5: 0.5, 0.8: 0.8}), n_boot=300)
    assert up["slope"] == pytest.approx(1.0) and up["verdict"] == "holds"
    flat = claims.sigma_rise(_inferences({0.2: 0.5, 0.8: 0.5}), n_boot=300)
    assert flat["slope"] == pytest.approx(0.0) and flat["verdict"] == "cannot tell"
    assert claims.sigma_rise(_inferences({0.8: 0.5}), n_boot=300)["verdict"] == "cannot tell"  # one σ
    one_mission = claims.sigma_rise(_inferences({0.2: 0.2, 0.8: 0.8}, houses=1, missions=1), n_boot=300)
    assert one_mission["verdict"] == "cannot tell" and one_mission["n_missions"] == 1  # nothing to resample


def _house_effect_inferences(rise: float) -> list[dict]:
    """3 σ values on 4 houses × 3 missions × 10 inferences; house h answers right with probability
    0.2 + 0.2·h at every σ, plus ``rise``·σ: a strong house effect, the same missions at every σ."""
    rows = []
    for s in (0.2, 0.5, 0.8):
        for h in range(4):
            for m in range(3):
                k = round(10 * min(1.0, 0.2 + 0.2 * h + rise * s))
                rows += [{"planner": "inter_llm", "scene": f"h{h}", "mission": f"m{m}", "temperature": s, "judged": 1,
                          "predicted": "easy", "correct": int(j < k)} for j in range(10)]
    return rows


def test_the_sigma_slope_resamples_houses_and_missions_the_same_at_every_sigma():
    """Drawing the same missions at every σ pairs the σ values: a house effect that is the same at every
    σ cancels from the slope, so the paired interval is narrower than one resampling each σ on its own."""
    rows = _house_effect_inferences(0.1)
    v = claims.sigma_rise(rows, n_boot=500)
    assert v["n_missions"] == 12 and v["slope"] == pytest.approx(np.polyfit([0.2, 0.5, 0.8], [
        np.mean([r["correct"] for r in rows if r["temperature"] == s]) for s in (0.2, 0.5, 0.8)], 1)[0])
    rng = np.random.default_rng(0)  # each σ resampled independently, houses then missions (unpaired)
    unpaired = []
    for _ in range(500):
        accs = []
        for s in (0.2, 0.5, 0.8):
            hs = rng.integers(0, 4, 4)
            accs.append(np.mean([r["correct"] for h in hs for r in rows if r["temperature"] == s
                                 and r["scene"] == f"h{h}"]))
        unpaired.append(np.polyfit([0.2, 0.5, 0.8], accs, 1)[0])
    lo, hi = np.quantile(unpaired, [0.025, 0.975])
    assert v["hi"] - v["lo"] < 0.5 * (hi - lo)
    assert v["verdict"] == "holds"


def test_houses_needed_for_a_10_percent_difference_by_hand():
    # the baseline costs 100 on every mission; in both houses the differences alternate 0, 20:
    # the house means agree (σ_b = 0) and the pooled within-house variance is 6·10² / 5 = 120
    rows = _paired({"h0": [0.0, 20.0] * 3, "h1": [0.0, 20.0] * 3})
    v = claims.houses_needed(rows, "inter_llm")["sayplan"]
    assert v["sd_within"] == pytest.approx(math.sqrt(120.0)) and v["sd_between"] == pytest.approx(0.0)
    # H = ⌈(1.959964 + 0.841621)² · (0 + 120 / 6) / 10²⌉ = ⌈1.57⌉ = 2 houses of 6 missions
    assert (v["houses_needed"], v["missions_needed"], v["missions_per_house"]) == (2, 12, 6.0)


def _paired(diffs_by_house: dict[str, list[float]]) -> list[dict]:
    """per_mission rows: sayplan at 100 s, inter_llm 100 − d for each house's differences d."""
    rows = []
    for h, ds in diffs_by_house.items():
        for i, d in enumerate(ds):
            rows += [{"planner": "sayplan", "scene": h, "mission": f"m{i}", "m_overall": 100.0},
                     {"planner": "inter_llm", "scene": h, "mission": f"m{i}", "m_overall": 100.0 - d}]
    return rows


def test_houses_needed_counts_the_spread_between_houses_not_only_the_missions():
    # every mission in a house gains the same: all spread is between houses (σ_w = 0), so more
    # missions per house buy nothing and the houses needed follow from the house means alone
    between = _paired({"h0": [0.0] * 10, "h1": [20.0] * 10, "h2": [10.0] * 10})
    v = claims.houses_needed(between, "inter_llm")["sayplan"]
    assert v["sd_within"] == pytest.approx(0.0) and v["sd_between"] == pytest.approx(10.0)
    # (1.96 + 0.84)² · 10² / (0.1 · 100)² = 7.85 -> 8 houses, 80 missions
    assert (v["houses_needed"], v["missions_needed"], v["n_houses"]) == (8, 80, 3)
    # the same spread within houses instead: the mean of 10 missions per house averages it away
    within = _paired({h: [0.0, 20.0] * 5 for h in ("h0", "h1", "h2")})
    w = claims.houses_needed(within, "inter_llm")["sayplan"]
    assert w["sd_between"] == pytest.approx(0.0) and w["houses_needed"] < v["houses_needed"]
    one = claims.houses_needed(_paired({"h0": [0.0, 20.0] * 5}), "inter_llm")["sayplan"]
    assert math.isnan(one["houses_needed"]) and one["n_houses"] == 1
