"""Generate mode on large houses (``planning.expansion``): a room-selection request, then plan
requests that show and allow only the chosen rooms, widened within a bound when they run short of
objects; ``llm.room_beam = 0`` keeps the flat prompt byte for byte; the call log's requests and
tokens counted per phase (``metrics.llm_usage``)."""

from __future__ import annotations

import hashlib
import json
import random
from dataclasses import replace

import pytest
from helpers.planners import ScriptedClient, tiny_mission, tiny_scene

from interllm.config import ConfigError, ExperimentConfig, LLMConfig
from interllm.core.actions import State
from interllm.llm.testing import schema_instance
from interllm.llm.types import LLMResponse
from interllm.metrics.llm_usage import planner_usage
from interllm.planning.expansion import rooms_view
from interllm.planning.feasibility import check_plan
from interllm.planning.proposers import make_proposer
from interllm.planning.request import Exclusions, PlanRequest
from interllm.scene.catalog import scene_config
from interllm.scene.generator import generate_scene
from interllm.scene.missions import generate_missions

START = State(at_furniture="dining_table_1", at_room="kitchen_1", holding=None)
NAV = {"action": "navigate", "furniture": "counter_1", "room": "kitchen_1", "object": ""}


class SchemaClient:
    """complete(): a seeded schema-valid answer (random rooms, random plans); records the requests."""

    def __init__(self):
        self.requests = []

    def complete(self, req):
        self.requests.append(req)
        answer = schema_instance(req.schema, random.Random(len(self.requests)))
        return LLMResponse("", answer, 0, 0, 0.0, False, "k")


class RoomsThenPlans(ScriptedClient):
    """Answers a room selection with the next of ``selections`` and a plan request with ``plan``."""

    def __init__(self, selections, plan=None):
        super().__init__(plan or {"actions": [NAV]})
        self.selections = list(selections)

    def complete(self, req):
        if req.purpose.startswith("rooms_for_"):
            self.requests.append(req)
            return LLMResponse("", {"rooms": self.selections.pop(0)}, 30, 5, 0.0, False, "k")
        return super().complete(req)


def generate_cfg(**llm) -> LLMConfig:
    return replace(ExperimentConfig().llm, proposal_mode="generate", cost_inference_mode="generate", **llm)


def propose(client, cfg: LLMConfig, scene=None, state=START, command=None, exclude=()):
    scene = scene or tiny_scene()
    command = command or tiny_mission().commands[0]
    proposer = make_proposer(client, cfg).plans
    req = PlanRequest(scene, state, command, command.goal.n_objects, exclude=Exclusions(tuple(exclude)),
                      context=(("command", command.id),))
    plans = proposer.propose(req, n_plans=2, seed=0)
    return proposer, plans


@pytest.fixture(scope="module")
def tokenizer():
    """The embedded model's tokenizer (its GGUF's vocabulary only)."""
    import llama_cpp

    from interllm.llm.model_files import resolve_model_path

    tok = llama_cpp.Llama(str(resolve_model_path("")), vocab_only=True, verbose=False)
    yield tok
    tok.close()


def tokens_per_command(tok, size: str, room_beam: int) -> float:
    """Prompt tokens (the embedded model's tokenizer) of everything the proposal of each command of
    the first mission sends: the room selection and the M = 3 plan requests."""
    scene = generate_scene(scene_config(size), 0)
    cfg = ExperimentConfig()
    mission = generate_missions(scene, cfg.mission)[0]
    state = State(mission.start_furniture, scene.furniture[mission.start_furniture].room, None)
    client = SchemaClient()
    proposer = make_proposer(client, replace(generate_cfg(), room_beam=room_beam)).plans
    for cmd in mission.commands:
        proposer.propose(PlanRequest(scene, state, cmd, cmd.goal.n_objects, context=(("command", cmd.id),)),
                         n_plans=cfg.planner.M, seed=0)
    n = sum(len(tok.tokenize(r.messages[0].content.encode(), add_bos=True, special=True)) for r in client.requests)
    return n / len(mission.commands)


@pytest.mark.embedded
def test_tokens_per_command_on_the_huge_house_are_at_most_twice_the_paper_house(tokenizer):
    paper, huge = tokens_per_command(tokenizer, "paper", 3), tokens_per_command(tokenizer, "huge", 3)
    assert huge <= 2 * paper, (paper, huge)
    assert tokens_per_command(tokenizer, "large", 0) > 5 * paper  # the flat prompt grows with the house


def _digests(requests) -> list[str]:
    return [hashlib.sha256(json.dumps([r.messages[0].content, r.schema], sort_keys=True).encode()).hexdigest()[:16]
            for r in requests]


def test_room_beam_0_keeps_the_flat_prompts_byte_for_byte():
    """The candidates, regeneration and replan requests (prompt and schema) of the flat prompt on
    the tiny scene, pinned by their sha256 prefixes."""
    scene, command = tiny_scene(), tiny_mission().commands[0]
    client = ScriptedClient({"actions": [{"action": "pickup", "furniture": "counter_1", "room": "", "object": "apple_1"}]})
    proposer, plans = propose(client, generate_cfg(room_beam=0))
    proposer.repair(PlanRequest(scene, START, command, 2), plans[0], check_plan(plans[0], scene, START),
                    round_index=0, candidate=0)
    proposer.replan(PlanRequest(scene, START, command, 2, exclude=Exclusions(("apple_1",))),
                    executed=["navigate(counter_1, kitchen_1)"], failure="pickup failed", attempt=0, seed=0)
    assert [r.purpose for r in client.requests] == ["candidates", "candidates", "regeneration", "replan"]
    assert _digests(client.requests) == ["8d6c282c6fa3513a", "c0daf3dbc5f0b895", "4bfe376ffa33927b", "aa995c9d4ca1510c"]


