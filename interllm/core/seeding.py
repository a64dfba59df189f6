"""Every seed derivation of the library, side by side, each named for what it seeds.

They differ (hash, byte order, width) for historical reasons; merging them would change every
committed result, so they stay distinct but live here. None uses Python's salted ``hash()``: the
same parts give the same seed in every process and on every machine.
"""

from __future__ import annotations

import hashlib
import json
import zlib
from typing import Any


def llm_sample_seed(*parts: Any) -> int:
    """31-bit seed of an LLM sampling call (attempt ``a`` of request j: ``(seed, j, a)``):
    sha256 of the parts as compact JSON, first 4 bytes big-endian, top bit cleared."""
    body = json.dumps([p if isinstance(p, (int, float, str, bool, type(None))) else str(p)
                       for p in parts], sort_keys=True, separators=(",", ":"))
    return int.from_bytes(hashlib.sha256(body.encode("utf-8")).digest()[:4], "big") & 0x7FFFFFFF


def planning_seed(*parts: Any) -> int:
    """32-bit seed of a planner's sampling (candidates, re-proposals, replans, cost labels):
    sha256 of the parts joined by U+001F, first 4 bytes little-endian."""
    h = hashlib.sha256("\x1f".join(str(p) for p in parts).encode("utf-8")).digest()
    return int.from_bytes(h[:4], "little")


def bootstrap_seed(seed: int, label: str) -> int:
    """32-bit seed of one bootstrap interval of the metrics: CRC32 of ``"<seed>:<label>"``."""
    return zlib.crc32(f"{int(seed)}:{label}".encode()) & 0xFFFFFFFF


def mission_seed(*parts: Any) -> int:
    """Seed of a scene's mission generator: CRC32 of the parts joined by ':'."""
    return zlib.crc32(":".join(str(p) for p in parts).encode("utf-8"))


def pose_sampling_seed(sim_seed: int, action: Any) -> int:
    """Seed of a manipulation's base-pose sampler: ``sim.seed + CRC32(str(action))``."""
    return int(sim_seed) + zlib.crc32(str(action).encode("utf-8"))
