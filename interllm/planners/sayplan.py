"""SayPlan baseline (Rana et al. 2023) as the paper describes it.

Plans from semantics alone: the shared initial candidates (with ``planner.fair_baselines``, for
commands after the first: M candidates proposed from the current state, without known costs) are
taken in order; each is checked
against the symbolic scene-graph simulator (``planning.feasibility``) and replanned from its
violation feedback up to ``planner.sayplan_max_iterations`` rounds; the first feasible one is
executed open-loop. No execution costs are used, and there is no replanning after an execution
failure (the failed object's remaining actions are skipped, as for every planner).
"""

from __future__ import annotations

from interllm.core.actions import plan_to_list
from interllm.planners.base import PLANNERS, CommandResult
from interllm.planners.context import PlannerContext
from interllm.planners.execution import execute_plan, finish, new_result
from interllm.planners.repair import first_feasible
from interllm.scene.graph import Command


@PLANNERS.register("sayplan", label="SayPlan", color="tab:red", order=0)
class SayPlanPlanner:
    name = "sayplan"

    def run_command(self, command: Command, ctx: PlannerContext) -> CommandResult:
        ctx.start_command()
        result = new_result(command)
        proposed, source = ctx.baseline_candidates(command)
        ctx.event("/planner/candidates", command, {"candidates": [plan_to_list(p) for p in proposed],
                                                   "source": source})
        if not proposed:
            result.notes.append(f"no initial candidates for command {command.id!r}")
            return finish(ctx, result)
        selected = first_feasible(ctx, command, proposed, ctx.cfg.sayplan_max_iterations, result)
        if selected is None:
            result.notes.append("no feasible candidate: nothing executed for this command")
            return finish(ctx, result)
        result.selected_plan = selected
        execute_plan(ctx, command, selected, result)
        return finish(ctx, result)
