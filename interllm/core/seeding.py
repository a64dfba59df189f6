"""The one seed derivation of the library, and the seeds it derives, each named for what it seeds.

``derive_seed(domain, *parts)``: SHA-256 of ``[domain, *parts]`` as compact JSON (parts that are
not JSON scalars enter as ``str(part)``), the first 4 bytes big-endian with the top bit cleared:
a 31-bit seed, valid for numpy, Python's ``random`` and llama.cpp alike. The domain keeps the
streams apart (a bootstrap and a pose sampler fed the same parts get unrelated seeds). None uses
Python's salted ``hash()``: the same parts give the same seed in every process and on every
machine.
"""

from __future__ import annotations

import hashlib
import json
from typing import Any


def derive_seed(domain: str, *parts: Any) -> int:
    """31-bit seed of ``parts`` in the stream ``domain`` (module doc)."""
    body = json.dumps([domain, *(p if isinstance(p, (int, float, str, bool, type(None))) else str(p)
                                 for p in parts)], separators=(",", ":"))
    return int.from_bytes(hashlib.sha256(body.encode("utf-8")).digest()[:4], "big") & 0x7FFFFFFF


def llm_sample_seed(*parts: Any) -> int:
    """Seed of an LLM sampling call (attempt ``a`` of request j: ``(seed, j, a)``)."""
    return derive_seed("llm_sample", *parts)


def planning_seed(*parts: Any) -> int:
    """Seed of a planner's sampling (candidates, re-proposals, replans, cost labels)."""
    return derive_seed("planning", *parts)


def bootstrap_seed(seed: int, label: str) -> int:
    """Seed of one bootstrap interval of the metrics (``metrics.seed``, the group's label)."""
    return derive_seed("bootstrap", int(seed), label)


def mission_seed(*parts: Any) -> int:
    """Seed of a scene's mission generator (scene id, ``mission.seed``, mission index)."""
    return derive_seed("mission", *parts)


def pose_sampling_seed(sim_seed: int, action: Any) -> int:
    """Seed of a manipulation's base-pose sampler (``sim.seed``, the action)."""
    return derive_seed("base_poses", int(sim_seed), str(action))


def scene_seed(seed: int, attempt: int) -> int:
    """Seed of attempt ``attempt`` of the scene generator for scene seed ``scene.seed + index``."""
    return derive_seed("scene", int(seed), int(attempt))
