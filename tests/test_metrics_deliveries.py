"""Deliveries first: the counting of replacements, delivered and cost per delivered beside
m_overall, the position between the two anchors (nothing, optimal), the delivery check of the
claims, the γ_obj sensitivity and its break-even, candidate diversity, deliverable slots and the
encoding pairs of a multirun; worked out by hand on hand-built records and tables."""

from __future__ import annotations

import json
import math
import re

import pytest
from test_metrics_compute import man, nav, summary

from interllm.config import from_dict
from interllm.core.actions import Action
from interllm.core.records import CommandRecord, GoalRecord, MissionRecord
from interllm.io import write_json
from interllm.metrics import claims, deliveries, planner_info
from interllm.metrics.compute import Gammas, mission_rows
from interllm.planners.base import shown_planners
from interllm.stages.aggregate import write_metrics

G = Gammas(10.0, 100.0, 100.0)
SCENE = {"category": {"apple_1": "apple", "apple_2": "apple", "bread_1": "bread", "mug_1": "mug"},
         "furniture": {"apple_1": "counter_1", "apple_2": "counter_2", "bread_1": "counter_1", "mug_1": "shelf_1"}}


PLANNERS_RUN = ["inter_llm", "sayplan", "nothing", "optimal"]


@pytest.fixture
def anchors():
    """The planner table the runs of these tests would record: ``nothing`` and ``optimal`` anchors."""
    with planner_info.shown(planner_info.PlannerTable.from_json(shown_planners(PLANNERS_RUN), "test")) as t:
        yield t


def _breakfast(actions, final, n=2) -> CommandRecord:
    return CommandRecord("breakfast", "Breakfast on the dining table.",
                         GoalRecord(("apple", "bread"), ("dining_table",), n), summary("breakfast", 0, 0, 0, []),
                         actions, final)


def _deliver(obj, src="counter_1", t=2.0):
    return [nav(src, "kitchen", 0, 1.0, t), man("pickup", obj, src, 1.0, t),
            nav("dining_table", "dining", 0, 1.0, t), man("place", obj, "dining_table", 1.0, t)]


# ---- 1. counting ------------------------------------------------------------------------------
def test_a_replacement_after_a_failure_is_counted():
    """n = 2: apple_1's pickup fails, bread_1 is delivered, then apple_2 replaces apple_1. apple_2 is
    folded into slot 2 (its costs stay there) and fills slot 1's sr_obj: 2 delivered, not 1."""
    failed = [nav("counter_1", "kitchen", 1, 2.0, 5.0), man("pickup", "apple_1", "counter_1", 0.0, 4.0, ok=False)]
    acts = failed + _deliver("bread_1") + _deliver("apple_2", "counter_2")
    c = _breakfast(acts, {"apple_1": "counter_1", "bread_1": "dining_table", "apple_2": "dining_table"})
    objs, cmds, mission = mission_rows(MissionRecord("moma_llm", "s0", "m0", [c]), SCENE, G)
    assert [r["object"] for r in objs] == ["apple_1", "bread_1+apple_2"]
    assert [r["sr_obj"] for r in objs] == [1.0, 1.0]
    assert cmds[0]["n_fulfilled"] == 2 and mission["n_fulfilled"] == 2
    # the costs stay where they were: slot 1 has apple_1's navigation and failed pickup only
    a, b = objs
    assert (a["cc"], a["d"], a["t_exe"], a["sr_man"]) == (1, 2.0, 9.0, 0.0)
    assert a["m_overall"] == pytest.approx(10 + 9 + 2 + 100 + 0)  # γ_obj·(1 − sr_obj) = 0 now
    assert (b["t_exe"], b["d"], b["sr_man"]) == (16.0, 4.0, 1.0)


