"""Planners behind one registry (``PLANNERS``, filled by each planner's decorator; its built-in
planners are imported on the first lookup): ``PLANNERS.get(name)()`` -> a planner with
``run_command(command, ctx)``. Names are imported from their modules on first use
(``interllm.lazy``)."""

from interllm.lazy import exports_of, lazy_exports

__all__ = ["PLANNERS", "CommandResult", "Planner", "InterLLMPlanner", "MoMaLLMPlanner", "SayPlanPlanner"]
__getattr__, __dir__ = lazy_exports(__name__, exports_of({
    "interllm.planners.base": ("PLANNERS", "CommandResult", "Planner"),
    "interllm.planners.inter_llm": ("InterLLMPlanner",),
    "interllm.planners.moma_llm": ("MoMaLLMPlanner",),
    "interllm.planners.sayplan": ("SayPlanPlanner",),
}))
