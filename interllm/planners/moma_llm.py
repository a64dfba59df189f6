"""MoMa-LLM baseline (Honerkamp et al. 2024) as the paper describes it.

Closed-loop without cost look-ahead: executes the first feasible shared initial candidate (with
``planner.fair_baselines``, for commands after the first: of M candidates proposed from the current
state, without known costs) after the bounded feasibility repair (planner.max_regenerations). After an execution failure (pickup
failing on every sampled pose, blocked path, action not executable) it asks the proposer to
replan the rest of the command from the failure text, at most ``planner.moma_max_replans`` times
per command, excluding the failed object (pickup or navigation to it failed) or the failed target
(navigation to it or placing failed). The target of the plan being executed is kept unless it
failed (in score mode every other furniture is excluded as a target; the generate-mode prompt
carries the failure text and the excluded objects).
"""

from __future__ import annotations

from typing import Optional

from interllm.core.actions import Action, Plan, plan_to_list
from interllm.core.results import ActionResult
from interllm.planners.base import PLANNERS, CommandResult
from interllm.planners.context import PlannerContext
from interllm.planners.execution import execute_plan, finish, new_result
from interllm.planners.repair import check_and_repair, first_feasible
from interllm.planning.proposers import Exclusions
from interllm.scene.graph import Command


@PLANNERS.register("moma_llm", label="MoMa-LLM", color="tab:blue", order=1)
class MoMaLLMPlanner:
    name = "moma_llm"

    def run_command(self, command: Command, ctx: PlannerContext) -> CommandResult:
        ctx.start_command()
        result = new_result(command)
        proposed, source = ctx.baseline_candidates(command)
        ctx.event("/planner/candidates", command, {"candidates": [plan_to_list(p) for p in proposed],
                                                   "source": source})
        selected = first_feasible(ctx, command, proposed, ctx.cfg.max_regenerations, result)
        if selected is None:
            result.notes.append("no feasible candidate: nothing executed for this command")
            return finish(ctx, result)
        result.selected_plan = selected
        n_total = ctx.n_objects(command)
        failed_objects: set[str] = set()
        failed_targets: set[str] = set()

        def replanner(res: Optional[ActionResult], text: str, action: Action,
                      delivered: list[str]) -> Optional[Plan]:
            if result.replans >= ctx.cfg.moma_max_replans:
                result.notes.append(f"replan bound ({ctx.cfg.moma_max_replans}) reached")
                return None
            world = ctx.world
            if action.kind == "place" or (action.kind == "navigate" and world.state.holding is not None):
                failed_targets.add(action.furniture)
            elif action.obj:
                failed_objects.add(action.obj)
            else:  # a navigate to the pickup furniture failed: its objects are out of reach
                failed_objects.update(o.id for o in world.scene.objects_on(action.furniture))
            result.replans += 1
            remaining = max(n_total - len(delivered), 0)
            excluded = sorted(set(ctx.delivered) | set(delivered) | failed_objects)
            executed = [str(r.action) + (" ok" if r.success else " FAILED") for r in result.actions]
            if remaining == 0:
                return None
            # keep the target of the plan being executed unless that target failed
            targets = [a.furniture for a in result.selected_plan if a.kind == "place"]
            keep = targets[-1] if targets and targets[-1] not in failed_targets else None
            ex_t = sorted(f for f in world.scene.furniture if f != keep) if keep else sorted(failed_targets)
            plan = ctx.proposer.plans.replan(world.scene, world.state, command, remaining, executed=executed,
                                             failure=text, exclude=Exclusions(tuple(excluded), tuple(ex_t)),
                                             attempt=result.replans,
                                             seed=ctx.seed("replan", command.id, result.replans),
                                             context=ctx.labels(command))
            ctx.event("/planner/candidates", command, {"candidates": [plan_to_list(plan)],
                                                       "source": f"replan {result.replans}",
                                                       "failure": text})
            return check_and_repair(ctx, command, plan, 100 + result.replans, ctx.cfg.max_regenerations, result,
                                    exclude=Exclusions(tuple(excluded), tuple(sorted(failed_targets))),
                                    n_objects=remaining)

        execute_plan(ctx, command, selected, result, replanner)
        return finish(ctx, result)
