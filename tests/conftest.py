"""Test session set-up. Importing interllm first pins the numerical environment (BLAS kernel and
threads, numpy's SIMD targets) before any test module imports numpy: see interllm/numerics.py."""

import interllm  # noqa: F401, I001  (must stay the first import: it pins the numerics before numpy loads)
import pytest

from interllm.config import ExperimentConfig


@pytest.fixture
def cfg() -> ExperimentConfig:
    """The default experiment config (the dataclass defaults, which conf/ composes to)."""
    return ExperimentConfig()


@pytest.fixture
def tiny_scene():
    """A fresh two-room scene graph for symbolic tests (``helpers.planners.tiny_scene``)."""
    from helpers.planners import tiny_scene as build

    return build()


@pytest.fixture
def tiny_mission():
    """A fresh two-command mission on ``tiny_scene`` (``helpers.planners.tiny_mission``)."""
    from helpers.planners import tiny_mission as build

    return build()
