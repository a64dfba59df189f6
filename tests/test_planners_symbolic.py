"""Planners end to end on the symbolic test world with fake LLM clients (fast)."""

import json

import pytest
from helpers.planners import (
    FakeScoreClient,
    ListRecorder,
    ScriptedClient,
    SymbolicWorld,
    run_tiny_mission,
    tiny_mission,
    tiny_scene,
)

from interllm.config import ConfigError, ExperimentConfig
from interllm.core.actions import Action, plan_to_list
from interllm.planners import PLANNERS
from interllm.planners.candidates import generate_initial_candidates
from interllm.planners.runner import run_mission


def cfg_for(**planner):
    cfg = ExperimentConfig()
    for k, v in planner.items():
        setattr(cfg.planner, k, v)
    return cfg


def test_registry_has_the_three_planners():
    assert {"inter_llm", "sayplan", "moma_llm"} <= set(PLANNERS.names())


def test_initial_candidates_are_m_distinct_feasible_plans_and_deterministic():
    cfg, scene, mission = ExperimentConfig(), tiny_scene(), tiny_mission()
    a = generate_initial_candidates(scene, mission, FakeScoreClient(), cfg)
    b = generate_initial_candidates(scene, mission, FakeScoreClient(), cfg)
    assert a == b and set(a) == {"breakfast"}  # only what is read: later commands are proposed when they run
    cfg_all = ExperimentConfig()
    cfg_all.planner.fair_baselines = False  # the baselines repair mission-start candidates for every command
    assert set(generate_initial_candidates(scene, mission, FakeScoreClient(), cfg_all)) == {"breakfast", "reading"}
    assert all(len(v) == cfg.planner.M for v in a.values())
    assert len({json.dumps(p) for p in a["breakfast"]}) == cfg.planner.M
    cfg0 = ExperimentConfig()
    cfg0.llm.temperature = 0.0
    best = generate_initial_candidates(scene, mission, FakeScoreClient(), cfg0)["breakfast"][0]
    placed = sorted(d["object"] for d in best if d["action"] == "place")
    assert placed == ["apple_1", "banana_1"] and best[-1]["furniture"] == "dining_table_1"


@pytest.mark.parametrize("name", ["inter_llm", "sayplan", "moma_llm"])
def test_each_planner_runs_a_mission_end_to_end(name, cfg):
    cfg.llm.temperature = 0.0
    recorder = ListRecorder()
    rec, world = run_tiny_mission(name, cfg, recorder=recorder)
    assert rec["planner"] == name and rec["mission_id"] == "m000" and rec["scene_id"] == "tiny"
    assert [c["command_id"] for c in rec["commands"]] == ["breakfast", "reading"]
    c1 = rec["commands"][0]
    assert c1["final_locations"] == {"apple_1": "dining_table_1", "banana_1": "dining_table_1"}
    assert c1["goal"]["n_objects"] == 2 and c1["summary"]["command_id"] == "breakfast"
    assert rec["sim_time"] == pytest.approx(world.clock) and world.clock > 0
    times = [a["t_start"] for c in rec["commands"] for a in c["actions"]]
    assert times == sorted(times)
    json.dumps(rec)
    topics = {e[0] for e in recorder.events}
    assert {"/planner/candidates", "/planner/feasibility", "/planner/selected"} <= topics
    assert len(recorder.actions) == sum(len(c["actions"]) for c in rec["commands"])
    # the second command does not take back objects delivered by the first
    assert not ({"apple_1", "banana_1"} & set(rec["commands"][1]["final_locations"]))


def test_runs_are_deterministic():
    a, _ = run_tiny_mission("inter_llm")
    b, _ = run_tiny_mission("inter_llm")
    assert json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)


