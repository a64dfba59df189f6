"""Resumable re-makes (``interllm/stages/resume.py``, ``resume=true``): a finished job is not made
again; a job whose config, code or outputs changed, or that never finished, is."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from interllm.stages import resume

ROOT = Path(__file__).resolve().parent.parent
SKIPPED = "already made with this config, code and benchmark; skipped"
TINY = ["experiment=quick", "scene=tiny", "benchmark=", "mission.n_missions=1", "planner.names=[nothing]",
        "llm=oracle", "resume=true"]


def _run(run_dir: Path, cache: Path, *extra: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "INTERLLM_PROGRESS": "0"}
    return subprocess.run([sys.executable, "-m", "pipeline.run", *TINY, f"hydra.run.dir={run_dir}",
                           f"llm.cache_dir={cache}", *extra], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=600)


def test_a_finished_job_is_skipped_and_a_changed_or_unfinished_one_is_made(tmp_path):
    run_dir, cache = tmp_path / "job", tmp_path / "cache"
    first = _run(run_dir, cache)
    assert first.returncode == 0, first.stderr[-3000:]
    metrics = run_dir / resume.METRICS
    made = metrics.stat().st_mtime_ns
    assert (run_dir / resume.FINISHED).is_file() and SKIPPED not in first.stderr

    again = _run(run_dir, cache, "jobs=1")  # an execution setting: the same job
    assert again.returncode == 0 and SKIPPED in again.stderr, again.stderr[-3000:]
    assert metrics.stat().st_mtime_ns == made

    metrics.write_text(metrics.read_text() + " ")  # outputs edited since: not the run that finished
    edited = _run(run_dir, cache)
    assert edited.returncode == 0 and SKIPPED not in edited.stderr, edited.stderr[-3000:]

    (run_dir / resume.FINISHED).unlink()  # a run killed before its end leaves no record
    unfinished = _run(run_dir, cache)
    assert unfinished.returncode == 0 and SKIPPED not in unfinished.stderr

    changed = _run(run_dir, cache, "metrics.ci=0.9")  # another config: another job
    assert changed.returncode == 0 and SKIPPED not in changed.stderr


def test_a_run_that_fails_part_way_leaves_no_record_of_the_earlier_one(tmp_path):
    run_dir, cache = tmp_path / "job", tmp_path / "cache"
    assert _run(run_dir, cache).returncode == 0
    # the same folder, another config that stops in the scenes stage: the old record must go
    failed = _run(run_dir, cache, "resume=false", "scene.n_furniture=1000")
    assert failed.returncode != 0
    assert not (run_dir / resume.FINISHED).exists()
    assert SKIPPED not in _run(run_dir, cache).stderr  # the first config is made again, not skipped


def test_the_key_follows_config_and_code_but_not_execution_settings(tmp_path):
    root = tmp_path / "repo"
    (root / "interllm").mkdir(parents=True)
    (root / "interllm" / "a.py").write_text("x = 1\n")
    cfg = {"seed": 0, "jobs": 0, "llm": {"n_threads": 2, "temperature": 0.8}, "resume": True}
    key = resume.job_key(cfg, root, None)
    assert resume.job_key({**cfg, "jobs": 2, "resume": False, "llm": {"n_threads": 1, "temperature": 0.8}},
                          root, None) == key
    assert resume.job_key({**cfg, "llm": {"n_threads": 2, "temperature": 0.2}}, root, None) != key
    (root / "interllm" / "a.py").write_text("x = 2\n")
    assert resume.job_key(cfg, root, None) != key
    bench = tmp_path / "bench"
    bench.mkdir()
    (bench / "scene.json").write_text("{}")
    with_bench = resume.job_key(cfg, root, bench)
    (bench / "scene.json").write_text("{ }")
    assert resume.job_key(cfg, root, bench) != with_bench


@pytest.mark.parametrize("record", ["", "not json", '{"key": 3}', "[]"])
def test_a_broken_record_means_not_finished(tmp_path, record):
    (tmp_path / resume.FINISHED).write_text(record)
    assert not resume.finished_run(tmp_path, "k")


@pytest.mark.parametrize("collector", ["sweeps", "runs"])
def test_a_job_committed_elsewhere_is_restored_not_made_again(tmp_path, collector):
    """A job finished in one run folder, collected as the Makefile commits it, is restored into a
    fresh run folder (another machine's) with the same key: the same metrics, recorded as finished."""
    from pipeline import collect_runs, collect_sweeps

    made, cache = tmp_path / "multirun" / "exp" / "0", tmp_path / "cache"
    assert _run(made, cache).returncode == 0
    key = json.loads((made / resume.FINISHED).read_text())["key"]
    committed = tmp_path / "committed"
    if collector == "sweeps":
        (copy_dir,) = collect_sweeps.collect(tmp_path / "multirun", committed)
    else:
        (copy_dir,) = collect_runs.collect(made.parent, committed)
    assert (copy_dir / resume.FINISHED).is_file()

    fresh = tmp_path / "elsewhere" / "0"
    assert resume.restore_committed(fresh, key, [committed]) == copy_dir
    assert (fresh / resume.METRICS).read_bytes() == (made / resume.METRICS).read_bytes()
    assert resume.finished_run(fresh, key)
    assert resume.restore_committed(tmp_path / "other", "another key", [committed]) is None
    assert not (tmp_path / "other").exists()  # nothing written when there is no copy

    copied = next(copy_dir.rglob("metrics.json"))
    copied.write_text(copied.read_text() + " ")  # a committed copy edited since: not the job that finished
    assert resume.committed_copy(key, [committed]) is None
