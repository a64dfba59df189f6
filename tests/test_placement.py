"""Where an object sits on its furniture, from geometry (``scene/placement.py``), and the
cost-inference prompts that carry it with ``llm.placement_attributes`` (read back from a real run's
LLM cache)."""

from __future__ import annotations

import json
import re

import pytest
from helpers.scenes import kitchen

from interllm.config import ExperimentConfig, MissionConfig
from interllm.scene.graph import Furniture
from interllm.scene.placement import open_sides, placement_of, placement_text


def test_depth_is_measured_from_the_open_sides():
    """The counter (x 1.4..2.6, y 2.15..2.95) stands against the north wall: S, W and E are open.
    mug_front is 0.10 m from S; mug_back 0.70 m from S and 0.60 m from W and E."""
    s = kitchen()
    assert open_sides(s, "counter_1") == ("S", "W", "E")
    front, back = placement_of(s, "mug_front"), placement_of(s, "mug_back")
    assert (front.depth, back.depth) == (0.10, 0.60)
    assert front.height == back.height == 0.90 and front.size == 0.10
    assert front.clearance == back.clearance == 0.52  # boxes y 2.21..2.29 and 2.81..2.89
    assert placement_text(back) == ("at the back, 0.60 m in from the open side, at 0.90 m height, "
                                    "0.52 m from the next object, 10 cm across")
    assert not placement_text(front).startswith("at the back")
    # furniture beside W and E closes those sides: only S is left, 0.70 m from the back mug
    s.furniture["fridge_1"] = Furniture("fridge_1", "fridge", "k", (1.0, 2.5), (0.6, 0.6, 1.8))
    s.furniture["shelf_1"] = Furniture("shelf_1", "shelf", "k", (3.0, 2.5), (0.4, 0.4, 1.2))
    assert open_sides(s, "counter_1") == ("S",)
    assert placement_of(s, "mug_back").depth == 0.70


_M_IN = re.compile(r"\d\.\d\d m in from the (open|nearest) side")


@pytest.mark.integration
@pytest.mark.embedded
def test_cost_inference_prompts_carry_the_placement_of_the_action_and_of_every_known_one(tmp_path):
    """Inter-LLM with the embedded model on two commands: every cost-inference prompt's action
    line and every measured-action line name the furniture instance and the object's place on it."""
    from interllm.llm import make_client
    from interllm.planners.candidates import generate_initial_candidates
    from interllm.planners.runner import run_mission
    from interllm.scene import catalog, generator
    from interllm.scene import missions as missions_mod
    from interllm.sim.world import World

    scene = generator.generate_scene(catalog.scene_config("tiny", seed=0), 0)
    mission = missions_mod.generate_missions(scene, MissionConfig(n_missions=1, commands_per_mission=2), 0.25)[0]
    cfg = ExperimentConfig()
    cfg.llm.cache_dir = str(tmp_path / "cache")
    cfg.llm.placement_attributes = True
    client = make_client(cfg.llm)
    cands = generate_initial_candidates(scene, mission, client, cfg)
    run_mission("inter_llm", World(scene, cfg.sim), mission, cands, client, cfg)
    requests = [json.loads(p.read_text()).get("request", {}) for p in (tmp_path / "cache").rglob("*.json")]
    prompts = [r["prompt"] for r in requests if r.get("template", {}).get("name") == "score_cost"]
    assert prompts, "no cost inference was asked"
    furniture = set(scene.furniture)
    pickups = 0
    for prompt in prompts:
        known = [ln for ln in prompt.splitlines() if ln.startswith("- ")]
        action = next(ln for ln in prompt.splitlines() if ln.startswith("Action:"))
        assert known
        for line in known + [action]:
            where = re.search(r" (?:from|on) (\w+), the ", line)
            assert where and where.group(1) in furniture, line
            assert _M_IN.search(line) or "surface at" in line, line
        # an unknown pickup's depth, height and size are what the geometry says of an object of that
        # category on that furniture (its clearance may differ: command 1 moved objects)
        m = re.match(r"Action: pickup (.+?) (?:\(.*?\) )?from (\w+), the ", action)
        if m:
            pickups += 1
            cands = [placement_of(scene, o.id) for o in scene.objects_on(m.group(2))
                     if o.category.replace("_", " ") == m.group(1)]
            assert any(f"{p.depth:.2f} m in from" in action and f"at {p.height:.2f} m height" in action
                       and f"{round(p.size * 100)} cm across" in action for p in cands), action
    assert pickups, "no cost inference of a pickup was asked"
