"""Planners behind one registry: ``get(name)()`` -> planner with ``run_command(command, ctx)``."""

from interllm.planners.base import CommandResult, Planner, get, names, register
from interllm.planners.inter_llm import InterLLMPlanner
from interllm.planners.moma_llm import MoMaLLMPlanner
from interllm.planners.sayplan import SayPlanPlanner

__all__ = ["CommandResult", "Planner", "get", "names", "register", "InterLLMPlanner", "MoMaLLMPlanner",
           "SayPlanPlanner"]

for _name, _cls in (("inter_llm", InterLLMPlanner), ("sayplan", SayPlanPlanner), ("moma_llm", MoMaLLMPlanner)):
    if _name not in names():
        register(_name, _cls)
