"""Cold-run determinism of the embedded model itself: fixed score and generate requests, asked of
a fresh backend, give the committed golden answers bit for bit. A llama.cpp build with other
kernels (native AVX-512 or AMX, another llama-cpp-python release) fails here, and the failure
prints both builds' features."""

from __future__ import annotations

import json

import pytest
from helpers.llm_golden import GOLDEN, SCORE_CASES, compute

pytestmark = pytest.mark.embedded


@pytest.fixture(scope="module")
def golden() -> dict:
    return json.loads(GOLDEN.read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def now() -> dict:
    return compute()


def _builds(golden: dict, now: dict) -> str:
    g, n = golden["build"], now["build"]
    return (f"\n  golden file's build: {g['kind']} {g['simd_features']}\n    {g['system_info']}"
            f"\n  this build:          {n['kind']} {n['simd_features']}\n    {n['system_info']}"
            f"\n  (regenerate only on purpose: .venv/bin/python tests/helpers/llm_golden.py)")


def test_golden_requests_are_the_committed_ones(golden):
    assert [(c["prompt"], c["continuations"]) for c in golden["score"]] == [(p, c) for p, c in SCORE_CASES]


def test_score_logprobs_bit_for_bit(golden, now):
    assert now["model_sha256"] == golden["model_sha256"]
    for g, n in zip(golden["score"], now["score"], strict=True):
        moved = [(c, a, b) for c, a, b in zip(g["continuations"], g["mean_logprob_hex"], n["mean_logprob_hex"],
                                              strict=True) if a != b]
        assert not moved, (f"prompt {g['prompt'][:40]!r}: {len(moved)} of {len(g['continuations'])} "
                           f"log-probs moved, e.g. {moved[0][0]!r}: golden {float.fromhex(moved[0][1])!r}, "
                           f"now {float.fromhex(moved[0][2])!r}" + _builds(golden, now))


def test_seeded_generate_answer_bit_for_bit(golden, now):
    assert now["generate"] == golden["generate"], (f"golden {golden['generate']['text']!r}, "
                                                   f"now {now['generate']['text']!r}" + _builds(golden, now))
