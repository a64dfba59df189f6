"""The sweeps behind the committed results: each is a declared grid (conf/experiment/<name>.yaml,
hydra.sweeper.params) that `make sweeps` runs; the jobs' config and metrics are collected into
data/sweeps/ (pipeline/collect_sweeps.py), the report is built from that copy, and `interllm results
diff` compares every collected metrics.json with its committed version."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from interllm.stages.report import find_encoding_results, find_oracle_results, find_sweep_results
from pipeline.collect_sweeps import METRICS, collect, job_name

ROOT = Path(__file__).resolve().parent.parent
CONF = ROOT / "conf"
COMMITTED_JOB = ROOT / "data" / "sweeps" / "m_ablation" / "planner.M_3" / "data" / "metrics"
SWEEP_EXPERIMENTS = sorted(p.stem for p in (CONF / "experiment").glob("*.yaml")
                           if (yaml.safe_load(p.read_text()) or {}).get("sweep"))


def _hydra_sweep_params(experiment: str) -> dict:
    from hydra import compose, initialize_config_dir

    with initialize_config_dir(config_dir=str(CONF), version_base="1.3"):
        cfg = compose(config_name="config", overrides=[f"experiment={experiment}"], return_hydra_config=True)
    return dict(cfg.hydra.sweeper.params or {})


def test_the_report_sweeps_are_the_experiments_make_sweeps_runs():
    makefile = (ROOT / "Makefile").read_text()
    listed = re.search(r"^SWEEPS \?= (.*)$", makefile, re.M).group(1).split()
    assert sorted(listed) == SWEEP_EXPERIMENTS == ["encoding_comparison", "estimate_comparison", "m_ablation",
                                                   "oracle_sweep", "temperature_ablation"]


@pytest.mark.parametrize("experiment", SWEEP_EXPERIMENTS)
def test_every_sweep_declares_its_grid_where_hydra_finds_it(experiment):
    params = _hydra_sweep_params(experiment)
    assert params and all("," in str(v) for v in params.values()), params


COMMITTED_SWEEPS = ROOT / "data" / "sweeps"


def test_every_committed_job_carries_what_places_it_on_its_axis():
    """A fresh clone rebuilds data/report_sweeps from data/sweeps alone: every job's config and
    overrides are committed beside its metrics, in today's layout, and the report finds all of them."""
    from interllm.stages.report import find_estimate_results

    jobs = sorted(p.parent.parent.parent for p in COMMITTED_SWEEPS.glob("*/*/data/metrics/metrics.json"))
    assert len(jobs) == 19  # 4 encoding, 2 estimate, 3 M, 4 oracle, 6 σ (make sweeps)
    for job in jobs:
        for f in ("config.yaml", "overrides.yaml"):
            path = job / ".hydra" / f
            assert path.is_file(), f"{path} is missing: the report cannot place this job"
            if (ROOT / ".git").exists():  # and in git, not only on this machine
                assert subprocess.run(["git", "-C", str(ROOT), "ls-files", "--error-unmatch", str(path)],
                                      capture_output=True).returncode == 0, f"{path} is not committed"
        assert job.name == job_name(yaml.safe_load((job / ".hydra" / "overrides.yaml").read_text()))
    temperatures, ms = find_sweep_results(COMMITTED_SWEEPS)
    found = (len(temperatures), len(ms), len(find_estimate_results(COMMITTED_SWEEPS)),
             len(find_oracle_results(COMMITTED_SWEEPS)), len(find_encoding_results(COMMITTED_SWEEPS)))
    assert found == (6, 3, 2, 5, 4), found  # the oracle axis: its 4 jobs and the encoding job at error 0


def _fake_job(root: Path, experiment: str, num: int, overrides: list[str], config: dict) -> Path:
    job = root / experiment / str(num)
    (job / ".hydra").mkdir(parents=True)
    (job / ".hydra" / "overrides.yaml").write_text(yaml.safe_dump([f"experiment={experiment}", *overrides]))
    (job / ".hydra" / "config.yaml").write_text(yaml.safe_dump(config))
    (job / "data" / "metrics").mkdir(parents=True)
    for f in METRICS:  # a committed job's files (in git, so on a fresh clone too): the real shapes
        shutil.copy2(COMMITTED_JOB / f, job / "data" / "metrics" / f)
    (job / "data" / "metrics" / "per_object.csv").write_text("not collected\n")
    return job


def test_collected_jobs_keep_what_the_report_finds_them_by(tmp_path):
    src, dst = tmp_path / "multirun", tmp_path / "sweeps"
    for i, e in enumerate((0.1, 0.5)):
        _fake_job(src, "oracle_sweep", i, [f"llm.oracle_error={e}"],
                  {"experiment": "oracle_sweep", "sweep": "oracle", "llm": {"oracle_error": e}})
    for i, m in enumerate((1, 5)):
        _fake_job(src, "m_ablation", i, [f"planner.M={m}"], {"experiment": "m_ablation", "sweep": "m",
                                                              "planner": {"M": m}})
    written = collect(src, dst)
    assert sorted(p.relative_to(dst).as_posix() for p in written) == [
        "m_ablation/planner.M_1", "m_ablation/planner.M_5", "oracle_sweep/llm.oracle_error_0.1",
        "oracle_sweep/llm.oracle_error_0.5"]
    assert sorted(p.name for p in (dst / "m_ablation" / "planner.M_1" / "data" / "metrics").iterdir()) == sorted(METRICS)
    assert [e for e, _ in find_oracle_results(dst)] == [0.1, 0.5]
    assert [lab for lab, _ in find_sweep_results(dst)[1]] == ["M=1", "M=5"]
    assert find_encoding_results(dst) == []
    # a second collection of one experiment replaces its copy whole and leaves the other's
    shutil.rmtree(src / "m_ablation")
    shutil.rmtree(src / "oracle_sweep" / "1")
    collect(src, dst)
    assert [p.name for p in (dst / "oracle_sweep").iterdir()] == ["llm.oracle_error_0.1"]
    assert sorted(p.name for p in (dst / "m_ablation").iterdir()) == ["planner.M_1", "planner.M_5"]


