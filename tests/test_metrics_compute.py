"""Per-object metrics of a hand-written MissionRecord, worked by hand (see the numbers below)."""

from __future__ import annotations

import copy
import csv

import pytest

from interllm.config import ExperimentConfig
from interllm.core.actions import Action
from interllm.core.records import (
    CommandRecord,
    CommandSummary,
    CostInference,
    GoalRecord,
    MissionRecord,
    RecordError,
)
from interllm.core.results import ActionResult, man_cost, nav_cost
from interllm.metrics.compute import (
    Gammas,
    MetricsInputError,
    assign_slots,
    m_overall,
    mission_rows,
    read_csv,
)
from interllm.metrics.planner_info import PlannerTableError
from interllm.planners.base import shown_planners
from interllm.stages.aggregate import write_metrics

SCENE = {"category": {"apple_1": "apple", "bread_1": "bread", "laptop_1": "laptop", "mug_1": "mug",
                      "book_1": "book"},
         "furniture": {"apple_1": "counter_1", "bread_1": "counter_1", "laptop_1": "desk_1", "mug_1": "shelf_1",
                       "book_1": "shelf_2"}}


def nav(furn, room, cc, d, t):
    return ActionResult(Action("navigate", furn, room=room), True, nav_cost(cc, t, d, 10.0), t, collisions=cc,
                        distance=d)


def man(kind, obj, furn, sr, t, ok=True):
    return ActionResult(Action(kind, furn, obj=obj), ok, man_cost(sr, t, 100.0), t, success_rate=sr)


def summary(cid, calls, tin, tout, inferences):
    return CommandSummary(cid, llm_calls=calls, llm_tokens_in=tin, llm_tokens_out=tout,
                          cost_inferences=[CostInference(*i) for i in inferences])


def record() -> MissionRecord:
    c1 = CommandRecord(
        "breakfast", "Set up breakfast on the dining table.", GoalRecord(("apple", "bread"), ("dining_table",), 2),
        # (action, predicted, estimate, measured truth, its c_man, its sr_man); book_1 could not be tried
        summary("breakfast", 4, 1000, 200, [("pickup(apple_1, counter_1)", "hard", 20.0, "hard", 54.0, 0.5),
                                            ("place(laptop_1, bed_desk)", "easy", 5.0, "easy", 3.0, 1.0),
                                            ("pickup(book_1, shelf_2)", "easy", 5.0),
                                            ("pickup(mug_1, shelf_1)", "unknown", 0.0, "hard", 110.0, 0.0)]),
        [nav("counter_1", "kitchen", 1, 5.0, 12.0),
         man("pickup", "apple_1", "counter_1", 0.5, 4.0),
         nav("dining_table", "dining", 0, 3.0, 6.0),
         man("place", "apple_1", "dining_table", 1.0, 2.0),
         nav("shelf_1", "living", 0, 4.0, 8.0),
         man("pickup", "mug_1", "shelf_1", 0.0, 10.0, ok=False)],  # failed pickup
        {"apple_1": "dining_table", "mug_1": "shelf_1"})
    c2 = CommandRecord(
        "meeting", "Set up my online meeting in the bedroom.", GoalRecord(("laptop",), ("bed_desk",), 2),
        summary("meeting", 2, 500, 50, [("pickup(apple_1, counter_1)", "easy", 5.0, "hard", 54.0, 0.5)]),
        [nav("desk_1", "office", 0, 2.0, 5.0),
         man("pickup", "laptop_1", "desk_1", 1.0, 3.0),
         nav("bed_desk", "bedroom", 2, 6.0, 20.0),  # two collisions
         man("place", "laptop_1", "bed_desk", 0.8, 4.0),
         nav("kitchen_table", "kitchen", 0, 1.0, 2.0)],  # trailing: previous object
        {"laptop_1": "bed_desk"})
    return MissionRecord("inter_llm", "s0", "m000", [c1, c2], sim_time=76.0)