@pytest.mark.parametrize("n, delivered, expect", [
    (2, ["bread_1"], [0.0, 1.0]),  # only the second object: slot 2, nothing spare
    (2, ["bread_1", "apple_2"], [1.0, 1.0]),  # a spare fills slot 1
    (1, ["bread_1", "apple_2"], [1.0]),  # n = 1: at most one counted
    (3, ["bread_1", "apple_2"], [0.0, 1.0, 1.0]),  # 3 slots: no folding, the failed slot stays unfulfilled
])
def test_a_command_counts_min_n_and_the_distinct_delivered(n, delivered, expect):
    failed = [man("pickup", "apple_1", "counter_1", 0.0, 4.0, ok=False)]
    acts = failed + [a for o in delivered for a in _deliver(o, SCENE["furniture"][o])]
    c = _breakfast(acts, {o: "dining_table" for o in delivered}, n)
    objs, _, _ = mission_rows(MissionRecord("moma_llm", "s0", "m0", [c]), SCENE, G)
    assert [r["sr_obj"] for r in objs] == expect
    assert sum(r["sr_obj"] for r in objs) == min(n, len(delivered))


# ---- 2. deliveries, comparisons, position -----------------------------------------------------
def _pm(planner, ms, fulfilled=None, cc=0.0, t=0.0, d=0.0):
    return [{"planner": planner, "scene": "s", "mission": f"m{i}", "m_overall": float(m),
             "n_fulfilled": (fulfilled[i] if fulfilled else 0), "cc": cc, "t_exe": t, "d": d}
            for i, m in enumerate(ms)]


def test_position_is_0_for_nothing_1_for_optimal_and_between_for_a_planner(anchors):
    nothing = _pm("nothing", [1800.0] * 6)
    optimal = _pm("optimal", [600.0, 620.0, 580.0, 610.0, 590.0, 600.0])
    mid = _pm("inter_llm", [1200.0, 1250.0, 1150.0, 1180.0, 1220.0, 1200.0])  # Σ 7200; Σ null 10800, Σ opt 3600
    worse = _pm("sayplan", [1900.0] * 6)
    pos = deliveries.positions(nothing + optimal + mid + worse, n_boot=300)
    assert pos["nothing"]["position"] == 0.0 and (pos["nothing"]["position_ci_lo"], pos["nothing"]["position_ci_hi"]) == (0, 0)
    assert pos["optimal"]["position"] == pytest.approx(1.0)
    assert pos["optimal"]["position_ci_lo"] == pytest.approx(1.0) and pos["optimal"]["position_ci_hi"] == pytest.approx(1.0)
    assert pos["inter_llm"]["position"] == pytest.approx((10800 - 7200) / (10800 - 3600))  # 0.5
    assert pos["inter_llm"]["position_ci_lo"] < 0.5 < pos["inter_llm"]["position_ci_hi"]
    assert pos["sayplan"]["position"] == pytest.approx(-100 / 1200)  # worse than doing nothing
    # m − m_null per mission, and whether it is significantly below
    assert pos["inter_llm"]["m_minus_nothing"] == pytest.approx(-600.0) and pos["inter_llm"]["below_nothing"] is True
    assert pos["sayplan"]["below_nothing"] is False
    assert "m_minus_nothing" not in pos["nothing"]
    # without the optimal reference: no position, still the comparison with doing nothing
    pos = deliveries.positions(nothing + mid, n_boot=300)
    assert "position" not in pos["inter_llm"] and pos["inter_llm"]["below_nothing"] is True
    assert deliveries.anchors_info(["inter_llm", "nothing"])["missing"] == ["optimal"]


