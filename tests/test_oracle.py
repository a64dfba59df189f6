"""The oracle input source (``llm=oracle``, interllm/planning/oracle.py): answers from ground truth,
wrong at a controlled rate, never mixed with a model and never written to the LLM cache."""

from __future__ import annotations

import json
from collections import Counter

import pytest
from helpers.planners import SymbolicWorld, tiny_mission, tiny_scene

from interllm.config import ConfigError, ExperimentConfig, LLMConfig, from_dict
from interllm.core.actions import Action, plan_from_list
from interllm.metrics.compute import read_csv
from interllm.planning.oracle import oracle_scores
from interllm.planning.proposers import OracleCosts, make_proposer
from interllm.scene.generator import generate_scene
from interllm.scene.missions import generate_missions
from interllm.stages.inputs import load_scene_and_missions
from interllm.stages.pipeline import run_all


def oracle_cfg(error: float = 0.0, **extra) -> LLMConfig:
    return from_dict({"llm": {"backend": "oracle", "proposal_mode": "oracle", "cost_inference_mode": "oracle",
                              "oracle_error": error, **extra}}).llm


def _delivers(plan, command, scene) -> bool:
    """Every object the plan picks is of a category the command asks for, and every place is on its target."""
    return all((a.kind != "pickup" or scene.objects[a.obj].category in command.goal.categories)
               and (a.kind != "place" or a.furniture in command.goal.target_furniture) for a in plan)


@pytest.mark.integration
def test_the_oracle_at_zero_error_runs_the_quick_experiment_right_and_caches_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv("INTERLLM_PROGRESS", "0")
    cfg = from_dict({"jobs": 1, "scene": {"n_scenes": 1}, "mission": {"n_missions": 1},
                     "llm": {"backend": "oracle", "proposal_mode": "oracle", "cost_inference_mode": "oracle",
                             "cache_dir": str(tmp_path / "cache")}})
    metrics = run_all(cfg, tmp_path / "data")
    data = tmp_path / "data"
    scene_id = next(p.name for p in (data / "scenes").iterdir() if p.is_dir())
    scene, loaded = load_scene_and_missions(data / "scenes", scene_id, cfg)
    missions = {m.id: m for m in loaded}

    # every candidate of every command (the shared initial ones, made for the first command, and
    # each planner's proposals for later ones) takes objects the command asks for to its target
    initial = json.loads((data / "candidates" / f"{scene_id}.json").read_text())
    n_plans = 0
    for mid, by_cmd in initial.items():
        mission = missions[mid]
        assert set(by_cmd) == {mission.commands[0].id}
        for p in by_cmd[mission.commands[0].id]:
            assert _delivers(plan_from_list(p), mission.commands[0], scene), (mission.commands[0].id, p)
            n_plans += 1
    for rec_path in (data / "runs").rglob("m*.json"):
        rec = json.loads(rec_path.read_text())
        mission = missions[rec["mission_id"]]
        for cmd, c in zip(mission.commands, rec["commands"], strict=True):
            for p in c["summary"]["candidates"]:
                assert _delivers(plan_from_list(p), cmd, scene), (rec_path, cmd.id, p)
                n_plans += 1
    assert n_plans >= 3 * 3 * 2
    # every cost inference is judged and right
    inferences = read_csv(data / "metrics" / "semantic_inferences.csv")
    assert inferences and all(int(r["judged"]) for r in inferences)
    assert all(r["predicted"] == r["truth"] for r in inferences)
    assert metrics["semantic_accuracy"]["inter_llm@0.8"]["accuracy"] == 1.0
    # no model was asked: nothing cached, no call logged; the results say who answered
    assert not (tmp_path / "cache").exists() or not any((tmp_path / "cache").rglob("*.json"))
    assert metrics["settings"]["source"] == "oracle (error 0)"
    assert all(p["llm_calls_per_mission"] == 0 for p in metrics["planners"].values())
    assert "oracle (error 0)" in (data / "report" / "report.md").read_text()


def test_the_error_replaces_that_share_of_answers_by_random_ones():
    """Relevance answers replaced by a fair coin disagree with the truth half the time, so at error
    e about e/2 of them are wrong; a replaced target is one of the scene's furniture at random."""
    from interllm.config import SceneConfig

    scene = generate_scene(SceneConfig(), 0)
    commands = [c for m in generate_missions(scene, ExperimentConfig().mission) for c in m.commands]
    for e in (0.0, 0.2, 0.6):
        cfg = oracle_cfg(e)
        wrong = n = wrong_targets = 0
        for i, cmd in enumerate(commands):
            s = oracle_scores(scene, cmd, cfg, (("scene", scene.id), ("mission", f"m{i:03d}")))
            for oid, v in s.instances.items():
                n += 1
                wrong += (v == 0.0) != (scene.objects[oid].category in cmd.goal.categories)
            picked = {f for f, v in s.targets.items() if v == 0.0}
            wrong_targets += not picked <= set(cmd.goal.target_furniture)
        assert n >= 500
        share = wrong / n
        assert abs(share - e / 2) < 0.05, (e, share)
        if e == 0.0:
            assert wrong_targets == 0
    # the same question gets the same answer whichever planner asks
    cmd = commands[0]
    a = oracle_scores(scene, cmd, oracle_cfg(0.6), (("planner", "sayplan"), ("scene", scene.id), ("mission", "m0")))
    b = oracle_scores(scene, cmd, oracle_cfg(0.6), (("planner", "inter_llm"), ("scene", scene.id), ("mission", "m0")))
    assert a == b


