"""MuJoCo execution of high-level actions (paper §III, §IV-B).

``World`` (world.py) is the stateful wrapper; ``build_world_spec`` (build.py) turns a scene into
an MjSpec; ``execute_navigate`` / ``execute_pickup`` / ``execute_place`` run one action;
results are the records of ``results.py``. Heavy modules (mujoco, mink) load on first use, so
``interllm.core.results`` stays cheap to import.
"""

from __future__ import annotations

import importlib

_LAZY = {
    "World": "interllm.sim.world",
    "build_world_spec": "interllm.sim.build",
    "build_local_spec": "interllm.sim.build",
    "execute_navigate": "interllm.sim.navigation",
    "execute_pickup": "interllm.sim.manipulation",
    "execute_place": "interllm.sim.manipulation",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'interllm.sim' has no attribute {name!r}; available: {__all__}")
