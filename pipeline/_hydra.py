"""Registers the typed schema (interllm.config dataclasses) in Hydra's ConfigStore.

conf/config.yaml lists it as `optional _schema: root`: in our processes (pipeline.run,
pipeline.params, the tests) composition is typed and validated; DVC's own composition, which
does not import this module, skips it and the stages validate params.yaml instead.
"""

from __future__ import annotations

from pathlib import Path

from hydra.core.config_store import ConfigStore

from interllm.config import ExperimentConfig, from_dict
from interllm.stages.validate import check_registered

CONF_DIR = str(Path(__file__).resolve().parent.parent / "conf")


def register() -> None:
    ConfigStore.instance().store(group="_schema", name="root", node=ExperimentConfig, package="_global_")


def compose(overrides: list[str] | None = None, typed: bool = True):
    """Compose conf/ like DVC does (typed=False) or with the schema (typed=True)."""
    from hydra import compose as _compose
    from hydra import initialize_config_dir

    if typed:
        register()
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return _compose(config_name="config", overrides=list(overrides or []))


def to_config(cfg) -> ExperimentConfig:
    """The typed config of a composed DictConfig, validated like params.yaml on the DVC path (types,
    ranges, unknown keys: Hydra lets ``+planner.MM=3`` add a key to the schema) and against the
    registries (planners, LLM backends, proposal modes)."""
    from omegaconf import OmegaConf

    typed = from_dict(OmegaConf.to_container(cfg, resolve=True),
                      source="the composed config (conf/ and the command-line overrides)")
    check_registered(typed)
    return typed
