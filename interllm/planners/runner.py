"""Run one planner over one mission: a fresh World and a fresh KnownCosts per mission; the memory
persists across the commands of the mission. Returns the JSON-able MissionRecord."""

from __future__ import annotations

from typing import Any, Optional

from interllm.config import ExperimentConfig
from interllm.planners.base import get
from interllm.planners.candidates import candidates_from_json
from interllm.planners.context import PlannerContext
from interllm.planning.memory import KnownCosts
from interllm.record.api import NullRecorder
from interllm.scene.graph import Mission, SceneGraph


def make_world(scene: SceneGraph, cfg: ExperimentConfig):
    from interllm.sim.world import World

    return World(scene, cfg.sim, cfg.scene.grid_resolution)


def run_mission(planner_name: str, scene: SceneGraph, mission: Mission, initial_candidates: dict,
                client: Any, cfg: ExperimentConfig, recorder: Any = None, world: Optional[Any] = None) -> dict:
    """MissionRecord: {"planner", "scene_id", "mission_id", "commands": [...], "sim_time"}.

    ``initial_candidates``: {command_id: [plan list, ...]} from ``generate_initial_candidates``.
    ``world``: an already built world (tests); default a fresh ``interllm.sim.world.World``.
    """
    if mission.scene_id != scene.id:
        raise ValueError(f"mission {mission.id!r} belongs to scene {mission.scene_id!r}, not {scene.id!r}")
    missing = [c.id for c in mission.commands if c.id not in initial_candidates]
    if missing:
        raise ValueError(f"initial candidates lack command(s) {missing} of mission {mission.id!r}; "
                         f"rerun the candidates stage for this mission")
    planner = get(planner_name)()
    recorder = recorder if recorder is not None else NullRecorder()
    world = world if world is not None else make_world(scene, cfg)
    world.reset(mission)
    labels = {"planner": planner_name, "scene": scene.id, "mission": mission.id}
    if hasattr(client, "with_context"):
        client = client.with_context(**labels)
    ctx = PlannerContext(world=world, client=client, memory=KnownCosts(), recorder=recorder, cfg=cfg,
                         mission=mission, planner=planner_name,
                         initial_candidates=candidates_from_json(initial_candidates))
    from interllm.metrics.compute import Gammas, mission_rows

    gammas = Gammas.from_config(cfg)
    scene_map = {"category": {o.id: o.category for o in scene.objects.values()},
                 "furniture": {o.id: o.furniture for o in scene.objects.values()}}
    commands = []
    for cmd in mission.commands:
        recorder.log(float(world.clock), "info", f"{planner_name}: command {cmd.id}: {cmd.text}")
        ctx.command_delivered = []
        res = planner.run_command(cmd, ctx)
        picked: list[str] = []
        for r in res.actions:
            if r.action.kind == "pickup" and r.success and r.action.obj not in picked:
                picked.append(r.action.obj)
        final = {o: ("held" if world.state.holding == o else world.scene.objects[o].furniture) for o in picked}
        # objects placed by the plan (not put back after a failure) are not taken again later
        ctx.delivered.update(o for o in ctx.command_delivered if o)
        commands.append({
            "command_id": cmd.id, "text": cmd.text,
            "goal": {"categories": list(cmd.goal.categories),
                     "target_furniture": list(cmd.goal.target_furniture),
                     "n_objects": int(cmd.goal.n_objects)},
            "summary": res.summary(),
            "actions": [r.to_record() for r in res.actions],
            "final_locations": final,
        })
        # the aggregate stage's per-object rows of this command, as they stand when it ends
        rows, cmd_rows, _ = mission_rows({"planner": planner_name, "scene_id": scene.id, "mission_id": mission.id,
                                          "commands": commands}, scene_map, gammas)
        for row in rows:
            if row["command_index"] == len(commands):
                recorder.event("/metrics/object", float(world.clock), row)
        recorder.event("/metrics/command", float(world.clock), cmd_rows[-1])
    return {"planner": planner_name, "scene_id": scene.id, "mission_id": mission.id, "commands": commands,
            "sim_time": float(world.clock)}