def test_delivered_and_cost_per_delivered_and_their_paired_differences():
    rows = _pm("inter_llm", [500.0] * 6, [3, 3, 2, 3, 3, 4], cc=1.0, t=50.0, d=20.0)
    rows += _pm("sayplan", [700.0] * 6, [5, 5, 4, 5, 6, 5], cc=0.0, t=100.0, d=50.0)
    dl = deliveries.planner_deliveries(rows, 10.0, n_boot=300)
    assert dl["inter_llm"]["delivered"] == 18 and dl["inter_llm"]["delivered_per_mission"] == pytest.approx(3.0)
    assert dl["inter_llm"]["exec_cost_per_delivered"] == pytest.approx(6 * (10 + 50 + 20) / 18)
    c = deliveries.paired_comparisons(rows, "inter_llm", n_boot=300)["inter_llm_vs_sayplan"]
    assert c["m_overall_diff"] == pytest.approx(-200.0) and c["delivered_diff"] == pytest.approx(-2.0)
    assert c["delivered_diff_ci_hi"] < 0 and c["n_pairs"] == 6 and c["baseline_anchor"] is False


# ---- 4. claims -----------------------------------------------------------------------------------
def _metrics(imp_lo, imp_hi, dl_lo, dl_hi):
    return {"planners": {"inter_llm": {}, "sayplan": {}, "optimal": {"anchor": True}},
            "improvement": {"inter_llm_vs_sayplan": {"pct": (imp_lo + imp_hi) / 2, "ci_lo": imp_lo, "ci_hi": imp_hi}},
            "comparisons": {"inter_llm_vs_sayplan": {"baseline": "sayplan", "delivered_diff": (dl_lo + dl_hi) / 2,
                                                     "delivered_diff_ci_lo": dl_lo, "delivered_diff_ci_hi": dl_hi},
                            "inter_llm_vs_optimal": {"baseline": "optimal", "baseline_anchor": True,
                                                     "delivered_diff": -5.0, "delivered_diff_ci_lo": -6.0,
                                                     "delivered_diff_ci_hi": -4.0}}}


@pytest.mark.parametrize("dl_lo, dl_hi, verdict", [(-1.0, 1.0, "holds"), (0.5, 2.0, "holds"),
                                                   (-3.0, -1.0, claims.FEWER)])
def test_the_delivery_check_flips_a_lower_m_overall_bought_by_delivering_less(dl_lo, dl_hi, verdict):
    m = _metrics(20.0, 40.0, dl_lo, dl_hi)
    assert claims.ordering(m)["verdict"] == verdict
    assert claims.improvement_30(m)["sayplan"]["verdict"] == verdict
    assert "does not hold: lower m_overall by delivering fewer objects" in claims.FEWER


def test_anchors_are_not_claimants():
    m = _metrics(20.0, 40.0, -1.0, 1.0)
    m["improvement"]["inter_llm_vs_optimal"] = {"pct": -50.0, "ci_lo": -60.0, "ci_hi": -40.0}  # worse than optimal
    o = claims.ordering(m)
    assert o["verdict"] == "holds" and set(o["improvements"]) == {"sayplan"}
    assert set(claims.improvement_30(m)) == {"sayplan"}
    rows = [{"planner": p, "scene": "s", "mission": f"m{i}", "m_overall": 100.0 + i * (p == "optimal")}
            for p in ("inter_llm", "sayplan", "optimal") for i in range(6)]
    assert set(claims.houses_needed(rows, "inter_llm", exclude={"optimal"})) == {"sayplan"}


# ---- 5. γ_obj ----------------------------------------------------------------------------------
def _slots(planner, mission, n_undelivered, exec_each, n=3):
    """n slots whose execution part E is ``exec_each`` each (t_exe only, sr_man = 1)."""
    return [{"planner": planner, "scene": "s", "mission": mission, "cc": 0.0, "d": 0.0, "t_exe": exec_each,
             "sr_man": 1.0, "sr_obj": 0.0 if k < n_undelivered else 1.0} for k in range(n)]


@pytest.mark.parametrize("exec_diff, und_diff, expect", [(200.0, -2.0, 100.0), (-100.0, -1.0, None), (50.0, 0.0, None),
                                                         (-30.0, 3.0, 10.0), (0.0, -1.0, 0.0)])
