"""Planner interface and registry.

A planner turns one command into executed actions. It receives the shared initial candidates
(generated once in the ``candidates`` stage), the simulated world, the cached LLM client, the
known-cost memory and a recorder, and returns a ``CommandResult``.

Adding a planner: one module defining a class with ``name`` and ``run_command``, one
``register`` line (see the bottom of ``interllm/planners/__init__.py``) and one config file
``conf/planner/<name>.yaml``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

from interllm.core.actions import Plan, plan_to_list
from interllm.core.results import ActionResult
from interllm.scene.graph import Command


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
    # Manipulation-cost inferences made while estimating (Inter-LLM): one dict per inferred
    # action: {"action": str(Action), "predicted": "easy|medium|hard|unknown", "estimate": float}.
    # The metrics join them with executed actions for the paper's Table II accuracy.
    cost_inferences: list[dict] = field(default_factory=list)

    def summary(self) -> dict[str, Any]:
        return {
            "command_id": self.command_id,
            "selected_plan": plan_to_list(self.selected_plan),
            "candidates": [plan_to_list(p) for p in self.candidates],
            "estimated_costs": [float(c) for c in self.estimated_costs],
            "dropped_candidates": self.dropped_candidates,
            "regenerations": self.regenerations,
            "replans": self.replans,
            "llm_calls": self.llm_calls,
            "llm_tokens_in": self.llm_tokens_in,
            "llm_tokens_out": self.llm_tokens_out,
            "notes": list(self.notes),
            "cost_inferences": list(self.cost_inferences),
        }


class Planner(Protocol):
    name: str

    def run_command(self, command: Command, ctx: Any) -> CommandResult: ...


_REGISTRY: dict[str, Callable[..., Planner]] = {}


def register(name: str, factory: Callable[..., Planner]) -> None:
    if name in _REGISTRY:
        raise ValueError(f"planner {name!r} is registered twice")
    _REGISTRY[name] = factory


def names() -> list[str]:
    return sorted(_REGISTRY)


def get(name: str) -> Callable[..., Planner]:
    try:
        return _REGISTRY[name]
    except KeyError:
        raise KeyError(f"unknown planner {name!r}; registered planners: {names()}") from None
