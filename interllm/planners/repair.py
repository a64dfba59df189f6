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
from interllm.planning.request import PlanRequest
from interllm.scene.graph import Command


def check_and_repair(ctx: PlannerContext, req: PlanRequest, plan: Plan, result: CommandResult, *, index: int,
                     max_rounds: int) -> Optional[Plan]:
    """``plan`` once feasible in ``req``'s scene graph and state, repaired by the proposer for ``req``
    at most ``max_rounds`` times; None = dropped at the bound.

    index: the candidate's number (for the log and the repair's sampling); ``req`` (built by
    ``ctx.request``) carries what the repairs show and avoid: the known costs (Inter-LLM), the
    objects and targets to avoid and the number of objects to deliver.
    """
    command = req.command
    for rnd in range(max_rounds + 1):
        report = check_plan(plan, req.scene, req.state)
        ctx.event("/planner/feasibility", command, {"candidate": index, "round": rnd,
                                                    "plan": plan_to_list(plan), **report.to_dict()})
        if report.valid:
            return plan
        if rnd == max_rounds:
            break
        result.regenerations += 1
        plan = ctx.proposer.plans.repair(req, plan, report, round_index=rnd, candidate=index)
    result.dropped_candidates += 1
    result.notes.append(f"candidate {index} dropped: still infeasible after {max_rounds} regenerations")
    return None


def first_feasible(ctx: PlannerContext, command: Command, proposed: list[Plan], max_rounds: int,
                   result: CommandResult) -> Optional[Plan]:
    """The first candidate that passes the feasibility checker within ``max_rounds`` repairs
    (SayPlan's and MoMa-LLM's selection); logs it on /planner/selected. None if none does."""
    req = ctx.request(command)
    for j, plan in enumerate(proposed):
        ok = check_and_repair(ctx, req, plan, result, index=j, max_rounds=max_rounds)
        if ok is not None:
            result.candidates = [ok]
            ctx.event("/planner/selected", command, {"index": j, "plan": plan_to_list(ok)})
            return ok
    return None
