"""Names in the config that must be registered implementations: planners, the LLM backend, the
proposal and cost-inference modes. Checked at composition (pipeline.params, pipeline.run) and
by each stage before it uses them, so an unknown name fails before any output is written."""

from __future__ import annotations

import difflib
import importlib

from interllm.config import ConfigError, ExperimentConfig
from interllm.llm.backend import BACKENDS
from interllm.planners import PLANNERS
from interllm.planners.base import planner_settings, settings_node
from interllm.planning.proposers import COST_INFERRERS, PLAN_PROPOSERS


def import_planner_modules(cfg: ExperimentConfig) -> None:
    """Import ``planner.modules`` (planners defined outside this package register themselves there);
    a module that cannot be imported raises ConfigError naming the key and the fix."""
    for name in cfg.planner.modules:
        try:
            importlib.import_module(name)
        except ImportError as e:
            raise ConfigError(f"config key 'planner.modules': cannot import {name!r} ({type(e).__name__}: {e}); "
                              f"put the folder that holds it on PYTHONPATH or correct the name") from None


def check_registered(cfg: ExperimentConfig, planners: bool = True) -> None:
    """Raise ConfigError naming the key and the registered names for any unknown one (after
    importing ``planner.modules``)."""
    import_planner_modules(cfg)
    BACKENDS.entry(cfg.llm.backend)
    PLAN_PROPOSERS.entry(cfg.llm.proposal_mode)
    COST_INFERRERS.entry(cfg.llm.cost_inference_mode)
    if planners:
        for name in cfg.planner.names:
            PLANNERS.entry(name)
            planner_settings(name, cfg.planner)  # its node planner.<name>, checked against its dataclass
        check_planner_nodes(cfg)


def check_planner_nodes(cfg: ExperimentConfig) -> None:
    """Raise ConfigError for a node ``planner.<name>`` that configures no registered planner (a typo,
    or a planner whose module is not in ``planner.modules``), naming the key and the valid names."""
    configured = {settings_node(n): n for n in PLANNERS.names() if PLANNERS.entry(n).meta.get("config")}
    for node in cfg.planner.external:
        if node in configured:
            planner_settings(configured[node], cfg.planner)
        else:
            close = difflib.get_close_matches(node, list(configured), n=1)
            raise ConfigError(f"config key 'planner.{node}' is neither a key of planner nor the settings of a "
                              f"registered planner{f' (did you mean planner.{close[0]}?)' if close else ''}; planners "
                              f"with settings: {sorted(configured)} (a planner defined outside the package registers with "
                              f"config=<dataclass> in a module listed in planner.modules)")
