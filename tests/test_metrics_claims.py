"""The paper's claims judged from hand-made rows (interllm/metrics/claims.py), worked out by hand."""

from __future__ import annotations

import math

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


def _inferences(acc_by_sigma: dict[float, float], n: int = 30) -> list[dict]:
    rows = []
    for s, acc in acc_by_sigma.items():
        k = round(acc * n)
        rows += [{"planner": "inter_llm", "temperature": s, "judged": 1, "predicted": "easy",
                  "correct": int(j < k)} for j in range(n)]
    return rows


def test_the_rise_of_accuracy_with_sigma():
    up = claims.sigma_rise(_inferences({0.2: 0.2, 0.5: 0.5, 0.8: 0.8}), n_boot=300)
    assert up["slope"] == pytest.approx(1.0) and up["verdict"] == "holds"
    flat = claims.sigma_rise(_inferences({0.2: 0.5, 0.8: 0.5}), n_boot=300)
    assert flat["slope"] == pytest.approx(0.0) and flat["verdict"] == "cannot tell"
    assert claims.sigma_rise(_inferences({0.8: 0.5}), n_boot=300)["verdict"] == "cannot tell"  # one σ


def test_missions_needed_for_a_10_percent_difference():
    # the baseline costs 100 on every mission; the differences alternate 0, 20: sd = 10.954
    rows = [{"planner": "sayplan", "scene": "s", "mission": f"m{i}", "m_overall": 100.0} for i in range(6)]
    rows += [{"planner": "inter_llm", "scene": "s", "mission": f"m{i}", "m_overall": 100.0 - 20 * (i % 2)}
             for i in range(6)]
    v = claims.missions_needed(rows, "inter_llm")["sayplan"]
    sd = math.sqrt(6 * 100 / 5)  # deviations of ±10 around the mean 10, ddof = 1
    assert v["sd_diff"] == pytest.approx(sd)
    assert v["n_needed"] == math.ceil(((1.959964 + 0.841621) * sd / 10.0) ** 2) == 10
