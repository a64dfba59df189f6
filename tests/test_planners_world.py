"""Planners end to end on the real MuJoCo World (tiny generated scene), fake and real LLM."""

import json
import re

import pytest
from helpers.planners import FakeScoreClient
from helpers.recording import rerun_cli, run_cli

from interllm.cli import _main as cli_main
from interllm.config import ExperimentConfig, MissionConfig
from interllm.core.actions import State, plan_from_list
from interllm.llm import make_client
from interllm.metrics.compute import Gammas, mission_rows, run_log_object_rows
from interllm.planners.candidates import generate_initial_candidates
from interllm.planners.runner import run_mission
from interllm.planning.feasibility import check_plan
from interllm.record import McapRecorder, read_run
from interllm.scene import catalog, generator
from interllm.scene import missions as missions_mod
from interllm.sim.kinematics import RobotKinematics
from interllm.sim.world import World
from interllm.stages.missions import command_results_logger


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
    rec = run_mission(name, World(scene, cfg.sim), mission, cands, client, cfg).to_dict()
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
    scene, mission = tiny
    mission = type(mission)(mission.id, mission.scene_id, mission.start, mission.start_furniture,
                            mission.commands[:1])
    cfg = ExperimentConfig()
    cfg.llm.cache_dir = str(tmp_path / "cache")
    client = make_client(cfg.llm)
    cands = generate_initial_candidates(scene, mission, client, cfg)
    cmd = mission.commands[0]
    assert len(cands[cmd.id]) == cfg.planner.M
    rec = run_mission("inter_llm", World(scene, cfg.sim), mission, cands, client, cfg)
    s = rec.commands[0].summary
    assert s.candidates and len(s.estimated_costs) == len(s.candidates)
    assert rec.commands[0].actions


def test_run_log_has_every_llm_call_and_the_results_the_metrics_come_from(tiny, tmp_path):
    """The mission's MCAP holds one /llm/calls event per counted call and, at the end of each
    command, that command's executed result; the per-object metric rows a replay computes from
    them are exactly the aggregate stage's."""

    scene, mission = tiny
    cfg = ExperimentConfig()
    cfg.mission.commands_per_mission = 2
    client = FakeScoreClient()
    cands = generate_initial_candidates(scene, mission, client, cfg)
    paths = []
    meta = {"planner": "inter_llm", "scene": scene.id, "mission": mission.id, "config": {"seed": 0}}
    for i in range(2):
        paths.append(tmp_path / f"run{i}.mcap")
        with McapRecorder(paths[-1], scene, meta, robot=RobotKinematics(cfg.sim)) as rec:
            record = run_mission("inter_llm", World(scene, cfg.sim), mission, cands, FakeScoreClient(), cfg,
                                 recorder=rec, on_command_end=command_results_logger(rec))
    assert paths[0].read_bytes() == paths[1].read_bytes()  # same inputs, same bytes
    run = read_run(paths[0])
    calls = run.events["/llm/calls"]
    assert len(calls) == sum(c.summary.llm_calls for c in record.commands) > 0
    assert all(p["key"] and p["kind"] in ("score", "complete") and p["purpose"] for _, p in calls)
    assert [t for t, _ in calls] == sorted(t for t, _ in calls)
    # the run log's results are the record's, command by command, each at the end of its command
    logged = run.command_records()
    assert json.loads(json.dumps([c.to_dict() for _, c in logged])) == \
        json.loads(json.dumps([c.to_dict() for c in record.commands]))
    clock, ends = 0.0, []
    for c in record.commands:
        clock += sum(a.time for a in c.actions)
        ends.append(clock)
    assert [t for t, _ in logged] == pytest.approx(ends)
    # and the rows computed from them are the aggregate stage's
    scene_map = {"category": {o.id: o.category for o in scene.objects.values()},
                 "furniture": {o.id: o.furniture for o in scene.objects.values()}}
    rows, _, mission_row = mission_rows(record, scene_map, Gammas.from_config(cfg))
    replayed = run_log_object_rows(run)
    assert [r for _, r in replayed] == rows
    assert replayed[-1][1]["m_overall_cum"] == pytest.approx(mission_row["m_overall"])
    if rerun_cli() is not None:  # `interllm replay` plots them: one point per object
        rrd = tmp_path / "run0.rrd"
        assert cli_main(["replay", str(paths[0]), "--save", str(rrd)]) == 0
        printed = run_cli("rrd", "print", str(rrd)).stdout
        n = sum(int(m.group(1)) for m in re.finditer(r"with (\d+) rows \([^)]*\) - /metrics/m_overall_cum - ", printed))
        assert n == len(rows)
