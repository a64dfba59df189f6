import numpy as np
import pytest

from interllm.core.actions import Action, State
from interllm.core.results import ActionResult
from interllm.planning.costs import (
    UNREACHABLE_COST,
    decode_cost,
    encode_cost,
    estimate_navigation,
    plan_total,
)
from interllm.planning.memory import KnownCosts


@pytest.mark.parametrize("cost,label", [(0.0, "easy"), (4.999, "easy"), (5.0, "medium"), (10.0, "medium"),
                                        (15.0, "medium"), (15.0001, "hard"), (120.0, "hard")])
def test_encode_thresholds(cost, label):
    assert encode_cost(cost) == label


@pytest.mark.parametrize("label,value", [("hard", 20), ("medium", 10), ("easy", 5), ("unknown", 0),
                                         (" Hard ", 20)])
def test_decode(label, value):
    assert decode_cost(label) == value


def test_decode_rejects_other_labels():
    with pytest.raises(ValueError, match="easy"):
        decode_cost("trivial")


def test_plan_total_with_unknown_manipulation():
    # Σ nav = 30; Σ man = 5 + 0 + 20 = 25; N_valid/N_man = 2/3 -> 30 + 25·2/3
    assert plan_total([10, 20], [5, 0, 20], [True, False, True]) == pytest.approx(30 + 50 / 3)


def test_plan_total_all_unknown_and_no_manipulation():
    assert plan_total([7.0], [0, 0], [False, False]) == pytest.approx(7.0)
    assert plan_total([7.0, 1.0], [], []) == pytest.approx(8.0)  # 0/0 := 0


S0 = State("sofa_1", "living_room_1")
NAV = Action("navigate", "desk_1", room="office_1")
PICK = Action("pickup", "desk_1", obj="mug_1")


def test_fusion_averages_same_pair_and_appends_new():
    k = KnownCosts()
    k.add_manipulation(PICK, S0, 10.0)
    k.add_manipulation(PICK, S0, 20.0)
    assert [r.cost for r in k.maned] == [15.0]
    k.add_manipulation(PICK, S0, 30.0)  # (30 + 15)/2
    assert k.maned[0].cost == pytest.approx(22.5) and k.maned[0].count == 3
    k.add_manipulation(PICK, State("desk_1", "office_1"), 4.0)  # different state: new pair
    assert [r.cost for r in k.maned] == [22.5, 4.0]
    assert k.manipulation_cost(PICK, S0) == pytest.approx(22.5)
    assert k.manipulation_cost(PICK, State("x", "y")) is None


def test_add_result_stores_driven_path_and_fuses_navigation():
    k = KnownCosts()
    p1 = np.array([[0, 0], [1, 0]], float)
    p2 = np.array([[0, 0], [2, 0]], float)
    k.add_result(ActionResult(NAV, True, 8.0, 2.0, driven_path=p1), S0)
    k.add_result(ActionResult(NAV, False, 20.0, 2.0, collisions=1, driven_path=p2), S0)
    assert len(k.naved) == 1 and k.naved[0].cost == pytest.approx(14.0)
    np.testing.assert_allclose(k.naved[0].path, p2)
    assert k.add_result(ActionResult(NAV, False, 1.0, 0.0), S0) is None  # no path at all
    k.add_result(ActionResult(PICK, False, 104.0, 4.0, success_rate=0.0), S0)
    assert k.maned[0].cost == 104.0


def straight(n=41, length=2.0, y=0.0):
    return np.stack([np.linspace(0, length, n), np.full(n, y)], axis=1)


def test_navigation_fallback_without_known_paths():
    # 2 m at 0.5 m/s: t = 4 s, d = 2 m, cc = 0 -> 6
    est, src = estimate_navigation(straight(), KnownCosts(), 1.0, "paper_sum", base_speed=0.5)
    assert est == pytest.approx(6.0) and src == "fallback_presumed"
    assert estimate_navigation(None, KnownCosts(), 1.0)[0] == UNREACHABLE_COST


def test_navigation_paper_sum_and_weighted_mean():
    k = KnownCosts()
    k.add_navigation(NAV, S0, straight(), 10.0)  # identical path: P° = 200
    k.add_navigation(Action("navigate", "bed_1", room="bedroom_1"), S0, straight(y=9.0), 100.0)  # P° = 0
    est, _ = estimate_navigation(straight(), k, 1.0, "paper_sum")
    assert est == pytest.approx(10.0 * 200 + 100.0 * 0)
    est, _ = estimate_navigation(straight(), k, 1.0, "weighted_mean")
    assert est == pytest.approx(10.0)
    # half overlap: the query is 0.5 m off the first path -> P° = 100 -> 10·100 = 1000
    est, _ = estimate_navigation(straight(y=0.5), k, 1.0, "paper_sum")
    assert est == pytest.approx(1000.0)


def test_weighted_mean_falls_back_when_nothing_overlaps():
    k = KnownCosts()
    k.add_navigation(NAV, S0, straight(y=9.0), 50.0)
    assert estimate_navigation(straight(), k, 1.0, "paper_sum")[0] == 0.0
    est, src = estimate_navigation(straight(), k, 1.0, "weighted_mean", base_speed=0.5)
    assert est == pytest.approx(6.0) and src == "fallback_presumed"


def test_unknown_mode_raises():
    with pytest.raises(ValueError, match="nav_estimate"):
        estimate_navigation(straight(), KnownCosts(), 1.0, "median")


def test_the_prior_estimate_has_no_novelty_bias():
    """ĉ = L (r_0 + Σ w_i r_i) / (1 + Σ w_i), r_0 = 1/0.5 + 1 = 3 per metre, w = P°/200."""
    from interllm.planning.costs import unknown_manipulation_estimate

    collided, clean = KnownCosts(), KnownCosts()
    collided.add_navigation(NAV, S0, straight(length=4.0), 40.0)  # 10 per metre: it hit something
    clean.add_navigation(NAV, S0, straight(length=4.0), 12.0)  # 3 per metre: what its length says
    same, new = straight(length=4.0), straight(length=4.0, y=5.0)  # P° = 200 and 0
    assert estimate_navigation(same, collided, 1.0, "prior")[0] == pytest.approx(4.0 * (3 + 10) / 2)  # 26
    assert estimate_navigation(same, clean, 1.0, "prior")[0] == pytest.approx(12.0)
    assert estimate_navigation(new, collided, 1.0, "prior")[0] == pytest.approx(12.0)  # its own length
    assert estimate_navigation(new, collided, 1.0, "paper_sum")[0] == 0.0  # the paper's form: new is free
    k = KnownCosts()
    assert unknown_manipulation_estimate("pickup", k) == 10.0  # nothing known: the middle class
    k.add_manipulation(PICK, S0, 80.0)
    k.add_manipulation(Action("place", "desk_1", obj="mug_1"), S0, 4.0)
    assert unknown_manipulation_estimate("pickup", k) == 80.0 and unknown_manipulation_estimate("place", k) == 4.0
