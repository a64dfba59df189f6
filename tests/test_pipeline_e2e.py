"""End to end: `experiment=quick` through real `dvc repro` on the real embedded model.

Runs in a copy of the working tree with an EMPTY LLM cache, so the model really answers; then
checks that DVC sees everything up to date, that a clean rerun from the (now warm) cache gives a
byte-identical metrics.json, and that `dvc exp run -S planner.M=1` is listed by `dvc exp show`.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.integration  # whole-pipeline runs: `make test-all`, not the fast tier

ROOT = Path(__file__).resolve().parent.parent
BIN = Path(sys.executable).parent
SKIP = {".git", ".venv", "data", "outputs", "multirun", ".pytest_cache", ".ruff_cache", "__pycache__",
        "dvc.lock"}


def _copy_tree(dst: Path) -> None:
    for p in ROOT.iterdir():
        if p.name in SKIP or p.name.endswith(".egg-info"):
            continue
        if p.is_dir():
            shutil.copytree(p, dst / p.name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "tmp"))
        else:
            shutil.copy2(p, dst / p.name)
    (dst / "data").mkdir()
    shutil.copytree(ROOT / "data" / "benchmarks", dst / "data" / "benchmarks")  # committed: the frozen missions


def _run(args, cwd, env, timeout=1800):
    r = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, f"{' '.join(map(str, args))} failed:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    return r.stdout + r.stderr


@pytest.fixture(scope="module")
def quick_repo(tmp_path_factory):
    repo = tmp_path_factory.mktemp("quick")
    _copy_tree(repo)
    env = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}",
           "INTERLLM_PROGRESS": "0", "DVC_NO_ANALYTICS": "1",
           "INTERLLM_PYTHON": sys.executable,  # the copy has no .venv for pipeline/stage to find
           "INTERLLM_IMPORTS_LOG": str(tmp_path_factory.mktemp("imports") / "imports.jsonl")}
    _run(["git", "init", "-q"], repo, env)
    _run(["git", "-c", "user.email=t@t", "-c", "user.name=t", "add", "-A"], repo, env)
    _run(["git", "-c", "user.email=t@t", "-c", "user.name=t", "commit", "-qm", "copy"], repo, env)
    _run([sys.executable, "-m", "pipeline.params", "experiment=quick"], repo, env)
    out = _run([str(BIN / "dvc"), "repro"], repo, env)
    return repo, env, out


def test_quick_produces_every_artifact(quick_repo):
    repo, _, _ = quick_repo
    d = repo / "data"
    scenes = [p for p in (d / "scenes").iterdir() if p.is_dir()]
    assert len(scenes) == 1
    for name in ("scene.json", "grid.npz", "scene.xml", "missions.json", "topdown.png"):
        assert (scenes[0] / name).stat().st_size > 0, name
    for planner in ("inter_llm", "sayplan", "moma_llm"):
        mcaps = list((d / "runs" / planner).rglob("*.mcap"))
        assert len(mcaps) == 1 and mcaps[0].stat().st_size > 0, planner
    metrics = json.loads((d / "metrics" / "metrics.json").read_text())
    assert metrics, "metrics.json is empty"
    assert (d / "report" / "report.html").stat().st_size > 0
    assert (d / "runs" / "provenance.json").is_file()


def test_every_module_a_stage_loads_is_among_its_dvc_deps(quick_repo):
    """Otherwise DVC would call a stage up to date after a change to code it runs."""
    import yaml

    repo, env, _ = quick_repo
    stages = yaml.safe_load((repo / "dvc.yaml").read_text())["stages"]
    seen: dict[str, set] = {}  # stage -> modules loaded by its process and its workers
    for line in Path(env["INTERLLM_IMPORTS_LOG"]).read_text().splitlines():
        r = json.loads(line)
        seen.setdefault(r["stage"], set()).update(r["modules"])
    assert "interllm/sim/world.py" in seen["missions"]  # the workers' imports are logged too
    assert set(seen) == set(stages)  # every stage ran and logged
    for stage, modules in seen.items():
        deps = [d.rstrip("/") for d in stages[stage]["deps"]]
        missing = sorted(m for m in modules if not any(m == d or m.startswith(d + "/") for d in deps))
        assert not missing, f"dvc.yaml stage {stage!r} runs {missing} but does not list them under deps"
        assert f"pipeline/{stage}.py" in modules


@pytest.mark.parametrize("module, reruns", [
    ("interllm/metrics/compute.py", {"aggregate", "report"}),  # a metric formula: no re-simulation
    ("interllm/report/verdicts.py", {"report"}),  # a report section: the metrics stand
    ("interllm/planners/moma_llm.py", {"candidates", "missions"}),  # a planner: its runs, not the scenes
])
def test_editing_a_module_leaves_every_stage_that_does_not_run_it_up_to_date(quick_repo, module, reruns):
    """DVC re-runs what changed: a stage depends only on the code it runs (and aggregate and report
    then re-run only if the missions' outputs changed, which `dvc status` cannot know beforehand)."""
    repo, env, _ = quick_repo
    path = repo / module
    before = path.read_bytes()
    try:
        path.write_bytes(before + b"\n# edited by a test\n")
        r = subprocess.run([str(BIN / "dvc"), "status", "--json"], cwd=repo, env=env, capture_output=True,
                           text=True, timeout=300)
    finally:
        path.write_bytes(before)
    assert r.returncode == 0, r.stderr
    changed = {stage.rsplit(":", 1)[-1] for stage in json.loads(r.stdout)}
    assert changed == reruns


def test_the_runs_name_their_benchmark_in_metrics_json_and_the_report(quick_repo):
    """experiment=quick runs the first house and mission of the committed benchmark paper-v3; the
    unchanged simulator measures every slot as frozen."""
    repo, _, _ = quick_repo
    b = json.loads((repo / "data" / "metrics" / "metrics.json").read_text())["benchmark"]
    assert b["name"] == "paper-v3" and b["slots"] == 9 and b["slots_changed"] == 0
    assert "Benchmark: **paper-v3**" in (repo / "data" / "report" / "report.md").read_text()


def test_the_real_model_answered(quick_repo):
    repo, _, _ = quick_repo
    calls = [json.loads(line) for line in (repo / "data" / "candidates" / "llm_calls.jsonl").read_text().splitlines()]
    assert calls and any(not c.get("cached", c.get("cache_hit", True)) for c in calls)
    assert any((repo / "data" / "llm_cache").rglob("*.json"))


def test_second_repro_runs_no_stage(quick_repo):
    repo, env, _ = quick_repo
    out = _run([str(BIN / "dvc"), "repro"], repo, env)
    assert "Running stage" not in out, out
    status = _run([str(BIN / "dvc"), "status"], repo, env)
    assert "up to date" in status.lower(), status


def test_clean_rerun_gives_byte_identical_metrics(quick_repo):
    repo, env, _ = quick_repo
    first = (repo / "data" / "metrics" / "metrics.json").read_bytes()
    _run([str(BIN / "dvc"), "repro", "--force"], repo, env)
    assert (repo / "data" / "metrics" / "metrics.json").read_bytes() == first


def test_dvc_exp_run_with_a_param_is_listed(quick_repo):
    repo, env, _ = quick_repo
    _run(["git", "-c", "user.email=t@t", "-c", "user.name=t", "add", "-A"], repo, env)
    _run(["git", "-c", "user.email=t@t", "-c", "user.name=t", "commit", "-qm", "quick baseline"], repo, env)
    _run([str(BIN / "dvc"), "exp", "run", "-S", "experiment=quick", "-S", "planner.M=1"], repo, env)
    show = _run([str(BIN / "dvc"), "exp", "show", "--json"], repo, env)
    assert '"M": 1' in show.replace(" ", "").replace('"M":1', '"M": 1')


def test_bytecode_and_tool_caches_do_not_change_stage_dependencies(quick_repo):
    """.dvcignore: bytecode written by any import (or absent on a fresh clone) is not a code change."""
    repo, env, _ = quick_repo
    for d in ("interllm/llm", "interllm/scene", "pipeline", "interllm"):
        cache = repo / d / "__pycache__"
        cache.mkdir(exist_ok=True)
        (cache / "fresh.cpython-311.pyc").write_bytes(b"\0" * 64)
    (repo / "interllm" / ".pytest_cache").mkdir(exist_ok=True)
    status = _run([str(BIN / "dvc"), "status"], repo, env)
    assert "up to date" in status.lower(), status
    for d in ("interllm/llm", "interllm/scene", "pipeline", "interllm"):  # and after removing all bytecode
        shutil.rmtree(repo / d / "__pycache__")
    status = _run([str(BIN / "dvc"), "status"], repo, env)
    assert "up to date" in status.lower(), status


def test_a_failed_stage_names_the_key_and_how_to_restore_its_outputs(quick_repo):
    """Runs last in this module: it leaves a failed experiment in the copy's workspace."""
    import re

    repo, env, _ = quick_repo
    outs = {"scenes": "data/scenes", "candidates": "data/candidates"}

    def listing(stage):
        return sorted((p.relative_to(repo).as_posix(), p.read_bytes()) for p in (repo / outs[stage]).rglob("*")
                      if p.is_file())

    before = {stage: listing(stage) for stage in outs}
    # a wrong type fails at DVC's composition (the schema plugin), before any stage runs
    r = subprocess.run([str(BIN / "dvc"), "exp", "run", "-S", "planner.M=abc"], cwd=repo, env=env,
                       capture_output=True, text=True, timeout=600)
    out = r.stdout + r.stderr
    assert r.returncode != 0 and "Traceback" not in out
    assert "planner.M=abc" in out and "full_key: planner.M" in out, out
    assert {stage: listing(stage) for stage in outs} == before
    # a value out of range fails in the stage that validates params.yaml
    r = subprocess.run([str(BIN / "dvc"), "exp", "run", "-S", "planner.M=0"], cwd=repo, env=env,
                       capture_output=True, text=True, timeout=600)
    out = r.stdout + r.stderr
    assert r.returncode != 0 and "Traceback" not in out
    assert "config key 'planner.M'" in out and "must be in [1, 20], got 0" in out
    m = re.search(r"`dvc checkout (\w+)` restores them", out)
    assert m and m[1] in outs, out
    _run([str(BIN / "dvc"), "checkout", m[1]], repo, env)
    assert listing(m[1]) == before[m[1]]  # DVC removed them before the stage failed; checkout restored them
