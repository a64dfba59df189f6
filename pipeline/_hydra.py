"""Compose conf/ with Hydra into the typed experiment config.

The schema (the interllm.config dataclasses, which hold every default) reaches Hydra through the
plugin ``hydra_plugins/interllm_schema``: Hydra's plugin discovery imports it when Hydra
initialises, in this process as in DVC's (``dvc exp run -S``), and conf/config.yaml lists it
first (``_schema: root``). The files in conf/ hold only what differs from the defaults.
"""

from __future__ import annotations

import sys
from pathlib import Path

from interllm.config import ConfigError, ExperimentConfig, from_dict
from interllm.stages.validate import check_registered

CONF_DIR = str(Path(__file__).resolve().parent.parent / "conf")
SCHEMA_ENTRY = "_schema/root.yaml"  # hydra_plugins/interllm_schema stores ExperimentConfig here


def require_schema() -> None:
    """Raise ConfigError unless Hydra's plugin discovery has registered the schema (the plugin
    package is not importable: the project is not installed in this interpreter)."""
    from hydra.core.config_store import ConfigStore
    from hydra.core.plugins import Plugins
    from hydra.plugins.config_source import ConfigLoadError

    Plugins.instance()  # the first call imports every hydra_plugins.* module
    try:
        ConfigStore.instance().load(SCHEMA_ENTRY)
    except ConfigLoadError:
        raise ConfigError(
            f"Hydra found no config schema ({SCHEMA_ENTRY[:-5]}): the plugin hydra_plugins/interllm_schema is "
            f"not importable by {sys.executable}; install the project into it (`make install`, or "
            f"`pip install -e .`)") from None


def compose(overrides: list[str] | None = None, config_dir: str | Path = CONF_DIR):
    """The DictConfig of ``config_dir``/config.yaml (default: the project's conf/) with ``overrides``,
    as DVC's composition gives it (typed by the schema: a typo or a wrong type fails here)."""
    from hydra import compose as _compose
    from hydra import initialize_config_dir

    require_schema()
    with initialize_config_dir(config_dir=str(config_dir), version_base="1.3"):
        return _compose(config_name="config", overrides=list(overrides or []))


def to_config(cfg) -> ExperimentConfig:
    """The typed config of a composed DictConfig, validated like params.yaml on the DVC path (types,
    ranges, unknown keys: Hydra lets ``+planner.MM=3`` add a key to the schema) and against the
    registries (planners, LLM backends, proposal modes)."""
    from omegaconf import OmegaConf

    typed = from_dict(OmegaConf.to_container(cfg, resolve=True),
                      source="the composed config (conf/ and the command-line overrides)")
    check_registered(typed)
    return typed.seeded()
