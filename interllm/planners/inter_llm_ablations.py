"""Inter-LLM with one part of its mechanism removed at a time, on the same candidates and missions
(issue #38): what each part of learning action costs from execution is worth.

- ``inter_llm_no_learning``: no known cost is kept from one command to the next (each command starts
  from an empty C^known), so proposals carry no known costs and every estimate comes from priors:
  the presumed path's length for navigation, the LLM's class without known examples for
  manipulation.
- ``inter_llm_no_cost_choice``: candidates are proposed and repaired as Inter-LLM's are, known costs
  in the prompts included, but none is estimated: the first feasible candidate (the proposer's own
  ranking) is executed.
- ``inter_llm_no_carry_over``: known costs are used only for the identical action in the identical
  state (C^known restricted to that pair, ``KnownCosts.only``); nothing carries over to similar
  paths or similar actions, and proposals carry no known costs.

Each is registered with ``ablates="inter_llm"``: the report pairs it against full Inter-LLM on the
missions both ran (``metrics.mechanism``), and it reads Inter-LLM's settings (``planner.inter_llm``),
so the pair differs in the removed part alone.
"""

from __future__ import annotations

from interllm.config import InterLLMConfig
from interllm.core.actions import Action, Plan, State
from interllm.planners.base import PLANNERS, CommandResult
from interllm.planners.context import PlannerContext
from interllm.planners.inter_llm import InterLLMPlanner
from interllm.planning.memory import KnownCosts
from interllm.scene.graph import Command


@PLANNERS.register("inter_llm_no_learning", label="Inter-LLM − learning", color="tab:olive", order=5,
                   ablates="inter_llm", config=InterLLMConfig)
class NoLearningPlanner(InterLLMPlanner):
    name = "inter_llm_no_learning"

    def run_command(self, command: Command, ctx: PlannerContext) -> CommandResult:
        ctx.memory = KnownCosts()  # forget what earlier commands measured
        return super().run_command(command, ctx)


@PLANNERS.register("inter_llm_no_cost_choice", label="Inter-LLM − cost choice", color="tab:cyan", order=6,
                   ablates="inter_llm", config=InterLLMConfig)
class NoCostChoicePlanner(InterLLMPlanner):
    name = "inter_llm_no_cost_choice"

    def select(self, feasible: list[Plan], command: Command, ctx: PlannerContext, result: CommandResult) -> int:
        """The first feasible candidate, unestimated."""
        return 0


@PLANNERS.register("inter_llm_no_carry_over", label="Inter-LLM − carry-over", color="tab:purple", order=7,
                   ablates="inter_llm", config=InterLLMConfig)
class NoCarryOverPlanner(InterLLMPlanner):
    name = "inter_llm_no_carry_over"

    def known_for_proposals(self, ctx: PlannerContext) -> KnownCosts:
        return KnownCosts()  # a fresh, empty one: nothing a caller could write to is shared across missions

    def known_for(self, action: Action, state: State, ctx: PlannerContext) -> KnownCosts:
        return ctx.memory.only(action, state)
