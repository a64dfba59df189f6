"""Run one planner over one mission: a fresh KnownCosts per mission that persists across its
commands; the world is reset to the mission's start. Returns the typed MissionRecord."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Optional

from interllm.config import ExperimentConfig
from interllm.core.records import CommandRecord, GoalRecord, MissionRecord
from interllm.planners.base import make_planner
from interllm.planners.candidates import candidates_from_json, initial_commands
from interllm.planners.context import LLMCallObserver, PlannerContext
from interllm.planners.world_view import WorldView
from interllm.planning.memory import KnownCosts
from interllm.planning.proposers import make_proposer
from interllm.record.api import NullRecorder
from interllm.scene.graph import Mission

CommandHook = Callable[[MissionRecord, float], None]


def run_mission(planner_name: str, world: WorldView, mission: Mission, initial_candidates: dict, client: Any,
                cfg: ExperimentConfig, *, recorder: Any = None,
                on_command_end: Optional[CommandHook] = None) -> MissionRecord:
    """One planner on one mission in ``world`` (reset to the mission's start first).

    initial_candidates: {command_id: [plan list, ...]} from ``generate_initial_candidates`` (the
    commands of ``initial_commands``);
    client: the LLM client (its calls get the run's labels and are tallied per command);
    on_command_end(record so far, simulated time [s]): called after each command (the missions
    stage logs the command's executed result with it).
    """
    planner = make_planner(planner_name, cfg.planner)
    missing = [c.id for c in initial_commands(mission, cfg) if c.id not in initial_candidates]
    if missing:
        raise ValueError(f"initial candidates lack command(s) {missing} of mission {mission.id!r}; "
                         f"rerun the candidates stage for this mission")
    recorder = recorder if recorder is not None else NullRecorder()
    world.reset(mission)
    if mission.scene_id != world.scene.id:
        raise ValueError(f"mission {mission.id!r} belongs to scene {mission.scene_id!r}, not {world.scene.id!r}")
    llm_calls = LLMCallObserver(world, recorder)
    observed = client.with_context(planner=planner_name, scene=world.scene.id, mission=mission.id) \
        .with_observer(llm_calls)
    ctx = PlannerContext(world=world, proposer=make_proposer(observed, cfg.llm, ground_truth=world),
                         memory=KnownCosts(), recorder=recorder, cfg=cfg.planner, mission=mission,
                         planner=planner_name, seed_base=cfg.llm.seed, base_speed=cfg.sim.base_speed,
                         gamma_obj=cfg.metrics.gamma_obj, llm_calls=llm_calls,
                         initial_candidates=candidates_from_json(initial_candidates))
    record = MissionRecord(planner=planner_name, scene_id=world.scene.id, mission_id=mission.id)
    for cmd in mission.commands:
        recorder.log(float(world.clock), "info", f"{planner_name} ({cfg.llm.source_label}): command {cmd.id}: {cmd.text}")
        ctx.command_delivered = []
        res = planner.run_command(cmd, ctx)
        picked: list[str] = []
        for r in res.actions:
            if r.action.kind == "pickup" and r.success and r.action.obj not in picked:
                picked.append(r.action.obj)
        final = {o: ("held" if world.state.holding == o else world.scene.objects[o].furniture) for o in picked}
        # objects placed by the plan (not put back after a failure) are not taken again later
        ctx.delivered.update(o for o in ctx.command_delivered if o)
        goal = GoalRecord(tuple(cmd.goal.categories), tuple(cmd.goal.target_furniture), int(cmd.goal.n_objects))
        record.commands.append(CommandRecord(cmd.id, cmd.text, goal, res.summary(), list(res.actions), final))
        if on_command_end is not None:
            on_command_end(record, float(world.clock))
    record.sim_time = float(world.clock)
    return record
