"""The ``optimal`` reference: ground-truth costs, searched exhaustively, executed in the simulator.

Per command it reads what no real planner knows: the goal's categories and target furniture, and
the simulator's scratch measurement of every pickup and place (``WorldView.measure_manipulation``,
the N_l-trial measurement Table II judges against). It then takes the cheapest assignment of
distinct reachable instances to the command's slots and targets (``planning.assignment``: most
deliveries first, then the least summed cost), with navigation costed by the presumed path on the
robot's map (c_nav with no collision: length/base_speed + length), and executes it with the rule
every planner shares. After an execution failure it searches again from the current state without
the failed object (at most ``n_objects`` times per command).

Instances: objects of a requested category, not already on a goal target, not delivered by an
earlier command; a pickup or place whose measured success rate is 0 is not an option. Places are
measured in the layout as it is when the search runs (a target that fills up shows at execution,
and the search then runs again). The report places every planner between ``nothing`` (0) and this
reference (1). It calls no LLM.
"""

from __future__ import annotations

import math
from typing import Optional

import numpy as np

from interllm.core.actions import Action, Plan
from interllm.core.results import ActionResult
from interllm.planners.base import PLANNERS, CommandResult
from interllm.planners.context import PlannerContext
from interllm.planners.execution import execute_plan, finish, new_result
from interllm.planning.assignment import Delivery, cheapest_assignment
from interllm.planning.costs import path_length
from interllm.planning.plans import assemble_deliveries
from interllm.scene.graph import Command

START = "@robot"  # the robot's current pose as a search location
MAX_OBJECTS = 12  # the search is exact over this many objects cheapest to deliver alone


@PLANNERS.register("optimal", label="Optimal (reference)", color="k", order=4, reference=True)
class OptimalPlanner:
    name = "optimal"

    def run_command(self, command: Command, ctx: PlannerContext) -> CommandResult:
        ctx.start_command()
        result = new_result(command)
        plan = self.search(command, ctx, set())
        result.candidates = [plan] if plan else []
        result.selected_plan = plan
        if not plan:
            result.notes.append("optimal: no deliverable instance of the command's categories")
            return finish(ctx, result)
        failed: set[str] = set()
        replans = [0]

        def replanner(res: Optional[ActionResult], text: str, action: Action, delivered: list[str]) -> Optional[Plan]:
            if action.obj:
                failed.add(action.obj)
            if replans[0] >= ctx.n_objects(command):
                return None
            replans[0] += 1
            result.replans += 1
            return self.search(command, ctx, failed)

        execute_plan(ctx, command, plan, result, replanner=replanner)
        return finish(ctx, result)

    def search(self, command: Command, ctx: PlannerContext, failed: set[str]) -> Plan:
        """The plan of the cheapest assignment for the rest of ``command`` from the current state."""
        world = ctx.world
        n = ctx.n_objects(command) - len(ctx.command_delivered) - (1 if world.state.holding else 0)
        options = self.options(command, ctx, failed)
        nav = self.nav_costs(ctx)
        start = world.state.at_furniture or START
        chosen, _ = cheapest_assignment(start, options, max(n, 0), nav, MAX_OBJECTS)
        return self.plan_of(ctx, chosen)

    def options(self, command: Command, ctx: PlannerContext, failed: set[str]) -> list[Delivery]:
        """Every (instance, target) whose pickup and place the simulator measures as possible."""
        world = ctx.world
        scene, goal = world.scene, command.goal
        targets = [t for t in goal.target_furniture if t in scene.furniture]
        wanted = set(goal.categories)
        out = []
        for oid in sorted(scene.objects):
            o = scene.objects[oid]
            if (o.category not in wanted or o.furniture in targets or oid in ctx.delivered or oid in failed
                    or oid in ctx.command_delivered or oid == world.state.holding or o.furniture not in scene.furniture):
                continue
            pick = world.measure_manipulation(Action("pickup", o.furniture, obj=oid))
            if pick is None or pick.success_rate <= 0:
                continue
            for t in targets:
                place = world.measure_manipulation(Action("place", t, obj=oid))
                if place is not None and place.success_rate > 0:
                    out.append(Delivery(oid, o.furniture, t, float(pick.cost), float(place.cost)))
        return out

    def nav_costs(self, ctx: PlannerContext):
        """nav(from, to): c_nav of the presumed path with no collision (length/base_speed + length)."""
        world = ctx.world
        memo: dict[tuple[str, str], float] = {}
        robot = np.asarray(world.robot_pose, dtype=float)[:2]

        def nav(a: str, b: str) -> float:
            if a == b:
                return 0.0
            if (a, b) not in memo:
                start = robot if a == START else world.anchor(a)
                path = world.presumed_path(start, b)
                length = path_length(path) if path is not None else math.inf
                memo[(a, b)] = length / ctx.base_speed + length
            return memo[(a, b)]
        return nav

    def plan_of(self, ctx: PlannerContext, chosen: list[Delivery]) -> Plan:
        """navigate -> pickup -> navigate -> place per delivery; an object in hand is first put on
        the first delivery's target (``planning.plans.assemble_deliveries``)."""
        return assemble_deliveries(ctx.world.scene, ctx.world.state, [(d.obj, d.target) for d in chosen])
