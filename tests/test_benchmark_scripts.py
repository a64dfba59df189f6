"""Every benchmark script answers ``--help`` with its usage and runs nothing (docs/benchmarks.md
promises that each takes ``--help``; a script that ignored it would start a 15-minute run)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted((ROOT / "benchmarks").glob("bench_*.py"))
HELP_SECONDS = 60  # [s] far more than importing a script takes; running one takes minutes


def _run(script: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(script), *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=HELP_SECONDS)


def test_every_benchmark_script_is_found():
    assert len(SCRIPTS) >= 19, [s.name for s in SCRIPTS]


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_help_prints_the_usage_and_runs_nothing(script: Path):
    out = _run(script, "--help")
    assert out.returncode == 0, out.stderr[-2000:]
    assert script.name in out.stdout or script.stem in out.stdout, out.stdout[:500]


@pytest.mark.parametrize("script", [s for s in SCRIPTS if "argparse" not in s.read_text()
                                    and "overrides(" not in s.read_text()], ids=lambda p: p.stem)
def test_a_script_without_arguments_refuses_one(script: Path):
    out = _run(script, "experiment=quick")
    assert out.returncode == 2
    assert "takes no arguments" in out.stderr and "experiment=quick" in out.stderr, out.stderr[-1000:]
