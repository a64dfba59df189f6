import numpy as np
import pytest
from helpers.planners import FakeScoreClient, ScriptedClient, tiny_mission, tiny_scene

from interllm.config import ExperimentConfig
from interllm.core.actions import Action, State
from interllm.core.seeding import planning_seed
from interllm.planning import expansion, generation, plans, scoring
from interllm.planning.feasibility import check_plan
from interllm.planning.memory import KnownCosts
from interllm.planning.proposers import make_proposer
from interllm.planning.request import Exclusions, PlanRequest

START = State("dining_table_1", "kitchen_1")


def scores_table():
    return scoring.SemanticScores(
        categories={},
        instances={"apple_1": 3.0, "banana_1": 2.5, "mug_1": 1.0, "book_1": 0.4, "laptop_1": 0.0},
        targets={"dining_table_1": 2.0, "counter_1": 1.0, "sofa_1": 0.0, "desk_1": -1.0})


def test_temperature_zero_is_argmax_then_next_best():
    sels = scoring.sample_selections(scores_table(), tiny_scene(), START, n_objects=2, n_plans=3, temperature=0.0,
                                     rng=np.random.default_rng(0))
    # summed scores on the dining table: apple+banana 2+3+2.5 = 7.5, apple+mug 6.0, banana+mug 5.5,
    # apple+book 5.4; the best on the counter (apple and banana are on it) is mug+book 1+1+0.4 = 2.4
    assert sels[0] == (("apple_1", "banana_1"), "dining_table_1")
    assert sels[1] == (("apple_1", "mug_1"), "dining_table_1")
    assert sels[2] == (("banana_1", "mug_1"), "dining_table_1")


def test_sampling_is_deterministic_by_seed_and_distinct():
    sc, scene = scores_table(), tiny_scene()
    def sample(seed: int):
        return scoring.sample_selections(sc, scene, START, n_objects=2, n_plans=4, temperature=0.8,
                                         rng=np.random.default_rng(seed))
    a, b = sample(7), sample(7)
    assert a == b and len(a) == 4
    assert len({(frozenset(o), t) for o, t in a}) == 4
    for objs, tgt in a:  # never picks an object already on the target
        assert all(scene.objects[o].furniture != tgt for o in objs)
    others = [sample(s) for s in range(1, 6)]
    assert any(o != a for o in others)


def test_assembled_plans_are_feasible_and_skip_redundant_navigation():
    scene = tiny_scene()
    plan = plans.assemble_plan(scene, State("counter_1", "kitchen_1"), ["apple_1", "mug_1"], "dining_table_1")
    assert [str(a) for a in plan] == [
        "pickup(apple_1, counter_1)", "navigate(dining_table_1, kitchen_1)", "place(apple_1, dining_table_1)",
        "navigate(desk_1, living_room_1)", "pickup(mug_1, desk_1)", "navigate(dining_table_1, kitchen_1)",
        "place(mug_1, dining_table_1)"]
    assert check_plan(plan, scene, State("counter_1", "kitchen_1")).valid
    held = plans.assemble_plan(scene, State("counter_1", "kitchen_1", "apple_1"), [], "sofa_1")
    assert [str(a) for a in held] == ["navigate(sofa_1, living_room_1)", "place(apple_1, sofa_1)"]


def test_score_command_with_fake_scorer_ranks_by_the_command(cfg):
    sc = scoring.score_command(FakeScoreClient(), tiny_scene(), tiny_mission().commands[0], cfg.llm)
    top = sorted(sc.instances, key=lambda o: -sc.instances[o])[:2]
    assert set(top) == {"apple_1", "banana_1"}
    assert max(sc.targets, key=sc.targets.get) == "dining_table_1"


def test_repair_reassembles_from_the_current_scene_and_replaces_bad_choices():
    scene = tiny_scene()
    bad = (Action("pickup", "sofa_1", obj="apple_1"), Action("place", "dining_table_1", obj="apple_1"),
           Action("pickup", "counter_1", obj="pear_9"), Action("place", "dining_table_1", obj="pear_9"))
    assert not check_plan(bad, scene, START).valid
    command = tiny_mission().commands[0]
    fixed = scoring.repair_by_scores(bad, scores_table(), PlanRequest(scene, START, command, 2))
    assert check_plan(fixed, scene, START).valid
    assert [a.obj for a in fixed if a.kind == "place"] == ["apple_1", "banana_1"]
    fixed2 = scoring.repair_by_scores(bad, scores_table(),
                                      PlanRequest(scene, START, command, 2, exclude=Exclusions(("apple_1",))))
    assert [a.obj for a in fixed2 if a.kind == "place"] == ["banana_1", "mug_1"]