def test_break_even_table(exec_diff, und_diff, expect):
    assert deliveries.break_even(exec_diff, und_diff) == (expect if expect is None else pytest.approx(expect))


def test_break_even_gamma_obj_on_a_constructed_example():
    """Inter-LLM: E = 3·200 = 600 s, 1 undelivered slot; SayPlan: E = 3·(400/3) = 400 s, 3 undelivered.
    Δ(γ) = 200 + γ·(1 − 3) crosses 0 at γ_obj = 100: above it Inter-LLM is cheaper."""
    rows = []
    for i in range(6):
        rows += _slots("inter_llm", f"m{i}", 1, 200.0 + (i % 2)) + _slots("sayplan", f"m{i}", 3, 400.0 / 3 + (i % 2))
    s = deliveries.gamma_obj_sensitivity(rows, gamma_nav=10.0, gamma_man=100.0, gammas=[50.0, 100.0, 500.0],
                                          judge="inter_llm", n_boot=300)
    c = s["comparisons"]["inter_llm_vs_sayplan"]
    assert c["exec_diff"] == pytest.approx(200.0) and c["undelivered_diff"] == pytest.approx(-2.0)
    assert c["break_even"] == pytest.approx(100.0) and c["judged_lower_above"] is True
    assert c["by_gamma"]["100"]["diff"] == pytest.approx(0.0, abs=1e-9)
    assert c["by_gamma"]["50"]["diff"] == pytest.approx(100.0) and c["by_gamma"]["500"]["diff"] == pytest.approx(-800.0)
    assert s["planners"]["inter_llm"]["m_overall"]["500"] == pytest.approx(3 * 200.5 + 500.0)
    from interllm.report.costs import break_even_text
    assert break_even_text(c, "inter_llm").startswith("100.0: ")


# ---- 6. candidate diversity --------------------------------------------------------------------
def _plan(*objs):
    return tuple(a for o in objs for a in (Action("pickup", "counter_1", obj=o), Action("place", "dining_table", obj=o)))


def test_candidate_diversity_share():
    cmds = []
    for cands in ([_plan("apple_1", "bread_1"), _plan("apple_2", "bread_1")],  # different objects
                  [_plan("apple_1", "bread_1"), _plan("bread_1", "apple_1")],  # same set, other order
                  [_plan("apple_1")],  # one candidate: cannot differ
                  []):  # no candidates: not counted
        c = _breakfast([], {})
        c.summary.candidates = cands
        cmds.append(c)
    div = deliveries.candidate_diversity([MissionRecord("inter_llm", "s0", "m0", cmds),
                                          MissionRecord("nothing", "s0", "m0", [_breakfast([], {})])])
    assert set(div) == {"inter_llm"}  # a planner without candidates has no row
    d = div["inter_llm"]
    assert (d["n_commands"], d["n_diverse"]) == (3, 1) and d["share"] == pytest.approx(1 / 3)
    assert d["candidates_per_command"] == pytest.approx(5 / 3)


# ---- the aggregate stage and the report with the anchors ----------------------------------------
def _scene_file(root):
    write_json(root / "scenes" / "s0" / "scene.json",
               {"id": "s0", "objects": [{"id": o, "category": c, "furniture": SCENE["furniture"][o]}
                                        for o, c in SCENE["category"].items()]})


def _mission(planner, i, objs):
    t = (60.0 if planner == "sayplan" else 2.0) + 0.1 * i  # SayPlan delivers more, slowly [s per action]
    acts = [a for o in objs for a in _deliver(o, SCENE["furniture"][o], t)]
    c = _breakfast(acts, {o: "dining_table" for o in objs})
    if planner == "inter_llm":
        c.summary.candidates = [_plan("apple_1", "bread_1"), _plan("apple_2")]
    return MissionRecord(planner, "s0", f"m{i:03d}", [c], sim_time=1.0)