def test_the_plan_requests_show_and_allow_only_the_chosen_rooms():
    client = RoomsThenPlans([["kitchen_1"]])
    propose(client, generate_cfg())
    select, plan = client.requests[0], client.requests[1]
    assert select.purpose == "rooms_for_candidates" and select.schema["properties"]["rooms"]["maxItems"] == 3
    assert select.schema["properties"]["rooms"]["items"]["enum"] == ["kitchen_1", "living_room_1"]
    assert "kitchen: kitchen_1" in select.messages[0].content and "living room: living_room_1" in select.messages[0].content
    text, items = plan.messages[0].content, plan.schema["properties"]["actions"]["items"]["properties"]
    assert "- counter_1: apple_1, banana_1" in text and "banana: for eating" in text
    assert "sofa_1" not in text and "book_1" not in text
    assert items["object"]["enum"] == ["apple_1", "banana_1", ""]
    assert items["furniture"]["enum"] == ["counter_1", "dining_table_1"] and items["room"]["enum"] == ["kitchen_1", ""]


def test_the_held_object_stays_nameable_outside_the_chosen_rooms():
    view = rooms_view(tiny_scene(), ["kitchen_1"], holding="book_1")
    assert "book_1" in view.objects and "book: for reading" in view.text


def test_a_selection_short_of_objects_is_widened_within_the_bound():
    # the living room holds 3 objects, 2 of them excluded: 1 usable for a command asking for 2
    client = RoomsThenPlans([["living_room_1"], ["kitchen_1"]])
    propose(client, generate_cfg(), exclude=("book_1", "mug_1"))
    selections = [r for r in client.requests if r.purpose == "rooms_for_candidates"]
    assert [r.options.sample_index for r in selections] == [0, 1]
    assert selections[1].schema["properties"]["rooms"]["items"]["enum"] == ["kitchen_1"]  # only the rooms not chosen
    assert "chosen already" in selections[1].messages[0].content
    plan = [r for r in client.requests if r.purpose == "candidates"][0]
    assert "apple_1" in plan.messages[0].content and "laptop_1" in plan.messages[0].content

    bounded = RoomsThenPlans([["living_room_1"]])  # no widening allowed: the plans see the one room
    propose(bounded, generate_cfg(room_widenings=0), exclude=("book_1", "mug_1"))
    assert [r.purpose for r in bounded.requests].count("rooms_for_candidates") == 1
    assert "apple_1" not in [r for r in bounded.requests if r.purpose == "candidates"][0].messages[0].content


def test_an_empty_selection_is_widened_then_falls_back_to_the_robots_room():
    client = RoomsThenPlans([[], [], []])
    propose(client, generate_cfg())
    assert [r.options.sample_index for r in client.requests if r.purpose.startswith("rooms_for_")] == [0, 1, 2]
    plan = [r for r in client.requests if r.purpose == "candidates"][0]
    assert plan.schema["properties"]["actions"]["items"]["properties"]["room"]["enum"] == ["kitchen_1", ""]


def test_repairs_and_replans_reuse_the_commands_selection():
    scene, command = tiny_scene(), tiny_mission().commands[0]
    client = RoomsThenPlans([["kitchen_1"]])
    proposer, plans = propose(client, generate_cfg())
    ctx = (("command", command.id),)
    proposer.repair(PlanRequest(scene, START, command, 2, context=ctx), plans[0], check_plan(plans[0], scene, START),
                    round_index=0, candidate=0)
    proposer.replan(PlanRequest(scene, START, command, 1, exclude=Exclusions(("apple_1",)), context=ctx),
                    executed=[], failure="pickup failed", attempt=0, seed=0)
    assert [r.purpose for r in client.requests] == ["rooms_for_candidates", "candidates", "candidates",
                                                    "regeneration", "replan"]
    assert "kitchen_1 (kitchen)" in client.requests[-1].messages[0].content


def test_requests_and_tokens_are_counted_per_phase_and_widenings_per_command():
    def call(purpose, command, tokens_in, sample_index=0, planner="moma_llm"):
        return {"planner": planner, "scene": "s", "mission": "m", "command": command, "purpose": purpose,
                "tokens_in": tokens_in, "tokens_out": 10, "sample_index": sample_index}

    calls = [call("rooms_for_candidates", "a", 100), call("candidates", "a", 500), call("regeneration", "a", 600),
             call("rooms_for_regeneration", "a", 90, sample_index=1), call("rooms_for_candidates", "b", 100),
             call("candidates", "b", 400), call("replan", "b", 300), call("cost_inference", "b", 50),
             call("score_objects", "c", 70, planner="inter_llm")]
    u = planner_usage(calls, {"moma_llm": 4})
    m = u["moma_llm"]
    assert m["commands"] == 4 and m["requests"] == 8 and m["tokens_in"] == 2140 and m["per_command"]["requests"] == 2
    assert m["phases"]["proposal"]["requests"] == 4 and m["phases"]["proposal"]["tokens_in"] == 1100
    assert m["phases"]["repair"]["requests"] == 2 and m["phases"]["repair"]["selection_requests"] == 1
    assert m["phases"]["replan"]["tokens_in"] == 300 and m["phases"]["cost_inference"]["requests"] == 1
    assert m["room_selection"] == {"commands": 2, "widened": 1, "widened_share": 0.5}
    assert u["inter_llm"]["phases"]["proposal"]["requests"] == 1 and u["inter_llm"]["room_selection"]["widened_share"] is None


def test_a_bad_widening_bound_names_the_key():
    with pytest.raises(ConfigError, match="llm.room_widenings"):
        LLMConfig(room_widenings=-1).validate()