def test_parse_plan_and_schema():
    scene = tiny_scene()
    schema = plans.plan_schema(scene)
    assert "apple_1" in schema["properties"]["actions"]["items"]["properties"]["object"]["enum"]
    plan = plans.parse_plan({"actions": [{"action": "navigate", "furniture": "sofa_1", "room": "living_room_1",
                                      "object": ""},
                                     {"action": "pickup", "furniture": "sofa_1", "room": "", "object": "book_1"}]})
    assert [str(a) for a in plan] == ["navigate(sofa_1, living_room_1)", "pickup(book_1, sofa_1)"]
    assert plans.parse_plan(None) == () and plans.parse_plan({"actions": [{"action": "fly"}]}) == ()


def test_generate_plans_one_call_per_candidate_with_sample_index():
    ans = {"actions": [{"action": "navigate", "furniture": "counter_1", "room": "kitchen_1", "object": ""}]}
    client = ScriptedClient(ans)
    req = PlanRequest(tiny_scene(), START, tiny_mission().commands[0], 2)
    plans = generation.generate_plans(client, req, ExperimentConfig().llm, view=expansion.flat_view(tiny_scene()),
                                      n_plans=3)
    assert len(plans) == 3 and [r.options.sample_index for r in client.requests] == [0, 1, 2]
    text = client.requests[0].messages[0].content
    assert text.index('"rooms"') < text.index("Command: Put an apple")  # static part first
    assert "Plans already proposed" in client.requests[1].messages[0].content


def test_cost_inference_unknown_without_known_costs_and_sampled_with_them():
    cfg, scene = ExperimentConfig(), tiny_scene()
    client = FakeScoreClient()
    costs = make_proposer(client, cfg.llm).costs
    pick = Action("pickup", "counter_1", obj="banana_1")
    assert costs.infer(pick, scene, KnownCosts(), seed_parts=(), context=()) == "unknown"
    assert client.n_score == 0
    k = KnownCosts()
    k.add_manipulation(Action("pickup", "counter_1", obj="apple_1"), START, 3.0)
    labs = {costs.infer(pick, scene, k, seed_parts=(s,), context=()) for s in range(30)}
    assert labs <= {"easy", "medium", "hard", "unknown"} and len(labs) > 1  # sampled at T = 0.8
    a = [costs.infer(pick, scene, k, seed_parts=("x",), context=()) for _ in range(3)]
    assert len(set(a)) == 1  # same seed parts -> same label
    gen = ScriptedClient({"cost": "hard"})
    cfg_g = ExperimentConfig()
    cfg_g.llm.cost_inference_mode = "generate"
    assert make_proposer(gen, cfg_g.llm).costs.infer(pick, scene, k, seed_parts=(), context=()) == "hard"
    prompt = gen.requests[0].messages[0].content
    assert "pickup apple (for eating) from the counter in the kitchen: easy" in prompt


@pytest.mark.parametrize("scores,label", [([0, 1, 3, 2], "hard"), ([5, 1, 0, 0], "easy")])
def test_sample_label_argmax_at_zero_temperature(scores, label):
    assert scoring.sample_label(scores, 0.0, 1) == label


def test_planning_seed_is_stable():
    assert planning_seed(0, "a") != planning_seed(1, "a")
    assert planning_seed(0, "candidates", "m000") != planning_seed(0, "candidates", "m001")
    # SHA-256 of b'["planning",0,"candidates"]', 4 bytes big-endian, top bit cleared: not salted per process
    assert planning_seed(0, "candidates") == 671786711


def test_plans_and_cost_labels_take_their_temperatures_separately(monkeypatch):
    import dataclasses

    from interllm.config import LLMConfig
    from interllm.planning import generation, proposers, scoring

    cfg = dataclasses.replace(LLMConfig(), temperature=0.2, plan_temperature=0.9)
    assert cfg.plan_sampling_temperature == 0.9
    assert dataclasses.replace(cfg, plan_temperature=None).plan_sampling_temperature == 0.2  # coupled
    assert generation._options(cfg).temperature == 0.9  # a plan request
    assert generation._options(cfg, plan=False).temperature == 0.2  # a cost-inference request: sigma
    seen = []
    monkeypatch.setattr(scoring, "propose_by_scores", lambda *a, **k: seen.append(k["temperature"]) or [])
    p = proposers.PLAN_PROPOSERS.get("score")(client=None, cfg=cfg)
    monkeypatch.setattr(p, "scores", lambda *a, **k: None)
    monkeypatch.setattr(p, "replan_scores", lambda *a, **k: None)  # a replan scores the command anew
    req = PlanRequest(tiny_scene(), START, tiny_mission().commands[0], 3)
    p.propose(req, n_plans=3, seed=0)
    p.replan(req, executed=(), failure="", attempt=0, seed=0)
    assert seen == [0.9, 0.9]