def test_per_object_by_hand():
    objs, cmds, mission = mission_rows(record(), SCENE, Gammas(10.0, 100.0, 100.0))
    assert [r["object"] for r in objs] == ["apple_1", "mug_1", "laptop_1", ""]
    assert [r["object_index"] for r in objs] == [1, 2, 3, 4]
    a, mug, lap, empty = objs
    # apple: navs 1 and 3 (cc 1, d 5+3, t 12+6), pickup sr .5 t 4, place sr 1 t 2, fulfilled
    assert (a["cc"], a["d"], a["t_nav"], a["t_man"], a["t_exe"]) == (1, 8.0, 18.0, 6.0, 24.0)
    assert a["sr_man"] == pytest.approx(0.75) and a["sr_obj"] == 1.0
    assert a["m_overall"] == pytest.approx(10 * 1 + 24 + 8 + 100 * 0.25 + 0)  # 67
    # mug: nav 5 + failed pickup; wrong category -> unfulfilled
    assert (mug["cc"], mug["d"], mug["t_exe"], mug["sr_man"], mug["sr_obj"]) == (0, 4.0, 18.0, 0.0, 0.0)
    assert mug["m_overall"] == pytest.approx(18 + 4 + 100 + 100)  # 222
    # laptop: navs 1, 3 and the trailing nav 5 (cc 2, d 2+6+1, t 5+20+2), man t 3+4, sr (1+.8)/2
    assert (lap["cc"], lap["d"], lap["t_nav"], lap["t_man"]) == (2, 9.0, 27.0, 7.0)
    assert lap["sr_man"] == pytest.approx(0.9) and lap["sr_obj"] == 1.0
    assert lap["m_overall"] == pytest.approx(20 + 34 + 9 + 10)  # 73
    # unfilled slot: zero cost terms, sr_man = sr_obj = 0
    assert (empty["filled"], empty["cc"], empty["d"], empty["t_exe"], empty["sr_man"]) == (0, 0, 0, 0, 0)
    assert empty["m_overall"] == pytest.approx(200.0)
    assert [r["m_overall_cum"] for r in objs] == pytest.approx([67, 289, 362, 562])
    # per command / mission aggregates
    assert cmds[0]["m_overall"] == pytest.approx(289) and cmds[1]["m_overall"] == pytest.approx(273)
    assert cmds[0]["n_fulfilled"] == 1 and cmds[0]["sr_obj"] == 0.5 and cmds[0]["llm_calls"] == 4
    assert mission["m_overall"] == pytest.approx(562)
    assert (mission["cc"], mission["d"], mission["t_exe"]) == (3, 21.0, 76.0)
    assert mission["sr_man"] == pytest.approx((0.75 + 0 + 0.9 + 0) / 4)
    assert mission["sr_obj"] == 0.5 and mission["n_fulfilled"] == 2
    assert (mission["llm_calls"], mission["llm_tokens_in"], mission["llm_tokens_out"]) == (6, 1500, 250)


def test_gammas_enter_linearly():
    g = Gammas(nav=2.0, man=50.0, obj=30.0)
    objs, _, _ = mission_rows(record(), SCENE, g)
    assert objs[0]["m_overall"] == pytest.approx(2 * 1 + 24 + 8 + 50 * 0.25)
    assert objs[3]["m_overall"] == pytest.approx(50 + 30)
    assert m_overall(1, 24, 8, 0.75, 1, g) == pytest.approx(objs[0]["m_overall"])


def test_fulfilment_judged_from_locations_not_plan():
    rec = record()
    rec.commands[0].final_locations["apple_1"] = "held"  # never put down
    objs, _, _ = mission_rows(rec, SCENE, Gammas())
    assert objs[0]["sr_obj"] == 0.0
    # without final_locations the last successful place decides
    rec = record()
    rec.commands[1].final_locations = {}
    assert mission_rows(rec, SCENE, Gammas())[0][2]["sr_obj"] == 1.0
    rec.commands[1].actions[3].success = False
    assert mission_rows(rec, SCENE, Gammas())[0][2]["sr_obj"] == 0.0