def test_oracle_cost_classes_are_the_measured_ones_or_seeded_noise():
    scene = tiny_scene()
    world = SymbolicWorld(scene, ExperimentConfig().sim, hard_objects=("apple_1",))
    world.reset(tiny_mission())
    pick = Action("pickup", "counter_1", obj="apple_1")
    easy = Action("pickup", "desk_1", obj="mug_1")
    ctx = (("scene", "tiny"), ("mission", "m000"))
    exact = OracleCosts(None, oracle_cfg(0.0), ground_truth=world)
    assert exact.infer(pick, scene, None, seed_parts=("c", 0), context=ctx) == "hard"
    assert exact.infer(easy, scene, None, seed_parts=("c", 0), context=ctx) == "easy"
    noisy = OracleCosts(None, oracle_cfg(1.0), ground_truth=world)
    labels = Counter(noisy.infer(pick, scene, None, seed_parts=("c", k), context=ctx) for k in range(300))
    assert set(labels) == {"easy", "medium", "hard"} and min(labels.values()) > 70  # uniform: 100 each
    with pytest.raises(RuntimeError, match="ground_truth=world"):
        OracleCosts(None, oracle_cfg(0.0)).infer(pick, scene, None, seed_parts=(), context=ctx)
    # the proposer hands the world to the oracle's cost mode only
    proposer = make_proposer(None, oracle_cfg(0.0), ground_truth=world)
    assert proposer.costs.truth is world


def test_the_oracle_is_never_mixed_with_a_model():
    with pytest.raises(ConfigError, match="llm=oracle"):
        from_dict({"llm": {"backend": "embedded", "cost_inference_mode": "oracle"}})
    with pytest.raises(ConfigError, match="llm=oracle"):
        from_dict({"llm": {"backend": "oracle"}})
    with pytest.raises(ConfigError, match="llm.oracle_error"):
        oracle_cfg(1.5)
    assert oracle_cfg(0.25).source_label == "oracle (error 0.25)"
    assert ExperimentConfig().llm.source_label == "embedded gemma3-270m"


def test_equivalent_error_and_where_the_look_ahead_stops_paying():
    from interllm.metrics.capability import equivalent_error, paying_errors

    sweep = [(0.0, 1.0), (0.1, 0.95), (0.25, 0.87), (0.5, 0.75)]
    assert equivalent_error(0.91, sweep) == pytest.approx(0.175)  # halfway between 0.95 and 0.87
    assert equivalent_error(1.0, sweep) == 0.0
    assert equivalent_error(0.6, sweep) is None and equivalent_error(0.9, sweep[:1]) is None
    # CI lower bounds above 0 at 0, 0.1 and 0.5, not at 0.25
    assert paying_errors([(0.5, 1.0, 3.0), (0.0, 2.0, 9.0), (0.1, 0.5, 6.0), (0.25, -1.0, 4.0)]) == \
        ([0.0, 0.1, 0.5], [0.25])
    assert paying_errors([(0.0, -0.1, 5.0)]) == ([], [0.0])


def test_answer_accuracy_counts_relevant_objects_and_right_targets():
    from test_metrics_compute import SCENE, record

    from interllm.core.actions import Action
    from interllm.metrics.capability import answer_accuracy

    rec = record()
    breakfast = rec.commands[0].summary  # asks for apple / bread on dining_table
    breakfast.candidates = [
        (Action("pickup", "counter_1", obj="apple_1"), Action("place", "dining_table", obj="apple_1"),
         Action("pickup", "counter_1", obj="bread_1"), Action("place", "dining_table", obj="bread_1")),
        (Action("pickup", "desk_1", obj="laptop_1"), Action("place", "bed_desk", obj="laptop_1"))]
    rec.commands[1].summary.candidates = []
    a = answer_accuracy([rec], {"s0": SCENE})
    assert (a["n_objects"], a["n_candidates"]) == (3, 2)
    assert a["relevance"] == pytest.approx(2 / 3) and a["target"] == pytest.approx(0.5)


@pytest.mark.integration
def test_the_sweep_report_places_a_run_on_the_oracle_axis(tmp_path, monkeypatch):
    """Two quick oracle runs (error 0 and 1) form the sweep; a third at error 0.5 plays the model."""
    from interllm.stages.report import find_oracle_results, run_report

    monkeypatch.setenv("INTERLLM_PROGRESS", "0")
    runs = {}
    for e in (0.0, 0.5, 1.0):
        job = tmp_path / "multirun" / f"e{e}"
        cfg = from_dict({"jobs": 1, "scene": {"n_scenes": 1}, "mission": {"n_missions": 1},
                         "experiment": "oracle_sweep",
                         "llm": {"backend": "oracle", "proposal_mode": "oracle", "cost_inference_mode": "oracle",
                                 "oracle_error": e, "cache_dir": str(tmp_path / "cache")}})
        run_all(cfg, job / "data")
        if e != 0.5:
            (job / ".hydra").mkdir(parents=True)
            (job / ".hydra" / "config.yaml").write_text(json.dumps({"experiment": "oracle_sweep",
                                                                    "llm": {"oracle_error": e}}))
        runs[e] = (cfg, job / "data")
    found = find_oracle_results(tmp_path / "multirun")
    assert [e for e, _ in found] == [0.0, 1.0]
    cfg, data = runs[0.5]
    run_report(cfg, data / "metrics", data / "scenes", data / "runs", tmp_path / "out", oracle_results=found)
    md = (tmp_path / "out" / "report.md").read_text()
    assert "LLM capability: the oracle sweep" in md
    assert "oracle (error 0.5) sits where its accuracy on object relevance" in md
    assert (tmp_path / "out" / "figures" / "capability.png").stat().st_size > 10_000
