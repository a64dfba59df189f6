"""How many MuJoCo measurements the ``optimal`` reference makes per command on scene=huge (seed 0,
110 rooms), and how long they take on this machine: its best-first search against the obvious
alternative, measuring every pickable instance's places on its ``MAX_TARGETS`` nearest targets
(what the previous lazy rule came to without the manipulation floor), each on its own world.

    .venv/bin/python benchmarks/bench_optimal_huge.py [--alternative]

Distinct measurements per command, budget 12, measured 2026-12-04 on 2 shared cores: best-first
breakfast 272 (12.0 s), meeting 438 (25.7 s), reading 535 (43.3 s); the alternative breakfast
2,023 (57.0 s), meeting 2,423 (88.1 s), reading stopped. The floor is the 12 kept instances' own
pickup and 8 places each, 108 per command: best-first measures 2.5x to 5x that.
"""

from __future__ import annotations

import argparse
import time

from interllm.config import ExperimentConfig, MissionConfig
from interllm.planners.context import PlannerContext
from interllm.planners.optimal import MAX_OBJECTS, OptimalPlanner
from interllm.planning.memory import KnownCosts
from interllm.record.api import NullRecorder
from interllm.scene.catalog import scene_config
from interllm.scene.generator import generate_scene
from interllm.scene.missions import generate_missions
from interllm.sim.world import World


def every_instance(planner: OptimalPlanner, command, ctx) -> list:
    """The alternative: every instance's pickup, then places on its nearest accepting targets."""
    targets = [t for t in command.goal.target_furniture if t in ctx.world.scene.furniture]
    return [d for oid in planner.instances(command, ctx, targets)
            for d in planner.measured_deliveries(oid, targets, ctx)]


def main(alternative: bool) -> None:
    cfg = ExperimentConfig()
    t0 = time.perf_counter()
    scene = generate_scene(scene_config("huge"), 0)
    mission = generate_missions(scene, MissionConfig(n_missions=1), cfg.sim.robot_radius)[0]
    print(f"house generated: {time.perf_counter() - t0:.1f} s", flush=True)
    for command in mission.commands:
        world = World(scene, cfg.sim, cfg.scene.grid_resolution)
        world.reset(mission)
        ctx = PlannerContext(world=world, proposer=None, memory=KnownCosts(), recorder=NullRecorder(),  # type: ignore[arg-type]
                             cfg=cfg.planner, mission=mission, planner="optimal")
        planner = OptimalPlanner()
        nav = planner.nav_costs(ctx)
        t = time.perf_counter()
        if alternative:
            options = every_instance(planner, command, ctx)
        else:
            options = planner.options(command, ctx, nav, MAX_OBJECTS)
        instances = sum(o.category in command.goal.categories for o in scene.objects.values())
        print(f"{'every instance' if alternative else 'best-first'} {command.id}: {instances} instances, "
              f"{len(command.goal.target_furniture)} targets, {len({d.obj for d in options})} kept, "
              f"{len(world._measured)} measurements, {time.perf_counter() - t:.1f} s", flush=True)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--alternative", action="store_true",
                    help="measure every pickable instance on its nearest targets instead")
    main(ap.parse_args().alternative)