@pytest.mark.parametrize("kinds, n, expect_slots, expect_objs", [
    # nav, pick a, nav, pick b, nav, pick c with 2 slots: c folds into slot 2
    (["N", "pa", "N", "pb", "N", "pc"], 2, [0, 0, 1, 1, 1, 1], [["a"], ["b", "c"]]),
    # navigation only: slot 1
    (["N", "N"], 3, [0, 0], [[], [], []]),
    # place of an object carried over opens a slot; trailing nav goes to the previous object
    (["N", "la", "N"], 1, [0, 0, 0], [["a"]]),
    (["pa", "N", "pb", "N", "lb", "N", "la"], 3, [0, 1, 1, 1, 1, 0, 0], [["a"], ["b"], []]),
])
def test_assign_slots_table(kinds, n, expect_slots, expect_objs):
    acts = []
    for k in kinds:
        if k == "N":
            acts.append(nav("f", "r", 0, 0.0, 0.0))
        else:
            acts.append(man("pickup" if k[0] == "p" else "place", k[1], "f", 1.0, 0.0))
    slots, objs = assign_slots(acts, n)
    assert slots == expect_slots and objs == expect_objs


def test_bad_record_names_the_key():
    rec = record().to_dict()
    del rec["commands"][1]["goal"]["n_objects"]
    with pytest.raises(RecordError, match=r"commands\[1\]\.goal: missing key 'n_objects'"):
        MissionRecord.from_dict(rec, "m000.json")
    with pytest.raises(RecordError, match=r"schema_version 0, this code reads 2; rerun the missions stage"):
        MissionRecord.from_dict({**record().to_dict(), "schema_version": 0}, "m000.json")


def test_records_round_trip():
    rec = record()
    assert MissionRecord.from_dict(rec.to_dict()).to_dict() == rec.to_dict()


