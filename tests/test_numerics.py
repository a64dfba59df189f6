"""The numerical environment is pinned before numpy loads, whatever the caller's shell set, and is
recorded; results that moved are compared metric by metric and conclusion by conclusion."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from interllm import numerics
from interllm.metrics.compare import compare_metrics, conclusions
from interllm.stages.provenance import for_run_log

AVX2 = {"avx", "avx2", "fma", "sse4_2"}
AVX512 = AVX2 | {"avx512f", "avx512bw"}


@pytest.mark.parametrize("machine, flags, release, coretype, simd_off, reason", [
    ("x86_64", AVX512, (2, 4), "Haswell", "X86_V4 AVX512_ICL AVX512_SPR", ""),
    ("x86_64", AVX2, (2, 4), "Haswell", "X86_V4 AVX512_ICL AVX512_SPR", ""),
    ("x86_64", AVX2, (1, 26), "Haswell", "AVX512F", ""),
    ("x86_64", {"sse4_2", "avx"}, (2, 4), None, "X86_V4", "lacks AVX2"),
    ("aarch64", {"asimd"}, (2, 4), None, None, "not x86-64"),
])
def test_what_is_pinned_on_which_machine(machine, flags, release, coretype, simd_off, reason):
    env, why = numerics.pinned_environment(machine, flags, release)
    assert env.get("OPENBLAS_CORETYPE") == coretype
    if simd_off is None:
        assert env == {}
    else:
        assert simd_off in env["NPY_DISABLE_CPU_FEATURES"] and env["OPENBLAS_NUM_THREADS"] == "1"
    assert (reason in why) if reason else why == ""


def _effective_in_child(env: dict) -> dict:
    code = "import interllm.numerics as n, json; print(json.dumps(n.effective()))"
    keep = {k: v for k, v in os.environ.items() if k not in numerics.PINNED_VARS + (numerics.POLICY_VAR,)}
    r = subprocess.run([sys.executable, "-c", code], env={**keep, **env}, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def _needs_pin():
    _, why = numerics.pinned_environment()
    if why:
        pytest.skip(f"nothing to pin on this machine: {why}")


def test_a_callers_blas_and_simd_choice_is_overridden():
    _needs_pin()
    e = _effective_in_child({"OPENBLAS_CORETYPE": "SkylakeX", "OPENBLAS_NUM_THREADS": "2",
                             "NPY_DISABLE_CPU_FEATURES": "X86_V4"})
    assert e["pinned"] and e["policy"] == "pinned"
    assert [b["kernel"] for b in e["blas"]] == ["Haswell"] and [b["threads"] for b in e["blas"]] == [1]
    assert e["overridden_caller_values"]["OPENBLAS_CORETYPE"] == "SkylakeX"
    assert not {"X86_V4", "AVX512_ICL", "AVX512_SPR"} & set(e["numpy_simd"]["dispatch_enabled"])


def test_inherit_keeps_the_callers_environment():
    _needs_pin()
    e = _effective_in_child({"INTERLLM_NUMERICS": "inherit", "OPENBLAS_NUM_THREADS": "2"})
    assert e["policy"] == "inherit" and not e["pinned"] and "inherit" in e["reason"]
    assert {b["threads"] for b in e["blas"]} == {2}


def test_a_bad_policy_names_the_variable_and_the_choices():
    keep = {k: v for k, v in os.environ.items() if k != numerics.POLICY_VAR}
    r = subprocess.run([sys.executable, "-c", "import interllm"], env={**keep, "INTERLLM_NUMERICS": "fast"},
                       capture_output=True, text=True, timeout=60)
    assert r.returncode != 0
    assert "INTERLLM_NUMERICS='fast' is not valid" in r.stderr and "['pinned', 'inherit']" in r.stderr


def test_run_logs_keep_the_results_part_of_the_numerics_only():
    prov = {"config": {}, "numerics": numerics.effective(), "llama_cpp": "CPU : AVX2 = 1"}
    log = for_run_log(prov)
    assert set(log["numerics"]) == {"policy", "pinned", "blas", "numpy_simd"}  # no CPU model, no caller values
    assert "llama_cpp" not in log and "cpu" in prov["numerics"]


def test_environment_change_names_kernel_simd_and_cpu():
    ref = {"numerics": {"policy": "pinned", "pinned": True, "blas": ["Haswell x1"], "numpy_simd": ["X86_V3"]},
           "cpu": {"machine": "x86_64", "model": "Intel Xeon", "simd_flags": ["avx2", "fma"]},
           "python": "3.11.7", "packages": {"mujoco": "4.0.0"}}
    now = {"numerics": {"policy": "inherit", "pinned": False, "blas": ["SkylakeX x2"],
                        "numpy_simd": ["X86_V3", "X86_V4"]},
           "cpu": {"machine": "x86_64", "model": "AMD EPYC", "simd_flags": ["avx2", "avx512f", "fma"]},
           "python": "3.11.7", "packages": {"mujoco": "3.17.0"}}
    text = "\n".join(numerics.describe_environment_change(ref, now))
    for want in ("BLAS kernel x threads: reference ['Haswell x1'], here ['SkylakeX x2']",
                 "numpy SIMD targets", "here also ['avx512f']", "package mujoco: reference 4.0.0, here 3.17.0"):
        assert want in text
    assert numerics.describe_environment_change(ref, ref) == []


def _metrics(inter, say, lo, hi):
    return {"planners": {"inter_llm": {"m_overall": inter}, "sayplan": {"m_overall": say}},
            "improvement": {"inter_llm_vs_sayplan": {"pct": 100 * (say - inter) / say, "ci_lo": lo, "ci_hi": hi}}}


@pytest.mark.parametrize("after, changed", [
    (_metrics(100.0, 120.0, 5.0, 30.0), []),  # identical
    (_metrics(101.0, 119.0, 4.0, 29.0), []),  # moved, same conclusions
    (_metrics(101.0, 119.0, -1.0, 29.0), ["improvement inter_llm_vs_sayplan"]),  # CI now includes 0
    (_metrics(125.0, 120.0, -30.0, -1.0), ["improvement inter_llm_vs_sayplan",
                                           "ordering on mean m_overall (best first)"]),
])
def test_comparison_says_which_conclusions_changed(after, changed):
    before = _metrics(100.0, 120.0, 5.0, 30.0)
    c = compare_metrics(before, after)
    assert c.changed_conclusions == changed
    assert c.identical == (before == after)
    text = c.text()
    assert ("No conclusion of the report changed" in text) == (not changed) or c.identical
    if not c.identical:
        assert "planners.inter_llm.m_overall" in text


def test_conclusions_read_the_committed_metrics():
    from pathlib import Path

    from interllm.metrics.compare import committed_file

    data = committed_file(Path(__file__).resolve().parents[1], "data/metrics/metrics.json")
    if data is None:
        pytest.skip("no git history")
    metrics = json.loads(data)
    ranked = conclusions(metrics)["ordering on mean m_overall (best first)"].split(" < ")
    planners = metrics["planners"]
    # every planner the report ranks, the anchors left out, from lowest (best) m_overall up
    assert sorted(ranked) == sorted(p for p, v in planners.items() if not v.get("anchor"))
    m = [planners[p]["m_overall"] for p in ranked]
    assert m == sorted(m)
