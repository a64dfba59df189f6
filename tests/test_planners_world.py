"""Planners end to end on the real MuJoCo World (tiny generated scene), fake and real LLM."""

import json

import pytest
from test_planners_fakes import FakeScoreClient

from interllm.config import ExperimentConfig, MissionConfig
from interllm.planners.candidates import generate_initial_candidates
from interllm.planners.runner import run_mission
from interllm.planning.domain import State, plan_from_list
from interllm.planning.feasibility import check_plan

pytest.importorskip("mujoco")
generator = pytest.importorskip("interllm.scene.generator")
missions_mod = pytest.importorskip("interllm.scene.missions")
catalog = pytest.importorskip("interllm.scene.catalog")


@pytest.fixture(scope="module")
def tiny():
    scene = generator.generate_scene(catalog.scene_config("tiny", seed=0), 0)
    mission = missions_mod.generate_missions(scene, MissionConfig(n_missions=1, commands_per_mission=2), 0.25)[0]
    return scene, mission


@pytest.mark.parametrize("name", ["inter_llm", "sayplan", "moma_llm"])
def test_each_planner_on_the_real_world(tiny, name):
    scene, mission = tiny
    cfg = ExperimentConfig()
    cfg.mission.commands_per_mission = 2
    client = FakeScoreClient()
    cands = generate_initial_candidates(scene, mission, client, cfg)
    start = State(mission.start_furniture, scene.furniture[mission.start_furniture].room)
    for plans in cands.values():
        assert all(check_plan(plan_from_list(p), scene, start).valid for p in plans)
    rec = run_mission(name, scene, mission, cands, client, cfg, None)
    json.dumps(rec)
    assert len(rec["commands"]) == len(mission.commands)
    acts = [a for c in rec["commands"] for a in c["actions"]]
    assert acts, "nothing was executed"
    # the simulated clock is the sum of the action times, and every result is recorded in order
    assert rec["sim_time"] == pytest.approx(sum(a["time"] for a in acts))
    for c in rec["commands"]:
        for where in c["final_locations"].values():
            assert where == "held" or where in scene.furniture
    if name == "inter_llm":
        assert all(len(c["summary"]["estimated_costs"]) == len(c["summary"]["candidates"])
                   for c in rec["commands"])


@pytest.mark.embedded
def test_inter_llm_with_the_real_embedded_model_on_one_command(tiny, tmp_path):
    llm = pytest.importorskip("interllm.llm")
    scene, mission = tiny
    mission = type(mission)(mission.id, mission.scene_id, mission.start, mission.start_furniture,
                            mission.commands[:1])
    cfg = ExperimentConfig()
    cfg.llm.cache_dir = str(tmp_path / "cache")
    client = llm.make_client(cfg.llm)
    cands = generate_initial_candidates(scene, mission, client, cfg)
    cmd = mission.commands[0]
    assert len(cands[cmd.id]) == cfg.planner.M
    rec = run_mission("inter_llm", scene, mission, cands, client, cfg, None)
    s = rec["commands"][0]["summary"]
    assert s["candidates"] and len(s["estimated_costs"]) == len(s["candidates"])
    assert rec["commands"][0]["actions"]