def test_a_job_is_named_by_what_it_overrides_in_one_folder_name():
    assert job_name(["experiment=encoding_comparison", "llm.oracle_costs=numeric", "planner.inter_llm.cost_encoding=paper"]) \
        == "llm.oracle_costs_numeric,planner.inter_llm.cost_encoding_paper"
    assert job_name(["experiment=quick"]) == "default"
    # what make sweeps adds to choose how a job runs is not part of its name
    assert job_name(["llm.oracle_error=0.1", "experiment=oracle_sweep", "resume=True",
                     "scenes_cache=multirun/scenes_cache", "jobs=1"]) == "llm.oracle_error_0.1"
    hostile = job_name(["llm.model=a/../../../etc/x", "scene.import_path=/tmp/h"])
    assert "/" not in hostile and hostile == "llm.model_a_.._.._.._etc_x,scene.import_path__tmp_h"
    assert not job_name(["..=x"]).startswith(".")


def test_only_the_sweeps_asked_for_are_collected_and_clashes_are_named(tmp_path):
    src, dst = tmp_path / "multirun", tmp_path / "sweeps"
    _fake_job(src, "oracle_sweep", 0, ["llm.oracle_error=0.1"], {"sweep": "oracle", "llm": {"oracle_error": 0.1}})
    _fake_job(src, "m_ablation", 0, ["planner.M=1"], {"sweep": "m", "planner": {"M": 1}})
    collect(src, dst, ["m_ablation"])
    assert [p.name for p in dst.iterdir()] == ["m_ablation"]  # the old oracle run stayed where it was
    _fake_job(src, "m_ablation", 1, ["planner.M=1"], {"sweep": "m", "planner": {"M": 1}})
    with pytest.raises(SystemExit, match=r"jobs .*m_ablation/0 and .*m_ablation/1 override the same keys"):
        collect(src, dst, ["m_ablation"])
    (src / "m_ablation" / "1" / "data" / "metrics" / "per_mission.csv").unlink()
    shutil.rmtree(src / "m_ablation" / "0")
    with pytest.raises(SystemExit, match=r"m_ablation/1 lacks \['per_mission.csv'\]"):
        collect(src, dst, ["m_ablation"])
    assert sorted(p.name for p in (dst / "m_ablation").iterdir()) == ["planner.M_1"]  # the copy survived


def test_nothing_to_collect_is_named(tmp_path):
    with pytest.raises(SystemExit, match="no job under .* holds data/metrics/metrics.json; run `make sweeps`"):
        collect(tmp_path, tmp_path / "out")


def test_results_diff_compares_every_file_it_is_given(tmp_path):
    repo = tmp_path / "repo"
    files = [repo / "data" / "sweeps" / "x" / j / "data" / "metrics" / "metrics.json" for j in ("a", "b")]
    for f in files:
        f.parent.mkdir(parents=True)
        f.write_text(json.dumps({"planners": {"inter_llm": {"m_overall": 1.0}}}))
    git = ["git", "-C", str(repo), "-c", "user.name=t", "-c", "user.email=t@t"]
    subprocess.run([*git[:3], "init", "-q"], check=True)
    subprocess.run([*git, "add", "."], check=True)
    subprocess.run([*git, "commit", "-qm", "m"], check=True)
    files[1].write_text(json.dumps({"planners": {"inter_llm": {"m_overall": 2.0}}}))
    r = subprocess.run([sys.executable, "-m", "interllm.cli", "results", "diff", "--repo", str(repo), "--check",
                        "--file", *(f.relative_to(repo).as_posix() for f in files)],
                       capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert r.returncode == 1, r.stderr
    assert "x/a/data/metrics/metrics.json reproduces the HEAD version byte for byte" in r.stdout
    assert "x/b/data/metrics/metrics.json differs from the HEAD version" in r.stdout
    assert "planners.inter_llm.m_overall" in r.stdout
    new = files[0].with_name("new.json")  # made for the first time: said, not an error
    new.write_text(files[0].read_text())
    r = subprocess.run([sys.executable, "-m", "interllm.cli", "results", "diff", "--repo", str(repo), "--check",
                        "--file", new.relative_to(repo).as_posix()], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert r.returncode == 0 and "is new: no version at git revision HEAD" in r.stdout, r.stdout + r.stderr
    r = subprocess.run([sys.executable, "-m", "interllm.cli", "results", "diff", "--repo", str(repo), "--file",
                        "data/sweeps/*/*/data/metrics/metrics.json"], capture_output=True, text=True, timeout=120,
                       cwd=ROOT)  # a glob that matched nothing reaches it unexpanded: missing, not new
    assert r.returncode == 2 and "is missing" in r.stderr, r.stdout + r.stderr
