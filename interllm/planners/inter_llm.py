"""Inter-LLM (paper Algorithm 1): interleaved LLM and motion planning.

Per command:
1. candidates: the M shared initial candidates for the first command; for later commands M new
   candidates proposed WITH the known costs in the prompt (generate) / scoring prompts (score),
   from the current scene graph and state, excluding objects delivered by earlier commands;
2. feasibility check + bounded regeneration (planner.max_regenerations) per candidate; a
   candidate still infeasible at the bound is dropped and recorded;
3. ĉ_total of each candidate with the multimodal similarity function: presumed path of every
   navigate (from the robot's pose for the first one, else from the anchor of the previous
   furniture, via ``world.presumed_path``) compared with every navigated path (P°); manipulation
   costs inferred by the LLM from the known ones (an exact (action, state) already measured uses
   its known cost; ``planner.inter_llm.cost_encoding=expected`` adds the expected loss of the object,
   ``planning.costs.expected_failure_cost``); ĉ_total = Σ ĉ_nav + Σ ĉ_man · N_valid/N_man;
4. execute the argmin action by action (``world.execute``), updating C^known with every result;
   a failed action skips the rest of that object's actions (see ``PlannerContext.execute_plan``).
"""

from __future__ import annotations

import numpy as np

from interllm.config import InterLLMConfig
from interllm.core.actions import Action, Plan, State, apply_effects, plan_to_list
from interllm.planners.base import PLANNERS, CommandResult
from interllm.planners.context import PlannerContext
from interllm.planners.execution import execute_plan, finish, new_result
from interllm.planners.repair import check_and_repair
from interllm.planning.costs import (
    CostEstimate,
    PlanEstimate,
    encode_cost,
    estimate_navigation,
    expected_failure_cost,
    failure_chance,
    plan_total,
    unknown_manipulation_estimate,
)
from interllm.planning.memory import KnownCosts
from interllm.scene.graph import Command


def robot_xy(world) -> np.ndarray:
    return np.asarray(world.robot_pose, dtype=float).reshape(-1)[:2]


