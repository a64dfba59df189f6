"""High-level planning: domain, feasibility checker, path similarity, known costs, cost estimation,
LLM proposals (and grid search in ``planning.search``).

Names are resolved lazily (PEP 562): ``interllm.core.results`` imports ``planning.domain``, and an
eager import of ``planning.memory`` here would be circular.
"""

import importlib

_EXPORTS = {
    "Action": "domain", "Plan": "domain", "State": "domain",
    "FeasibilityReport": "feasibility", "InfeasibleAction": "feasibility", "Violation": "feasibility",
    "apply": "feasibility", "check_plan": "feasibility",
    "path_overlap": "similarity", "KnownCosts": "memory",
    "CostEstimate": "costs", "PlanEstimate": "costs", "decode_cost": "costs", "encode_cost": "costs",
    "estimate_navigation": "costs", "plan_total": "costs",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"interllm.planning.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'interllm.planning' has no attribute {name!r}")