@pytest.fixture
def runs(tmp_path):
    _scene_file(tmp_path)
    write_json(tmp_path / "runs" / "planners.json", shown_planners(PLANNERS_RUN))  # as the missions stage does
    plans = {"nothing": [], "optimal": ["apple_1", "bread_1"], "inter_llm": ["apple_1"], "sayplan": ["apple_1", "bread_1"]}
    for p, objs in plans.items():
        for i in range(6):
            write_json(tmp_path / "runs" / p / "s0" / f"m{i:03d}.json", _mission(p, i, objs).to_dict())
    return tmp_path


def test_aggregate_writes_deliveries_position_and_the_anchors(runs):
    cfg = from_dict({"metrics": {"bootstrap_samples": 200, "gamma_obj_sensitivity": [100.0, 300.0]}})
    out = write_metrics(runs / "runs", runs / "scenes", cfg, runs / "metrics")
    pl = out["planners"]
    assert pl["nothing"]["position"] == 0.0 and pl["optimal"]["position"] == 1.0
    assert pl["nothing"]["anchor"] is True and pl["inter_llm"]["anchor"] is False
    assert pl["optimal"]["label"] == "Optimal (anchor)" and pl["inter_llm"]["order"] == 2
    assert pl["nothing"]["delivered"] == 0 and pl["nothing"]["m_overall"] == pytest.approx(400.0)
    assert pl["inter_llm"]["delivered"] == 6 and pl["sayplan"]["delivered"] == 12
    assert pl["inter_llm"]["below_nothing"] is True
    assert pl["nothing"]["exec_cost_per_delivered"] is None  # nothing delivered: no cost per object
    assert set(out["improvement"]) == {"inter_llm_vs_sayplan"}  # anchors are not baselines
    assert out["comparisons"]["inter_llm_vs_sayplan"]["delivered_diff"] == -1.0
    assert out["comparisons"]["inter_llm_vs_optimal"]["baseline_anchor"] is True
    assert out["anchors"] == {"flagged": ["nothing", "optimal"], "missing": []}
    assert out["gamma_obj_sensitivity"]["gammas"] == [100.0, 300.0]
    assert out["candidate_diversity"]["inter_llm"]["share"] == 1.0
    # Inter-LLM is cheaper per mission than SayPlan by leaving bread_1: the claim does not hold
    o = claims.ordering(out)
    assert out["improvement"]["inter_llm_vs_sayplan"]["ci_lo"] > 0 and o["verdict"] == claims.FEWER
    first = (runs / "metrics" / "metrics.json").read_bytes()
    write_metrics(runs / "runs", runs / "scenes", cfg, runs / "metrics")
    assert (runs / "metrics" / "metrics.json").read_bytes() == first


def test_the_report_leads_with_deliveries_and_positions(runs):
    from interllm.report.build import build_report

    cfg = from_dict({"metrics": {"bootstrap_samples": 200}})
    write_metrics(runs / "runs", runs / "scenes", cfg, runs / "metrics")
    write_json(runs / "scenes" / "s0" / "feasibility.json", {"totals": {"slots_asked": 12, "slots_fulfillable": 9}})
    md = build_report(runs / "metrics", runs / "scenes", runs / "runs", runs / "report", cfg)["markdown"].read_text()
    head = md.split("## ")[1]
    assert head.startswith("Headline: objects delivered, m_overall and position")
    assert md.index("## Headline") < md.index("## The paper's claims") < md.index("## Summary per planner")
    assert "| planner | missions | delivered | delivered / mission [CI] | m_overall / mission [CI] | position [CI] |" in md
    assert "0 (anchor)" in head and "1 (anchor)" in head and "| Optimal (anchor) |" in head
    assert "9 of 12 slots asked (75%) can be fulfilled at all" in head
    optimal = re.search(r"The optimal reference delivered (\d+) of the 9 fulfillable slots \((.*?)\)\.", head)
    assert optimal, head
    assert (optimal[2] == "every one") == (optimal[1] == "9"), optimal[0]
    claims_part = md.split("## The paper's claims")[1].split("## ")[0]
    assert claims.FEWER in claims_part
    assert "## Sensitivity to γ_obj" in md and "## Candidate diversity" in md
    # without the anchors' runs, no position column: the report says why
    for p in ("nothing", "optimal"):
        for f in (runs / "runs" / p / "s0").iterdir():
            f.unlink()
    (runs / "scenes" / "s0" / "feasibility.json").write_text("{not json")
    write_metrics(runs / "runs", runs / "scenes", cfg, runs / "metrics")
    md = build_report(runs / "metrics", runs / "scenes", runs / "runs", runs / "report", cfg)["markdown"].read_text()
    head = md.split("## ")[1]
    assert "position [CI]" not in head and "No runs of the `nothing` and `optimal` anchors" in head
    assert "feasibility.json could not be read" in head


