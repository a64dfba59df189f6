"""Planners behind one registry (``PLANNERS``, filled by each planner's decorator):
``PLANNERS.get(name)()`` -> a planner with ``run_command(command, ctx)``."""

from interllm.planners import inter_llm, moma_llm, nothing, optimal, sayplan  # noqa: F401  (each registers its planner)
from interllm.planners.base import PLANNERS, CommandResult, Planner
from interllm.planners.inter_llm import InterLLMPlanner
from interllm.planners.moma_llm import MoMaLLMPlanner
from interllm.planners.sayplan import SayPlanPlanner

__all__ = ["PLANNERS", "CommandResult", "Planner", "InterLLMPlanner", "MoMaLLMPlanner", "SayPlanPlanner"]
