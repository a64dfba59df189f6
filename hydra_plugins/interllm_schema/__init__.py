"""The experiment's typed schema as a Hydra plugin: importing this module stores
``interllm.config.ExperimentConfig`` in Hydra's ConfigStore as ``_schema/root`` (package
``_global_``), which ``conf/config.yaml`` lists first in its defaults, and registers the
``${interllm_pid:}`` resolver its run folders end in (one folder per run process).

Hydra imports every module of the ``hydra_plugins`` namespace package when it initialises
(``hydra.core.plugins.Plugins``), so every process that composes ``conf/`` gets the schema
without importing project code: ``python -m pipeline.run``, ``python -m pipeline.params``, the
tests, and DVC's own composition of params.yaml (``dvc repro``, ``dvc exp run -S``). The schema
holds every default; the files in ``conf/`` hold only what differs from it.

``hydra_plugins/`` has no ``__init__.py`` (Hydra requires a namespace package); the editable
install (``pip install -e .``, ``make install``) puts this package on the interpreter's path.
"""

from __future__ import annotations

import os

from hydra.core.config_store import ConfigStore
from omegaconf import OmegaConf

from interllm.config import ExperimentConfig

SCHEMA_GROUP = "_schema"
SCHEMA_NAME = "root"
PID_RESOLVER = "interllm_pid"


def schema():
    """ExperimentConfig as Hydra's typed node, its ``planner`` node open to keys it does not declare:
    ``planner.<name>`` of a planner defined outside the package (``planner.modules``), whose
    dataclass Hydra cannot know before that module is imported. Its declared keys stay typed; what
    it does not declare is checked by ``interllm.config.from_dict`` and, once the planner's module is
    imported, against the dataclass it registers. ``planner.external`` (where from_dict keeps those
    nodes) is no key of the composed config."""
    node = OmegaConf.structured(ExperimentConfig)
    OmegaConf.set_struct(node.planner, False)
    del node.planner["external"]
    return node


def register() -> None:
    """Store the schema as ``_schema/root`` (idempotent: a second call overwrites the entry)."""
    ConfigStore.instance().store(group=SCHEMA_GROUP, name=SCHEMA_NAME, node=schema(), package="_global_")
    # conf/config.yaml's run folders end in the process id: unique per run process
    OmegaConf.register_new_resolver(PID_RESOLVER, os.getpid, replace=True)


register()