def test_missing_feasibility_is_said(tmp_path):
    from interllm.report.headline import feasibility_sentence

    s = feasibility_sentence(tmp_path, ["s0"], {})
    assert "No feasibility.json" in s and "s0" in s


# ---- 8. encodings of a multirun -------------------------------------------------------------------
def test_encoding_runs_are_found_paired_and_reported(runs):
    from interllm.report.build import build_report
    from interllm.stages.report import find_encoding_results, find_oracle_results

    cfg = from_dict({"metrics": {"bootstrap_samples": 200}})
    write_metrics(runs / "runs", runs / "scenes", cfg, runs / "metrics")
    sweep = runs / "multirun"
    for n, (oc, ce, err) in enumerate((("classes", "paper", 0.0), ("numeric", "paper", 0.0), ("classes", "expected", 0.0),
                                       ("classes", "paper", 0.5), ("numeric", "paper", 0.5), ("classes", "paper", 0.9))):
        job = sweep / str(n)
        (job / ".hydra").mkdir(parents=True)
        (job / ".hydra" / "config.yaml").write_text(json.dumps(
            {"experiment": "oracle_sweep", "llm": {"oracle_error": err, "oracle_costs": oc, "cache_dir": f"/c{n}"},
             # jobs 0-2 as composed before each planner had its own node (a flat planner.cost_encoding)
             "planner": {"cost_encoding": ce} if n < 3 else {"inter_llm": {"cost_encoding": ce}}}))
        write_metrics(runs / "runs", runs / "scenes", cfg, job / "data" / "metrics")
    found = find_encoding_results(sweep)
    assert [(g, v) for g, v, _ in found] == [
        ("llm.oracle_error=0.0", "oracle_costs=classes, cost_encoding=expected"),
        ("llm.oracle_error=0.0", "oracle_costs=classes, cost_encoding=paper"),
        ("llm.oracle_error=0.0", "oracle_costs=numeric, cost_encoding=paper"),
        ("llm.oracle_error=0.5", "oracle_costs=classes, cost_encoding=paper"),
        ("llm.oracle_error=0.5", "oracle_costs=numeric, cost_encoding=paper")]  # 0.9 has one variant: no pair
    assert [e for e, _ in find_oracle_results(sweep)] == [0.0, 0.5, 0.9]  # the paper's encoding only
    md = build_report(runs / "metrics", runs / "scenes", runs / "runs", runs / "report", cfg,
                      encoding_results=found)["markdown"].read_text()
    sec = md.split("## Cost encoding")[1]
    row = next(line for line in sec.splitlines() if "oracle_error=0.5 | oracle_costs=numeric" in line)
    assert row.endswith("| 6 | 0.00 [0.00, 0.00] | 0.0 [0.0, 0.0] | 0.00 [0.00, 0.00] |")  # the same runs
    assert "oracle_costs=classes, cost_encoding=paper (base)" in sec


