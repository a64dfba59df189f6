"""Inter-LLM with one part of its mechanism removed (interllm/planners/inter_llm_ablations.py), on a
two-command mission: what each variant still knows when it estimates, and how the metrics pair
each variant against full Inter-LLM (interllm/metrics/mechanism.py)."""

from __future__ import annotations

import pytest
from helpers.planners import FakeScoreClient, ListRecorder, SymbolicWorld, two_apples

from interllm.config import ExperimentConfig
from interllm.core.actions import Action, State
from interllm.metrics import claims, mechanism
from interllm.planners.base import shown_planners
from interllm.planners.candidates import generate_initial_candidates
from interllm.planners.runner import run_mission
from interllm.planning.memory import KnownCosts
from interllm.report import mechanism as mechanism_report

VARIANTS = ("inter_llm_no_learning", "inter_llm_no_cost_choice", "inter_llm_no_carry_over")


def _run(name: str) -> tuple[dict, ListRecorder]:
    cfg = ExperimentConfig()
    cfg.llm.temperature = 0.0
    scene, m = two_apples()
    client = FakeScoreClient()
    cands = generate_initial_candidates(scene, m, client, cfg)
    rec = ListRecorder()
    return run_mission(name, SymbolicWorld(scene, cfg.sim), m, cands, client, cfg, recorder=rec).to_dict(), rec


def _nav_sources(log: ListRecorder, command: str) -> set[str]:
    """Where the navigation estimates of ``command``'s candidates came from."""
    return {n["source"] for e in log.events if e[0] == "/planner/estimates" and e[2]["command"] == command
            for est in e[2]["estimates"] for n in est["nav"]}


def test_only_full_inter_llm_carries_the_first_commands_paths_to_the_second():
    # full Inter-LLM compares the second command's presumed paths with the first command's driven ones
    full = _run("inter_llm")[1]
    assert _nav_sources(full, "breakfast") == {"fallback_presumed"} and "similarity" in _nav_sources(full, "snack")
    # without learning nothing is known at the second command; without carry-over only identical
    # (action, state) pairs are, and the second command's are new
    for name in ("inter_llm_no_learning", "inter_llm_no_carry_over"):
        assert _nav_sources(_run(name)[1], "snack") == {"fallback_presumed"}, name


def test_no_cost_choice_executes_the_first_feasible_candidate_unestimated():
    rec, log = _run("inter_llm_no_cost_choice")
    assert not [e for e in log.events if e[0] == "/planner/estimates"]
    chosen = [e[2] for e in log.events if e[0] == "/planner/selected"]
    assert [c["index"] for c in chosen] == [0, 0] and all(c["estimate"] is None for c in chosen)
    assert all(c["summary"]["cost_inferences"] == [] for c in rec["commands"])
    assert rec["commands"][0]["summary"]["selected_plan"] == rec["commands"][0]["summary"]["candidates"][0]


def test_the_variants_run_the_same_first_candidates_and_deliver():
    full = _run("inter_llm")[0]
    for name in VARIANTS:
        rec = _run(name)[0]
        assert rec["commands"][0]["summary"]["candidates"] == full["commands"][0]["summary"]["candidates"], name
        assert rec["commands"][0]["final_locations"], name


def test_known_costs_only_keeps_the_identical_action_and_state():
    known = KnownCosts()
    here, there = State("sofa_1", None), State("desk_1", None)
    pick = Action("pickup", obj="apple_1", furniture="sofa_1")
    known.add_manipulation(pick, here, 7.0)
    known.add_navigation(Action("navigate", furniture="desk_1", room="room_a"), here, [[0, 0], [1, 0]], 3.0)
    assert [r.cost for r in known.only(pick, here).maned] == [7.0] and not known.only(pick, here).naved
    assert len(known.only(pick, there)) == 0
    assert len(known.only(Action("pickup", obj="apple_2", furniture="sofa_1"), here)) == 0


def test_the_variants_are_registered_as_ablations_of_inter_llm():
    shown = shown_planners(("inter_llm",) + VARIANTS)
    assert "ablates" not in shown["inter_llm"]
    assert {shown[v]["ablates"] for v in VARIANTS} == {"inter_llm"}
    assert len({shown[v]["label"] for v in VARIANTS} | {shown["inter_llm"]["label"]}) == 4


