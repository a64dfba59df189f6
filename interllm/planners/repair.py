"""Feasibility check and bounded repair of candidates (paper §IV-A), shared by the planners.

``check_and_repair`` checks a plan with the symbolic feasibility checker and, while it is
infeasible, asks the proposer for a repaired one (the violation texts are fed back in generate
mode; the deliveries are re-assembled in score mode), at most ``max_rounds`` times; a candidate
still infeasible at the bound is dropped (None) and recorded. Every round is logged on
``/planner/feasibility``.
"""

from __future__ import annotations

from typing import Optional

from interllm.core.actions import Plan, plan_to_list
from interllm.planners.base import CommandResult
from interllm.planners.context import PlannerContext
from interllm.planning.feasibility import check_plan
from interllm.planning.memory import KnownCosts
from interllm.planning.proposers import Exclusions
from interllm.scene.graph import Command


def check_and_repair(ctx: PlannerContext, command: Command, plan: Plan, index: int, max_rounds: int,
                     result: CommandResult, known: Optional[KnownCosts] = None,
                     exclude: Exclusions = Exclusions(), n_objects: Optional[int] = None) -> Optional[Plan]:
    """``plan`` once feasible, repaired at most ``max_rounds`` times; None = dropped at the bound.

    index: the candidate's number (for the log and the repair's sampling); known: the costs the
    proposer may show (Inter-LLM); exclude: objects (besides the delivered ones) and targets a
    repair must avoid; n_objects: objects the plan should deliver (default: the command's).
    """
    scene, state = ctx.world.scene, ctx.world.state
    n = ctx.n_objects(command) if n_objects is None else n_objects
    avoid = Exclusions(tuple(sorted(ctx.delivered | set(exclude.objects))), exclude.targets)
    for rnd in range(max_rounds + 1):
        report = check_plan(plan, scene, state)
        ctx.event("/planner/feasibility", command, {"candidate": index, "round": rnd,
                                                    "plan": plan_to_list(plan), **report.to_dict()})
        if report.valid:
            return plan
        if rnd == max_rounds:
            break
        result.regenerations += 1
        plan = ctx.proposer.plans.repair(plan, report, scene, state, command, n, round_index=rnd, candidate=index,
                                         known=known, exclude=avoid, context=ctx.labels(command))
    result.dropped_candidates += 1
    result.notes.append(f"candidate {index} dropped: still infeasible after {max_rounds} regenerations")
    return None


def first_feasible(ctx: PlannerContext, command: Command, proposed: list[Plan], max_rounds: int,
                   result: CommandResult) -> Optional[Plan]:
    """The first candidate that passes the feasibility checker within ``max_rounds`` repairs
    (SayPlan's and MoMa-LLM's selection); logs it on /planner/selected. None if none does."""
    for j, plan in enumerate(proposed):
        ok = check_and_repair(ctx, command, plan, j, max_rounds, result)
        if ok is not None:
            result.candidates = [ok]
            ctx.event("/planner/selected", command, {"index": j, "plan": plan_to_list(ok)})
            return ok
    return None