def test_inter_llm_selects_the_cheapest_candidate_and_estimates():
    scene, mission = tiny_scene(), tiny_mission()
    far = [Action("navigate", "desk_1", room="living_room_1"), Action("pickup", "desk_1", obj="mug_1"),
           Action("navigate", "dining_table_1", room="kitchen_1"), Action("place", "dining_table_1", obj="mug_1")]
    near = [Action("navigate", "counter_1", room="kitchen_1"), Action("pickup", "counter_1", obj="apple_1"),
            Action("navigate", "dining_table_1", room="kitchen_1"),
            Action("place", "dining_table_1", obj="apple_1")]
    cands = generate_initial_candidates(scene, mission, FakeScoreClient(), ExperimentConfig())
    cands["breakfast"] = [plan_to_list(tuple(far)), plan_to_list(tuple(near))]
    recorder = ListRecorder()
    rec, _ = run_tiny_mission("inter_llm", cands=cands, recorder=recorder)
    s1 = rec["commands"][0]["summary"]
    assert s1["selected_plan"] == plan_to_list(tuple(near))
    assert len(s1["estimated_costs"]) == 2 and s1["estimated_costs"][1] < s1["estimated_costs"][0]
    assert any(e[0] == "/planner/estimates" for e in recorder.events)
    # second command: re-proposed with the known costs -> LLM cost inferences for manipulations
    s2 = rec["commands"][1]["summary"]
    assert s2["cost_inferences"] and all(ci["predicted"] in ("easy", "medium", "hard", "unknown")
                                         for ci in s2["cost_inferences"])
    assert len(s2["estimated_costs"]) == len(s2["candidates"]) >= 1


def test_regeneration_bound_with_an_always_infeasible_llm():
    cfg = cfg_for(max_regenerations=2)
    cfg.llm.proposal_mode = "generate"
    bad = {"actions": [{"action": "pickup", "furniture": "counter_1", "room": "", "object": "pear_9"}]}
    client = ScriptedClient(bad)
    scene, mission = tiny_scene(), tiny_mission()
    cands = generate_initial_candidates(scene, mission, client, cfg)
    n_initial = len(client.requests)
    # a plan per candidate of the first command; the scripted answer names no room, so its room
    # selection is widened to its bound (then the plans look at the robot's room)
    purposes = [r.purpose for r in client.requests]
    assert purposes.count("candidates") == cfg.planner.M  # the first command's only: later ones run in another state
    assert purposes.count("rooms_for_candidates") == 1 + cfg.llm.room_widenings
    rec, world = run_tiny_mission("inter_llm", cfg, client=client, cands=cands)
    s = rec["commands"][0]["summary"]
    assert s["dropped_candidates"] == cfg.planner.M
    assert s["regenerations"] == cfg.planner.M * 2
    regen = [r for r in client.requests[n_initial:] if r.purpose == "regeneration"]
    assert len(regen) >= cfg.planner.M * 2
    assert "pear_9" in regen[0].messages[0].content and "not in the scene graph" in regen[0].messages[0].content
    assert rec["commands"][0]["actions"] == [] and s["candidates"] == []


def test_sayplan_open_loop_vs_moma_replanning_after_a_failure(cfg):
    cfg.llm.temperature = 0.0
    say, _ = run_tiny_mission("sayplan", cfg, hard=("apple_1",))
    moma, _ = run_tiny_mission("moma_llm", cfg, hard=("apple_1",))
    s_say, s_moma = say["commands"][0], moma["commands"][0]
    assert s_say["summary"]["replans"] == 0
    assert s_say["final_locations"] == {"banana_1": "dining_table_1"}
    assert s_moma["summary"]["replans"] == 1
    delivered = [o for o, f in s_moma["final_locations"].items() if f == "dining_table_1"]
    assert len(delivered) == 2 and "apple_1" not in delivered
    failed = [a for a in s_moma["actions"] if not a["success"]]
    assert [a["action"]["object"] for a in failed] == ["apple_1"]


class _PromptLog(FakeScoreClient):
    """FakeScoreClient that keeps every score prompt."""

    def __init__(self):
        super().__init__()
        self.prompts: list[str] = []

    def score(self, req):
        self.prompts.append(req.prompt)
        return super().score(req)


def test_moma_replans_in_score_mode_from_the_failure_and_what_was_executed(cfg):
    """Score mode's replan scores the command again with the execution so far and the failure's
    text before the request (generate mode's replan prompt carries the same two); the oracle's
    scores are ground truth: its replan asks no model."""
    cfg.llm.temperature = 0.0
    client = _PromptLog()
    rec, _ = run_tiny_mission("moma_llm", cfg, hard=("apple_1",), client=client)
    assert rec["commands"][0]["summary"]["replans"] == 1
    told = [p for p in client.prompts if "An action failed during execution:" in p]
    assert told, "no score prompt carried the failure"
    assert all("pickup(apple_1" in p and "FAILED" in p and p.index("FAILED") < p.index("Request:") for p in told)
    assert all("Executed so far: navigate(" in p for p in told)
    assert len(told) >= 3  # the objects', the targets' and the rooms' prompts of the one replan
    assert "An action failed" not in client.prompts[0]  # the proposals before it were told nothing