# ---- the mechanism table ------------------------------------------------------------------------
def _rows(planner: str, delivered: list[int], cost: float, houses: int = 4, missions: int = 3) -> tuple[list, list]:
    """per_mission and per_command rows: in every mission, command k delivers delivered[k] objects at
    ``cost`` s of driving each; m_overall charges 200 per undelivered slot of 3."""
    pm, pc = [], []
    for h in range(houses):
        for m in range(missions):
            rows = [{"planner": planner, "scene": f"h{h}", "mission": f"m{m}", "command_index": k + 1,
                     "n_fulfilled": d, "cc": 0, "t_exe": cost * d, "d": 0.0,
                     "m_overall": cost * d + 200.0 * (3 - d)} for k, d in enumerate(delivered)]
            pc += rows
            pm.append({"planner": planner, "scene": f"h{h}", "mission": f"m{m}",
                       **{k: sum(r[k] for r in rows) for k in ("n_fulfilled", "cc", "t_exe", "d", "m_overall")}})
    return pm, pc


def test_the_mechanism_table_pairs_each_variant_with_the_full_planner_by_hand():
    full_m, full_c = _rows("inter_llm", [2, 3, 3], 50.0)  # learns: the later commands deliver more
    var_m, var_c = _rows("inter_llm_no_learning", [2, 2, 2], 60.0)
    planners = {"inter_llm": {}, "inter_llm_no_learning": {"ablates": "inter_llm"}, "nothing": {"anchor": True}}
    t = mechanism.mechanism_table(full_m + var_m, full_c + var_c, planners, gamma_nav=10.0, n_boot=300)
    d = t["inter_llm_no_learning"]
    assert (d["ablates"], d["n_pairs"]) == ("inter_llm", 12)
    assert (d["n_fulfilled_diff"], d["n_fulfilled_diff_ci_lo"], d["n_fulfilled_diff_ci_hi"]) == (2.0, 2.0, 2.0)
    # m: full 8·50 + 1·200 = 600; variant 6·60 + 3·200 = 960
    assert d["m_overall_diff"] == pytest.approx(-360.0)
    assert (d["cost_per_delivered_full"], d["cost_per_delivered_variant"]) == pytest.approx((50.0, 60.0))
    curve = d["by_command"]
    assert [r["command_index"] for r in curve] == [1, 2, 3]
    assert [r["n_fulfilled_diff"] for r in curve] == [0.0, 1.0, 1.0]  # the same first command, then learning
    assert mechanism_report._verdict(d) == "helps"
    assert mechanism.mechanism_table(full_m, full_c, {"inter_llm": {}}, 10.0) == {}


def test_ablation_variants_are_neither_claimants_nor_baselines_of_the_papers_claims():
    m = {"planners": {"inter_llm": {}, "sayplan": {}, "inter_llm_no_learning": {"ablates": "inter_llm"},
                      "nothing": {"anchor": True}},
         "improvement": {"inter_llm_vs_sayplan": {"pct": 10.0, "ci_lo": 5.0, "ci_hi": 15.0},
                         "inter_llm_vs_inter_llm_no_learning": {"pct": -10.0, "ci_lo": -15.0, "ci_hi": -5.0}}}
    assert claims.set_aside(m) == {"nothing", "inter_llm_no_learning"}
    o = claims.ordering(m)
    assert set(o["improvements"]) == {"sayplan"} and o["verdict"] == "holds"


def test_a_variant_that_delivers_less_is_reported_as_a_part_that_helps():
    d = {"n_fulfilled_diff_ci_lo": 0.2, "n_fulfilled_diff_ci_hi": 1.0, "m_overall_diff_ci_lo": 10.0,
         "m_overall_diff_ci_hi": 50.0}
    assert mechanism_report._verdict(d) == "helps"  # deliveries first
    assert mechanism_report._verdict({**d, "n_fulfilled_diff_ci_lo": -0.5}) == "hurts"
    assert mechanism_report._verdict({**d, "n_fulfilled_diff_ci_lo": -0.5, "m_overall_diff_ci_lo": -1.0}) == \
        "cannot tell"
    assert mechanism_report._verdict({}) == "cannot tell"  # no interval: nothing is claimed
