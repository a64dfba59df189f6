"""The missions stage gives the same runs in one process and in worker processes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from mcap.reader import make_reader

from interllm.stages.candidates import run_candidates
from interllm.stages.missions import run_missions
from interllm.stages.scenes import run_scenes
from pipeline._hydra import compose, to_config

pytestmark = pytest.mark.integration  # whole-pipeline runs: `make test-all`, not the fast tier

ROOT = Path(__file__).resolve().parents[1]


def _messages(p: Path):
    with open(p, "rb") as f:
        r = make_reader(f)
        return ([(c.topic, m.log_time, m.sequence, m.data) for _, c, m in r.iter_messages(log_time_order=False)],
                {m.name: dict(m.metadata) for m in r.iter_metadata()})


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """Scene 0 and its first mission of the default experiment (the committed benchmark), candidates
    from the committed cache."""
    root = tmp_path_factory.mktemp("par")
    cfg = to_config(compose(["scene.n_scenes=1", "mission.limit_missions=1", "llm.cache_mode=replay",
                             f"llm.cache_dir={ROOT / 'data' / 'llm_cache'}", f"benchmark_dir={ROOT / 'data' / 'benchmarks'}"]))
    run_scenes(cfg, root / "scenes")
    run_candidates(cfg, root / "scenes", root / "candidates")
    return root, cfg


def test_one_or_two_workers_write_the_same_runs(inputs, monkeypatch):
    monkeypatch.setenv("INTERLLM_PROGRESS", "0")
    root, cfg = inputs
    outs = {}
    for jobs in (1, 2):
        cfg.jobs = jobs
        run_missions(cfg, root / "scenes", root / "candidates", root / f"runs{jobs}")
        outs[jobs] = root / f"runs{jobs}"
    one, two = outs[1], outs[2]
    files = sorted(p.relative_to(one) for p in one.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(two) for p in two.rglob("*") if p.is_file())  # no worker leftovers
    assert len([f for f in files if f.suffix == ".mcap"]) == len(cfg.planner.names)  # one per planner
    for f in files:
        if f.name == "provenance.json":  # the one file that records how the runs were executed
            pa, pb = json.loads((one / f).read_bytes()), json.loads((two / f).read_bytes())
            assert (pa["config"].pop("jobs"), pb["config"].pop("jobs")) == (1, 2) and pa == pb
        elif f.suffix in (".json", ".mcap"):
            assert (one / f).read_bytes() == (two / f).read_bytes(), f  # run logs included, byte for byte
    _, meta = _messages(one / next(f for f in files if f.suffix == ".mcap"))
    run_config = json.loads(meta["run"]["config"])
    assert "jobs" not in run_config and "n_threads" not in run_config["llm"]
    assert "jobs" in meta["run"]["execution_settings"]

    def calls(d):
        return [{k: v for k, v in json.loads(line).items() if k != "latency"}
                for line in (d / "llm_calls.jsonl").read_text().splitlines()]

    assert calls(one) == calls(two)  # merged in job order


def test_a_failing_run_names_the_job_and_keeps_the_call_log(inputs, monkeypatch, tmp_path):
    """Mission m001 has no candidates (they were made for m000 only): its runs fail, m000's do not."""
    monkeypatch.setenv("INTERLLM_PROGRESS", "0")
    root, cfg = inputs
    monkeypatch.setattr(cfg.mission, "limit_missions", 2)
    for jobs in (1, 2):
        monkeypatch.setattr(cfg, "jobs", jobs)
        out = tmp_path / f"runs{jobs}"
        with pytest.raises(RuntimeError, match=r"planner '(inter_llm|sayplan|moma_llm|nothing|optimal)' on scene 'paper_s0000' "
                                               r"mission 'm001' failed: StageError: .*has no candidates for mission .*rerun the candidates stage"):
            run_missions(cfg, root / "scenes", root / "candidates", out)
        assert (out / "llm_calls.jsonl").is_file()  # merged even after the failure
        assert not list(out.glob(".llm_calls.worker*"))


def test_the_runs_are_the_same_with_or_without_the_scenes_stage_measurements(inputs, monkeypatch, tmp_path):
    """The missions stage starts from the scenes stage's measurements.json; measuring everything
    itself instead gives byte-identical runs (sim.measurements: a measurement on the initial map
    depends on its key alone)."""
    import shutil

    from interllm.sim.measurements import MEASUREMENTS_FILE

    monkeypatch.setenv("INTERLLM_PROGRESS", "0")
    from interllm.sim.manipulator import Manipulator

    made: list[str] = []
    real = Manipulator.measure
    monkeypatch.setattr(Manipulator, "measure", lambda self, *a: made.append("m") or real(self, *a))
    root, cfg = inputs
    cfg.jobs = 1
    bare = tmp_path / "scenes"
    shutil.copytree(root / "scenes", bare)
    removed = [p.unlink() or p for p in bare.glob(f"*/{MEASUREMENTS_FILE}")]
    assert removed
    run_missions(cfg, root / "scenes", root / "candidates", tmp_path / "with")
    with_file = len(made)
    run_missions(cfg, bare, root / "candidates", tmp_path / "without")
    assert 0 < with_file < len(made) - with_file  # the file was used (the benchmark's scenes fingerprint alike)
    files = sorted(p.relative_to(tmp_path / "with") for p in (tmp_path / "with").rglob("m*.*")
                   if p.suffix in (".json", ".mcap"))
    assert len(files) == 2 * len(cfg.planner.names)
    for f in files:
        assert (tmp_path / "with" / f).read_bytes() == (tmp_path / "without" / f).read_bytes(), f
