"""SayPlan baseline (Rana et al. 2023) as the paper describes it.

Plans from semantics alone: the shared initial candidates (with ``planner.fair_baselines``, for
commands after the first: M candidates proposed from the current state, without known costs) are
taken in order; each is checked
against the symbolic scene-graph simulator (``planning.feasibility``) and replanned from its
violation feedback up to ``planner.sayplan.max_iterations`` rounds; the first feasible one is
executed open-loop. No execution costs are used, and there is no replanning after an execution
failure (the failed object's remaining actions are skipped, as for every planner).
"""

from __future__ import annotations

from interllm.config import SayPlanConfig
from interllm.planners.base import PLANNERS, CommandResult
from interllm.planners.context import PlannerContext
from interllm.planners.execution import execute_plan, finish, open_baseline_command
from interllm.scene.graph import Command


@PLANNERS.register("sayplan", label="SayPlan", color="tab:red", order=0, config=SayPlanConfig)
class SayPlanPlanner:
    name = "sayplan"

    def __init__(self, settings: SayPlanConfig | None = None) -> None:
        self.settings = settings if settings is not None else SayPlanConfig()  # planner.sayplan

    def run_command(self, command: Command, ctx: PlannerContext) -> CommandResult:
        result, selected = open_baseline_command(ctx, command, max_rounds=self.settings.max_iterations,
                                                 note_no_candidates=True)
        if selected is not None:
            execute_plan(ctx, command, selected, result)
        return finish(ctx, result)