def test_paired_runs_differences():
    base = _pm("inter_llm", [1000.0] * 6, [2] * 6) + _pm("nothing", [1800.0] * 6) + _pm("optimal", [600.0] * 6)
    var = _pm("inter_llm", [900.0] * 6, [3] * 6) + _pm("nothing", [1800.0] * 6) + _pm("optimal", [600.0] * 6)
    c = deliveries.paired_runs(var, base, "inter_llm", n_boot=200)
    assert c["n_pairs"] == 6 and c["m_overall_diff"] == pytest.approx(-100.0) and c["delivered_diff"] == 1.0
    assert c["position_diff"] == pytest.approx(100 / 1200)
    assert math.isnan(deliveries.paired_runs(var[:6], base[:6], "inter_llm", n_boot=200)["position_diff"])


def test_the_conclusions_of_a_metrics_diff_include_deliveries():
    from interllm.metrics.compare import conclusions

    m = _metrics(20.0, 40.0, -3.0, -1.0)
    m["planners"]["inter_llm"]["below_nothing"] = True
    c = conclusions(m)
    assert c["delivered inter_llm_vs_sayplan"] == "fewer, CI excludes 0"
    assert c["inter_llm below doing nothing"] == "yes, CI below 0"


def test_sweep_jobs_are_found_by_what_their_experiment_declares(tmp_path):
    """The report finds a multirun's jobs by the ``sweep`` their experiment declares, not by the
    experiment's name: a new experiment file with ``sweep: oracle`` joins the oracle axis."""
    from interllm.stages.report import find_oracle_results, find_sweep_results

    def job(n: int, config: dict) -> None:
        (tmp_path / str(n) / ".hydra").mkdir(parents=True)
        (tmp_path / str(n) / ".hydra" / "config.yaml").write_text(json.dumps(config))
        write_json(tmp_path / str(n) / "data" / "metrics" / "metrics.json", {})

    job(0, {"experiment": "my_axis", "sweep": "oracle", "llm": {"oracle_error": 0.3}})
    job(1, {"experiment": "oracle_sweep", "llm": {"oracle_error": 0.1}})  # composed before sweeps were declared
    job(2, {"experiment": "my_other_run", "sweep": "", "llm": {"oracle_error": 0.2}})  # declares none
    job(3, {"experiment": "low_t", "sweep": "temperature", "llm": {"temperature": 0.2}})
    assert [e for e, _ in find_oracle_results(tmp_path)] == [0.1, 0.3]
    assert [lab for lab, _ in find_sweep_results(tmp_path)[0]] == ["0.2"]


def test_a_hostile_planner_table_is_escaped_or_refused(runs):
    """planners.json is input the report trusts as little as any: a label is text (escaped in the
    HTML), a colour matplotlib does not know stops the report with the file and the fix."""
    from interllm.errors import UserError
    from interllm.report.build import build_report

    table = shown_planners(PLANNERS_RUN)
    table["sayplan"]["label"] = "<script>alert(1)</script>"
    write_json(runs / "runs" / "planners.json", table)
    cfg = from_dict({"metrics": {"bootstrap_samples": 200}})
    write_metrics(runs / "runs", runs / "scenes", cfg, runs / "metrics")
    out = build_report(runs / "metrics", runs / "scenes", runs / "runs", runs / "report", cfg)
    html = out["html"].read_text()
    assert "<script>alert(1)</script>" not in html and "&lt;script&gt;alert(1)&lt;/script&gt;" in html
    table["sayplan"]["color"] = "url(javascript:alert(1))"
    write_json(runs / "runs" / "planners.json", table)
    write_metrics(runs / "runs", runs / "scenes", cfg, runs / "metrics")
    with pytest.raises(UserError, match=r"planner 'sayplan': colour .* is not a matplotlib colour; rerun the missions"):
        build_report(runs / "metrics", runs / "scenes", runs / "runs", runs / "report", cfg)
