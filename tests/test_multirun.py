"""Hydra multirun (joblib launcher, 2 parallel jobs): the same pipeline into separate job folders, and the
ablation report gathers them."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.integration  # whole-pipeline runs: `make test-all`, not the fast tier

ROOT = Path(__file__).resolve().parent.parent


def test_multirun_m_ablation_writes_one_pipeline_per_job_and_the_report_gathers_them(tmp_path):
    sweep = tmp_path / "multirun"
    env = {**os.environ, "INTERLLM_PROGRESS": "0"}
    r = subprocess.run(
        [sys.executable, "-m", "pipeline.run", "-m", "hydra/launcher=joblib", "hydra.launcher.n_jobs=2",
         "experiment=m_ablation", "scene=tiny", "benchmark=",
         "mission.n_missions=1", "planner.names=[sayplan]", "planner.M=1,2",
         f"llm.cache_dir={tmp_path / 'cache'}", f"hydra.sweep.dir={sweep}"],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-3000:]
    jobs = sorted(p for p in sweep.iterdir() if p.is_dir() and (p / ".hydra").is_dir())
    assert len(jobs) == 2
    for job, m in zip(jobs, (1, 2), strict=True):
        cfg = (job / ".hydra" / "config.yaml").read_text()
        assert f"M: {m}" in cfg
        metrics = json.loads((job / "data" / "metrics" / "metrics.json").read_text())
        assert "sayplan" in metrics["planners"]
        prov = json.loads((job / "data" / "runs" / "provenance.json").read_text())
        assert prov["config"]["jobs"] == 1  # under the joblib launcher, no second layer of worker processes
        assert prov["config"]["llm"]["n_threads"] == 1  # 2 threads shared by 2 parallel jobs
        cands = json.loads(next((job / "data" / "candidates").glob("*.json")).read_text())
        assert all(len(c) <= m for mission in cands.values() for c in mission.values())

    from interllm.stages.report import find_sweep_results

    temps, ms = find_sweep_results(sweep)
    assert temps == [] and [label for label, _ in ms] == ["M=1", "M=2"]
    out = tmp_path / "report"
    r = subprocess.run([sys.executable, "-m", "interllm.cli", "report", "--data", str(jobs[0] / "data"),
                        "--params", str(tmp_path / "none.yaml"), "--sweeps", str(sweep), "--out", str(out)],
                       cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    md = (out / "report.md").read_text()
    assert "M=1" in md and "M=2" in md


def test_submitit_local_runs_two_jobs_against_one_shared_llm_cache(tmp_path):
    """The cluster path: Hydra's submitit launcher (its local executor is the code path of
    hydra/launcher=submitit_slurm) runs two jobs as separate processes; both ask the same prompts
    and write one cache. Every entry must be whole, and each job must replay from it alone."""

    pytest.importorskip("hydra_plugins.hydra_submitit_launcher", reason="pip install -e '.[slurm]'")
    from interllm.llm.cache import ResponseCache

    sweep, cache = tmp_path / "multirun", tmp_path / "cache"
    env = {**os.environ, "INTERLLM_PROGRESS": "0"}
    common = ["experiment=m_ablation", "scene=tiny", "benchmark=", "mission.n_missions=1", "planner.names=[sayplan]",
              f"llm.cache_dir={cache}", "jobs=1", "llm.n_threads=1"]
    r = subprocess.run([sys.executable, "-m", "pipeline.run", "-m", "hydra/launcher=submitit_local",
                        "hydra.launcher.timeout_min=20", "hydra.launcher.cpus_per_task=1", *common, "planner.M=1,2",
                        f"hydra.sweep.dir={sweep}"], cwd=ROOT, env=env, capture_output=True, text=True, timeout=1200)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-3000:]
    jobs = sorted(p for p in sweep.iterdir() if p.is_dir() and (p / ".hydra").is_dir())
    assert len(jobs) == 2 and all((j / "data" / "metrics" / "metrics.json").is_file() for j in jobs)
    logs = sorted((sweep / ".submitit").rglob("*_log.out"))
    assert len(logs) == 2  # two submitit jobs, two processes
    entries = [p for p in cache.rglob("*.json") if p.name != "models.json"]
    store = ResponseCache(cache, "replay")
    assert entries and all(store._read(p.stem) is not None for p in entries)  # every entry whole, checksum ok
    for m in (1, 2):  # each job's answers are all in the shared cache
        r = subprocess.run([sys.executable, "-m", "pipeline.run", *common, f"planner.M={m}", "llm.cache_mode=replay",
                            f"hydra.run.dir={tmp_path / f'replay{m}'}"], cwd=ROOT, env=env, capture_output=True,
                           text=True, timeout=600)
        assert r.returncode == 0, r.stderr[-3000:]
        assert (tmp_path / f"replay{m}" / "data" / "metrics" / "metrics.json").read_bytes() == \
            (jobs[m - 1] / "data" / "metrics" / "metrics.json").read_bytes()


def test_collect_runs_copies_each_jobs_metrics_and_report_and_replaces_older_copies(tmp_path):
    from pipeline.collect_runs import collect

    src, dst = tmp_path / "multirun", tmp_path / "data" / "mechanism"
    for job in ("oracle_error_0.0", "oracle_error_0.25"):
        m = src / job / "data" / "metrics"
        m.mkdir(parents=True)
        for name in ("metrics.json", "per_mission.csv", "per_command.csv", "per_object.csv"):
            (m / name).write_text(f"{job} {name}")
        (src / job / "data" / "report" / "figures").mkdir(parents=True)
        (src / job / "data" / "report" / "report.md").write_text(job)
        (src / job / "data" / "report" / "report.html").write_text("<html>")
        (src / job / "data" / "report" / "figures" / "learning_curve.png").write_bytes(b"png")
    (src / "unfinished" / "data").mkdir(parents=True)  # a job without metrics is left out
    (dst / "oracle_error_0.0" / "stale").mkdir(parents=True)
    got = collect(src, dst)
    assert [p.name for p in got] == ["oracle_error_0.0", "oracle_error_0.25"]
    one = dst / "oracle_error_0.25"
    assert (one / "metrics" / "metrics.json").read_text() == "oracle_error_0.25 metrics.json"
    assert sorted(p.name for p in (one / "metrics").iterdir()) == ["metrics.json", "per_command.csv",
                                                                  "per_mission.csv"]
    assert (one / "report" / "figures" / "learning_curve.png").is_file()
    assert not (one / "report" / "report.html").exists()
    assert not (dst / "oracle_error_0.0" / "stale").exists() and not list(dst.glob(".*tmp"))
    with pytest.raises(SystemExit, match="no job under"):
        collect(tmp_path / "empty", dst)
