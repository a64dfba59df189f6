"""MoMa-LLM baseline (Honerkamp et al. 2024) as the paper describes it.

Closed-loop without cost look-ahead: executes the first feasible shared initial candidate (with
``planner.fair_baselines``, for commands after the first: of M candidates proposed from the current
state, without known costs) after the bounded feasibility repair (planner.max_regenerations). After an execution failure (pickup
failing on every sampled pose, blocked path, action not executable) it asks the proposer to
replan the rest of the command from the failure text, at most ``planner.moma_llm.max_replans`` times
per command, excluding the failed object (pickup or navigation to it failed) or the failed target
(navigation to it or placing failed). The target of the plan being executed is kept unless it
failed (in score mode every other furniture is excluded as a target). The model is told the
failure's text and the actions executed so far in every mode that asks one: in the generate-mode
replan prompt, and before the request of the score prompts the score-mode replan scores the
command with (docs/protocol.md).
"""

from __future__ import annotations

from typing import Optional

from interllm.config import MoMaLLMConfig
from interllm.core.actions import Action, Plan, plan_to_list
from interllm.core.results import ActionResult
from interllm.planners.base import PLANNERS, CommandResult
from interllm.planners.context import PlannerContext
from interllm.planners.execution import execute_plan, finish, open_baseline_command
from interllm.planners.repair import check_and_repair
from interllm.planning.request import Exclusions
from interllm.scene.graph import Command


@PLANNERS.register("moma_llm", label="MoMa-LLM", color="tab:blue", order=1, config=MoMaLLMConfig)
class MoMaLLMPlanner:
    name = "moma_llm"

    def __init__(self, settings: MoMaLLMConfig | None = None) -> None:
        self.settings = settings if settings is not None else MoMaLLMConfig()  # planner.moma_llm

    def run_command(self, command: Command, ctx: PlannerContext) -> CommandResult:
        result, selected = open_baseline_command(ctx, command, max_rounds=ctx.cfg.max_regenerations)
        if selected is None:
            return finish(ctx, result)
        n_total = ctx.n_objects(command)
        failed_objects: set[str] = set()
        failed_targets: set[str] = set()

        def replanner(res: Optional[ActionResult], text: str, action: Action,
                      delivered: list[str]) -> Optional[Plan]:
            if result.replans >= self.settings.max_replans:
                result.notes.append(f"replan bound ({self.settings.max_replans}) reached")
                return None
            world = ctx.world
            if action.kind == "place" or (action.kind == "navigate" and world.state.holding is not None):
                failed_targets.add(action.furniture)
            elif action.obj:
                failed_objects.add(action.obj)
            else:  # a navigate to the pickup furniture failed: its objects are out of reach
                failed_objects.update(o.id for o in world.scene.objects_on(action.furniture))
            remaining = max(n_total - len(delivered), 0)
            if remaining == 0:  # nothing left to deliver: no replan is asked for, none is counted
                return None
            result.replans += 1
            avoid = tuple(sorted(set(delivered) | failed_objects))  # ctx.request adds earlier deliveries
            executed = [str(r.action) + (" ok" if r.success else " FAILED") for r in result.actions]
            # keep the target of the plan being executed unless that target failed
            targets = [a.furniture for a in result.selected_plan if a.kind == "place"]
            keep = targets[-1] if targets and targets[-1] not in failed_targets else None
            ex_t = sorted(f for f in world.scene.furniture if f != keep) if keep else sorted(failed_targets)
            req = ctx.request(command, n_objects=remaining, avoid=Exclusions(avoid, tuple(ex_t)))
            plan = ctx.proposer.plans.replan(req, executed=executed, failure=text, attempt=result.replans,
                                             seed=ctx.seed("replan", command.id, result.replans))
            ctx.event("/planner/candidates", command, {"candidates": [plan_to_list(plan)],
                                                       "source": f"replan {result.replans}",
                                                       "failure": text})
            # its repairs may deliver to any target but a failed one
            req = ctx.request(command, n_objects=remaining, avoid=Exclusions(avoid, tuple(sorted(failed_targets))))
            return check_and_repair(ctx, req, plan, result, index=100 + result.replans,
                                    max_rounds=ctx.cfg.max_regenerations)

        execute_plan(ctx, command, selected, result, replanner)
        return finish(ctx, result)