def test_aggregate_writes_tables(tmp_path, cfg):
    from interllm.io import write_json

    write_json(tmp_path / "scenes" / "s0" / "scene.json",
               {"id": "s0", "objects": [{"id": o, "category": c, "furniture": SCENE["furniture"][o]}
                                        for o, c in SCENE["category"].items()]})
    rec = record()
    write_json(tmp_path / "runs" / "inter_llm" / "s0" / "m000.json", rec.to_dict())
    base = copy.deepcopy(rec)
    base.planner = "sayplan"
    base.commands[1].actions[2].collisions = 5  # +3 collisions -> +30 on obj 3
    write_json(tmp_path / "runs" / "sayplan" / "s0" / "m000.json", base.to_dict())
    write_json(tmp_path / "runs" / "planners.json", shown_planners(["inter_llm", "sayplan"]))
    out = write_metrics(tmp_path / "runs", tmp_path / "scenes", cfg, tmp_path / "metrics")
    assert out["planners"]["inter_llm"]["m_overall"] == pytest.approx(562)
    assert out["planners"]["sayplan"]["m_overall"] == pytest.approx(592)
    imp = out["improvement"]["inter_llm_vs_sayplan"]
    assert imp["pct"] == pytest.approx(round(100 * 30 / 592, 6)) and imp["n_pairs"] == 1
    sem = out["semantic_accuracy"]["inter_llm@0.8"]
    # every inference with a measured truth is judged (not only those whose action ran later)
    assert sem["n_inferences"] == 5 and sem["n_judged"] == 4
    assert sem["accuracy"] == pytest.approx(0.5)  # hard>hard, easy>easy right; hard>unknown, hard>easy wrong
    assert sem["unknown_share"] == pytest.approx(0.25)
    assert sem["accuracy_known"] == pytest.approx(round(2 / 3, 6))
    # the measured truth of pickup(apple_1) and pickup(mug_1) agrees with their later executions
    # (c_man 54 and 100: hard); place(laptop_1, bed_desk) was measured easy but ran at sr 0.8 (hard)
    assert sem["truth_agreement"] == pytest.approx(round(2 / 3, 6))
    with open(tmp_path / "metrics" / "per_object.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [float(r["m_overall"]) for r in rows if r["planner"] == "inter_llm"] == [67, 222, 73, 200]
    cum = read_csv(tmp_path / "metrics" / "cumulative.csv")
    assert [r["m_overall_cum"] for r in cum if r["planner"] == "sayplan"] == [67, 289, 392, 592]
    for name in ("per_command.csv", "per_mission.csv", "per_object_summary.csv", "semantic_accuracy.csv",
                 "semantic_inferences.csv"):
        assert (tmp_path / "metrics" / name).stat().st_size > 0


def test_aggregate_errors_name_the_fix(tmp_path):
    with pytest.raises(MetricsInputError, match="missions"):
        write_metrics(tmp_path / "nope", tmp_path, ExperimentConfig(), tmp_path / "m")
    from interllm.io import write_json
    write_json(tmp_path / "runs" / "inter_llm" / "s9" / "m000.json", {**record().to_dict(), "scene_id": "s9"})
    with pytest.raises(MetricsInputError, match="scene.json"):
        write_metrics(tmp_path / "runs", tmp_path / "scenes", ExperimentConfig(), tmp_path / "m")
    write_json(tmp_path / "scenes" / "s9" / "scene.json", {"id": "s9", "objects": []})
    with pytest.raises(PlannerTableError, match=r"runs/planners.json is missing: the missions stage writes it"):
        write_metrics(tmp_path / "runs", tmp_path / "scenes", ExperimentConfig(), tmp_path / "m")


def _one(cmds: list) -> MissionRecord:
    return MissionRecord("inter_llm", "s0", "m000", cmds, sim_time=1.0)


def _breakfast(actions, final) -> CommandRecord:
    return CommandRecord("breakfast", "Breakfast on the dining table.",
                         GoalRecord(("apple", "bread"), ("dining_table",), 1), summary("breakfast", 0, 0, 0, []),
                         actions, final)


def test_sr_obj_counts_only_what_the_robot_delivered():
    g = Gammas(10.0, 100.0, 100.0)
    scene = {"category": {"apple_1": "apple"}, "furniture": {"apple_1": "dining_table"}}  # on the target already
    # a failed pickup of an object standing on its target: no delivery
    failed = _breakfast([man("pickup", "apple_1", "dining_table", 0.0, 5.0, ok=False)], {"apple_1": "dining_table"})
    assert mission_rows(_one([failed]), scene, g)[0][0]["sr_obj"] == 0.0
    # picked up from the target and put back on it: no progress
    back = _breakfast([man("pickup", "apple_1", "dining_table", 1.0, 3.0),
                       man("place", "apple_1", "dining_table", 1.0, 3.0)], {"apple_1": "dining_table"})
    assert mission_rows(_one([back]), scene, g)[0][0]["sr_obj"] == 0.0
    # from the counter onto the table: delivered
    elsewhere = {"category": {"apple_1": "apple"}, "furniture": {"apple_1": "counter_1"}}
    moved = _breakfast([man("pickup", "apple_1", "counter_1", 1.0, 3.0),
                        man("place", "apple_1", "dining_table", 1.0, 3.0)], {"apple_1": "dining_table"})
    assert mission_rows(_one([moved]), elsewhere, g)[0][0]["sr_obj"] == 1.0
    # picked up in one command, carried, put on the target in the next: delivered in the second
    carry = _breakfast([man("pickup", "apple_1", "counter_1", 1.0, 3.0)], {"apple_1": "held"})
    put = _breakfast([man("place", "apple_1", "dining_table", 1.0, 3.0)], {"apple_1": "dining_table"})
    objs = mission_rows(_one([carry, put]), elsewhere, g)[0]
    assert [r["sr_obj"] for r in objs] == [0.0, 1.0]
