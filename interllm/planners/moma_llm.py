"""MoMa-LLM baseline (Honerkamp et al. 2024) as the paper describes it.

Closed-loop without cost look-ahead: executes the first feasible shared initial candidate (after
the bounded feasibility repair, planner.max_regenerations). After an execution failure (pickup
failing on every sampled pose, blocked path, action not executable) it asks the LLM to replan
the rest of the command from the failure text, at most ``planner.moma_max_replans`` times per
command. In ``generate`` mode the replan prompt carries the failure text and the excluded
objects; in ``score`` mode the replan resamples (M = 1) excluding the failed object (pickup or
navigation to it failed) or the failed target (navigation to it or placing failed).
"""

from __future__ import annotations

from typing import Optional

from interllm.core.actions import Action, Plan, plan_to_list
from interllm.core.results import ActionResult
from interllm.planners.base import CommandResult
from interllm.planners.context import PlannerContext, finish, new_result
from interllm.planning import proposals as P
from interllm.scene.graph import Command


class MoMaLLMPlanner:
    name = "moma_llm"

    def run_command(self, command: Command, ctx: PlannerContext) -> CommandResult:
        ctx.client.reset()
        result = new_result(command)
        proposed = ctx.candidates_for(command)
        ctx.event("/planner/candidates", command, {"candidates": [plan_to_list(p) for p in proposed],
                                                   "source": "initial"})
        selected = ctx.first_feasible(command, proposed, ctx.cfg.planner.max_regenerations, result)
        if selected is None:
            result.notes.append("no feasible candidate: nothing executed for this command")
            return finish(ctx, result)
        result.selected_plan = selected
        n_total = ctx.n_objects(command)
        failed_objects: set[str] = set()
        failed_targets: set[str] = set()
        executed: list[str] = []

        def replanner(res: Optional[ActionResult], text: str, action: Action,
                      delivered: list[str]) -> Optional[Plan]:
            if result.replans >= ctx.cfg.planner.moma_max_replans:
                result.notes.append(f"replan bound ({ctx.cfg.planner.moma_max_replans}) reached")
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
            executed[:] = [str(r.action) + (" ok" if r.success else " FAILED") for r in result.actions]
            if remaining == 0:
                return None
            if ctx.cfg.llm.proposal_mode == "generate":
                plan = P.replan_llm(ctx.client, world.scene, world.state, command, ctx.cfg, executed,
                                    text, remaining, excluded, result.replans, ctx.labels(command))
            else:
                # keep the target of the plan being executed unless that target failed
                targets = [a.furniture for a in result.selected_plan if a.kind == "place"]
                keep = targets[-1] if targets and targets[-1] not in failed_targets else None
                ex_t = (sorted(f for f in world.scene.furniture if f != keep) if keep
                        else sorted(failed_targets))
                plans = P.propose_by_scores(ctx.scores(command), world.scene, world.state, remaining, 1,
                                            ctx.cfg.llm.temperature, ctx.seed("replan", command.id,
                                                                             result.replans),
                                            excluded, ex_t)
                plan = plans[0] if plans else ()
            ctx.event("/planner/candidates", command, {"candidates": [plan_to_list(plan)],
                                                       "source": f"replan {result.replans}",
                                                       "failure": text})
            return ctx.check_and_repair(command, plan, 100 + result.replans,
                                        ctx.cfg.planner.max_regenerations, result,
                                        exclude_targets=tuple(sorted(failed_targets)),
                                        exclude_objects=tuple(excluded), n_objects=remaining)

        ctx.execute_plan(command, selected, result, replanner)
        return finish(ctx, result)