def test_blocked_navigation_is_skipped_and_recorded(cfg):
    cfg.llm.temperature = 0.0
    rec, world = run_tiny_mission("sayplan", cfg, blocked=("counter_1",))
    c1 = rec["commands"][0]
    nav = [a for a in c1["actions"] if a["kind"] == "navigate" and not a["success"]]
    assert nav and nav[0]["collisions"] == 1
    assert any("skipping the rest" in n for n in c1["summary"]["notes"])
    assert world.state.holding is None


def test_unknown_planner_and_missing_candidates_raise():
    scene, mission = tiny_scene(), tiny_mission()
    with pytest.raises(ConfigError, match="'greedy' is not a registered planner"):
        run_mission("greedy", SymbolicWorld(scene, ExperimentConfig().sim), mission, {"breakfast": [], "reading": []},
                    FakeScoreClient(), ExperimentConfig())
    with pytest.raises(ValueError, match=r"lack command\(s\) \['breakfast'\].*candidates stage"):
        run_mission("sayplan", SymbolicWorld(scene, ExperimentConfig().sim), mission, {"reading": []},
                    FakeScoreClient(), ExperimentConfig())
    loose = ExperimentConfig()
    loose.planner.fair_baselines = False  # then the baselines read every command's
    with pytest.raises(ValueError, match=r"lack command\(s\) \['reading'\]"):
        run_mission("sayplan", SymbolicWorld(scene, loose.sim), mission, {"breakfast": []}, FakeScoreClient(), loose)


def test_moma_counts_no_replan_when_a_failure_comes_after_the_command_is_fulfilled():
    """A plan that goes on after the command's objects are delivered and fails there: nothing is
    left to replan, so no replan is asked for and none is counted."""
    cfg = ExperimentConfig()
    cfg.llm.proposal_mode = "generate"
    steps = [("navigate", "counter_1", None), ("pickup", "counter_1", "apple_1"),
             ("navigate", "dining_table_1", None), ("place", "dining_table_1", "apple_1"),
             ("navigate", "counter_1", None), ("pickup", "counter_1", "banana_1"),
             ("navigate", "dining_table_1", None), ("place", "dining_table_1", "banana_1"),
             ("navigate", "desk_1", None), ("pickup", "desk_1", "mug_1"),
             ("navigate", "dining_table_1", None), ("place", "dining_table_1", "mug_1")]
    rooms = {"counter_1": "kitchen_1", "dining_table_1": "kitchen_1", "desk_1": "living_room_1"}
    plan = {"actions": [{"action": k, "furniture": f, "room": rooms[f], **({"object": o} if o else {})}
                        for k, f, o in steps]}
    rec, _ = run_tiny_mission("moma_llm", cfg, hard=("mug_1",), client=ScriptedClient(plan))
    c = rec["commands"][0]
    assert [a for a in c["actions"] if not a["success"]], "the mug's pickup was to fail"
    assert c["summary"]["replans"] == 0


@pytest.mark.parametrize("shared, first_source", [(True, "initial"), (False, "reproposed")])
def test_inter_llm_labels_its_candidates_by_where_they_come_from(shared, first_source):
    """Only the shared initial candidates are "initial"; a first command without them is proposed
    from the current state like every later one."""
    cfg, client = ExperimentConfig(), FakeScoreClient()
    scene, mission = tiny_scene(), tiny_mission()
    cands = generate_initial_candidates(scene, mission, client, cfg) if shared else \
        {c.id: [] for c in mission.commands}
    log = ListRecorder()
    run_tiny_mission("inter_llm", cfg, client=client, cands=cands, recorder=log)
    assert [e[2]["source"] for e in log.events if e[0] == "/planner/candidates"] == [first_source, "reproposed"]
