"""Names in the config that must be registered implementations: planners, the LLM backend, the
proposal and cost-inference modes. Checked at composition (pipeline.params, pipeline.run) and
by each stage before it uses them, so an unknown name fails before any output is written."""

from __future__ import annotations

from interllm.config import ExperimentConfig
from interllm.llm.backend import BACKENDS
from interllm.planners import PLANNERS
from interllm.planning.proposers import COST_INFERRERS, PLAN_PROPOSERS


def check_registered(cfg: ExperimentConfig, planners: bool = True) -> None:
    """Raise ConfigError naming the key and the registered names for any unknown one."""
    BACKENDS.entry(cfg.llm.backend)
    PLAN_PROPOSERS.entry(cfg.llm.proposal_mode)
    COST_INFERRERS.entry(cfg.llm.cost_inference_mode)
    if planners:
        for name in cfg.planner.names:
            PLANNERS.entry(name)