@PLANNERS.register("inter_llm", label="Inter-LLM (ours)", color="tab:green", order=2, config=InterLLMConfig)
class InterLLMPlanner:
    name = "inter_llm"

    def __init__(self, settings: InterLLMConfig | None = None) -> None:
        self.settings = settings if settings is not None else InterLLMConfig()  # planner.inter_llm

    # ---- what the known costs reach (``inter_llm_ablations`` overrides these and ``select``) ----
    def known_for_proposals(self, ctx: PlannerContext) -> KnownCosts:
        """The known costs the proposal prompts of a later command carry."""
        return ctx.memory

    def known_for(self, action: Action, state: State, ctx: PlannerContext) -> KnownCosts:
        """The known costs an estimate of ``action`` in ``state`` may draw on: all of them, so a cost
        carries over to similar paths (navigation) and similar actions (the LLM's inference)."""
        return ctx.memory

    # ---- proposals ----------------------------------------------------------------------
    def propose(self, command: Command, ctx: PlannerContext) -> tuple[list[Plan], str]:
        """The command's candidates and where they come from: the shared initial candidates
        (first command) or proposed now from the current state and the known costs."""
        return ctx.candidates(command, known=self.known_for_proposals(ctx))

    # ---- estimation ---------------------------------------------------------------------
    def estimate(self, plan: Plan, command: Command, ctx: PlannerContext, paths: dict, labels: dict,
                 result: CommandResult) -> PlanEstimate:
        world, cfg = ctx.world, self.settings
        state: State = world.state
        prev = None  # previous furniture (None: start from the robot's pose)
        nav: list[CostEstimate] = []
        man: list[CostEstimate] = []
        for a in plan:
            if a.kind == "navigate":
                key = (prev, a.furniture)
                if key not in paths:
                    start = robot_xy(world) if prev is None else world.anchor(prev)
                    paths[key] = world.presumed_path(start, a.furniture)
                est, src = estimate_navigation(paths[key], self.known_for(a, state, ctx), cfg.epsilon_d,
                                               cfg.nav_estimate, ctx.base_speed)
                nav.append(CostEstimate(str(a), "navigate", est, src))
                prev = a.furniture
                state = apply_effects(a, state, world.scene.furniture_rooms)
                continue
            man.append(self._manipulation_estimate(a, state, command, ctx, labels, result))
            if prev is None:
                prev = state.at_furniture
            state = apply_effects(a, state, world.scene.furniture_rooms)
        total = plan_total([e.estimate for e in nav], [e.estimate for e in man], [e.valid for e in man])
        return PlanEstimate(total, nav, man)

    def _manipulation_estimate(self, a, state: State, command: Command, ctx: PlannerContext, inferences: dict,
                               result: CommandResult) -> CostEstimate:
        """ĉ_man of one pickup or place in ``state``: its known cost when the (action, state) pair was
        measured, else the LLM's inferred class decoded (once per pair; ``inferences`` memoises),
        with ``planner.inter_llm.cost_encoding=expected`` plus the expected loss of the object."""
        cfg, mem = self.settings, self.known_for(a, state, ctx)
        rec = mem.manipulation_record(a, state)
        if rec is not None:
            est = CostEstimate(str(a), a.kind, rec.cost, "known", encode_cost(rec.cost), True)
            p_fail = failure_chance(est.label, cfg.hard_failure_prob, known_failed=rec.failed)
        else:
            key = (str(a), state.describe())
            if key not in inferences:
                inference = ctx.infer_cost(a, command, known=mem)
                inferences[key] = inference
                result.cost_inferences.append(inference)
            inf = inferences[key]
            lab = inf.predicted
            if lab == "unknown" and cfg.nav_estimate == "prior":  # no novelty bias for manipulation either
                est = CostEstimate(str(a), a.kind, unknown_manipulation_estimate(a.kind, mem), "prior", lab, True)
            else:
                est = CostEstimate(str(a), a.kind, inf.estimate, "llm", lab, lab != "unknown")
            p_fail = failure_chance(lab, cfg.hard_failure_prob,
                                    measured_sr=ctx.answered_success_rate(a, lab))
        if cfg.cost_encoding == "expected":
            est.estimate = expected_failure_cost(est.estimate, p_fail, ctx.gamma_obj)
        return est

    # ---- one command --------------------------------------------------------------------
    def run_command(self, command: Command, ctx: PlannerContext) -> CommandResult:
        ctx.start_command()
        result = new_result(command)
        proposed, source = self.propose(command, ctx)
        ctx.event("/planner/candidates", command, {"candidates": [plan_to_list(p) for p in proposed],
                                                   "source": source})
        feasible: list[Plan] = []
        req = ctx.request(command, known=self.known_for_proposals(ctx))
        for j, plan in enumerate(proposed):
            ok = check_and_repair(ctx, req, plan, result, index=j, max_rounds=ctx.cfg.max_regenerations)
            if ok is not None:
                feasible.append(ok)
        result.candidates = feasible
        if not feasible:
            result.notes.append("no feasible candidate: nothing executed for this command")
            return finish(ctx, result)
        best = self.select(feasible, command, ctx, result)
        result.selected_plan = feasible[best]
        ctx.event("/planner/selected", command, {
            "index": best, "plan": plan_to_list(feasible[best]),
            "estimate": result.estimated_costs[best] if result.estimated_costs else None})
        execute_plan(ctx, command, feasible[best], result)
        return finish(ctx, result)

    def select(self, feasible: list[Plan], command: Command, ctx: PlannerContext, result: CommandResult) -> int:
        """Estimate ĉ_total of every feasible candidate (recorded on ``result`` and the run log) and
        return the index of the lowest (ties: the first)."""
        paths: dict = {}
        labels: dict = {}
        estimates = [self.estimate(p, command, ctx, paths, labels, result) for p in feasible]
        result.estimated_costs = [e.total for e in estimates]
        ctx.event("/planner/estimates", command, {"estimates": [e.to_dict() for e in estimates]})
        return min(range(len(estimates)), key=lambda i: (estimates[i].total, i))
