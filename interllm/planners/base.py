"""The planner interface, its result and the planner registry.

A planner turns one command into executed actions: it receives the shared initial candidates
(made once in the ``candidates`` stage), and through a :class:`~interllm.planners.context.PlannerContext`
the world (:class:`~interllm.planners.world_view.WorldView`), the proposer (the LLM, one
implementation per mode), the known-cost memory, the recorder and its config (``PlannerConfig``).

Adding a planner: one module with a class decorated ``@PLANNERS.register("<name>", label="<Name>")``
that has ``run_command(command, ctx) -> CommandResult``, imported by ``interllm/planners/__init__.py``,
and one config file ``conf/planner/<name>.yaml`` (see the README's "Adding a planner").
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

from interllm.core.actions import Plan
from interllm.core.records import CommandSummary, CostInference
from interllm.core.results import ActionResult
from interllm.registry import Registry
from interllm.scene.graph import Command

PLANNERS: Registry = Registry("planner", "planner.names")


@dataclass
class CommandResult:
    command_id: str
    selected_plan: Plan
    candidates: list[Plan]  # after feasibility repair (dropped candidates excluded)
    estimated_costs: list[float]  # per candidate (empty for planners that do not estimate)
    actions: list[ActionResult]  # executed, in order (replans included)
    dropped_candidates: int = 0  # hit the regeneration bound
    regenerations: int = 0
    replans: int = 0
    llm_calls: int = 0
    llm_tokens_in: int = 0
    llm_tokens_out: int = 0
    notes: list[str] = field(default_factory=list)
    # Manipulation-cost inferences made while estimating (Inter-LLM); the metrics join them with
    # executed actions for the paper's Table II accuracy.
    cost_inferences: list[CostInference] = field(default_factory=list)

    def summary(self) -> CommandSummary:
        return CommandSummary(self.command_id, self.selected_plan, list(self.candidates),
                              [float(c) for c in self.estimated_costs], self.dropped_candidates,
                              self.regenerations, self.replans, self.llm_calls, self.llm_tokens_in,
                              self.llm_tokens_out, list(self.notes), list(self.cost_inferences))


class Planner(Protocol):
    name: str

    def run_command(self, command: Command, ctx: Any) -> CommandResult: ...
