"""The recipes of docs/extending.md ("Adding a planner", "Adding an LLM backend", "Adding a proposal
mode"), followed once each: a planner, an LLM backend and a proposal mode defined here, registered,
and run on the quick experiment (one paper-size scene, the paper's mission) through the real stages."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import shutil
from collections.abc import Sequence
from pathlib import Path

import pytest

from interllm.config import ConfigError
from interllm.core.actions import plan_to_list
from interllm.core.seeding import llm_sample_seed
from interllm.llm.backend import BACKENDS, Generation, Scores
from interllm.planners import PLANNERS
from interllm.planners.base import CommandResult
from interllm.planners.context import PlannerContext
from interllm.planners.execution import execute_plan, finish, new_result
from interllm.planning.plans import assemble_plan
from interllm.planning.proposers import PLAN_PROPOSERS
from interllm.planning.request import PlanRequest
from interllm.scene.graph import Command
from interllm.stages.aggregate import run_aggregate
from interllm.stages.candidates import run_candidates
from interllm.stages.missions import run_missions
from interllm.stages.scenes import run_scenes

ROOT = Path(__file__).resolve().parents[1]


# -- "Adding a planner": execute the first initial candidate as it is -------------------------------
class FirstCandidatePlanner:
    """Executes the first command's first shared initial candidate without repair or look-ahead, and
    nothing on later commands (it asks the LLM for nothing, so it runs on the committed cache)."""

    name = "first_candidate"

    def run_command(self, command: Command, ctx: PlannerContext) -> CommandResult:
        ctx.start_command()
        result = new_result(command)
        proposed = ctx.shared_candidates(command)
        if proposed:
            result.selected_plan = proposed[0]
            result.candidates = [proposed[0]]
            ctx.event("/planner/selected", command, {"index": 0, "plan": plan_to_list(proposed[0])})
            execute_plan(ctx, command, proposed[0], result)
        return finish(ctx, result)


# -- "Adding a backend": a backend that scores by word overlap, and a proposal mode ----------------
class OverlapBackend:
    """Scores a continuation by the share of its words found in the prompt; writes no plans."""

    name = "overlap"

    def __init__(self, cfg) -> None:
        self.cfg = cfg
        self.score_calls = 0

    def model_name(self) -> str:
        return "word-overlap-v1"

    def model_id(self) -> str:
        return hashlib.sha256(b"word-overlap-v1").hexdigest()

    def generate(self, messages, schema, options, seed) -> Generation:
        raise RuntimeError("the overlap backend only scores; use a score proposal mode")

    def score(self, prompt: str, continuations: Sequence[str], calibration_prompt=None) -> Scores:
        self.score_calls += 1
        words = set(prompt.lower().split())

        def f(c: str) -> float:
            w = c.lower().split()
            return sum(x in words for x in w) / max(1, len(w)) - llm_sample_seed(c) / 2**31 * 1e-3
        raw = [f(c) for c in continuations]
        calib = [f(c) * 0.5 for c in continuations] if calibration_prompt is not None else None
        return Scores(raw=raw, calibration=calib, tokens_in=len(prompt.split()))

    def close(self) -> None:
        pass


class NearestObjectsProposer:
    """A proposal mode without the LLM: the first objects (in id order) not on the target,
    delivered to the last furniture in id order; repair and replan re-assemble the same way."""

    def __init__(self, client, cfg) -> None:
        self.client, self.cfg = client, cfg

    def _plan(self, req: PlanRequest):
        scene, state, exclude = req.scene, req.state, req.exclude
        target = sorted(f for f in scene.furniture if f not in exclude.targets)[-1]
        objs = [o for o in sorted(scene.objects) if o not in exclude.objects and o != state.holding
                and scene.objects[o].furniture != target][:req.n_objects]
        return assemble_plan(scene, state, objs, target)

    def propose(self, req, *, n_plans, seed):
        return [self._plan(req)]

    def repair(self, req, plan, report, *, round_index, candidate):
        return self._plan(req)

    def replan(self, req, *, executed, failure, attempt, seed):
        return self._plan(req)


@pytest.fixture
def registered():
    PLANNERS.register("first_candidate", label="First candidate", color="tab:gray", order=3)(FirstCandidatePlanner)
    BACKENDS.register("overlap")(OverlapBackend)
    PLAN_PROPOSERS.register("nearest")(NearestObjectsProposer)
    yield
    PLANNERS.unregister("first_candidate")
    BACKENDS.unregister("overlap")
    PLAN_PROPOSERS.unregister("nearest")


def _quick(tmp_path, **llm):
    """The quick experiment (the committed benchmark's first house and mission) with two planners."""
    from omegaconf import OmegaConf

    from pipeline._hydra import compose

    # composed but not yet checked (a stage checks): the planner registered here may not be registered yet
    cfg = OmegaConf.to_object(compose(["experiment=quick", "jobs=1",  # a planner registered here exists in this process only
                                       f"benchmark_dir={ROOT / 'data' / 'benchmarks'}",
                                       "planner.names=[first_candidate,sayplan]"]))
    return dataclasses.replace(cfg, llm=dataclasses.replace(cfg.llm, cache_dir=str(tmp_path / "cache"), **llm))


@pytest.mark.integration
def test_a_new_planner_runs_the_quick_experiment(registered, tmp_path, monkeypatch):
    monkeypatch.setenv("INTERLLM_PROGRESS", "0")
    cfg = _quick(tmp_path, cache_mode="replay")
    cfg.llm.cache_dir = str(ROOT / "data" / "llm_cache")  # the committed answers of the quick experiment
    run_scenes(cfg, tmp_path / "scenes")
    run_candidates(cfg, tmp_path / "scenes", tmp_path / "candidates")
    run_missions(cfg, tmp_path / "scenes", tmp_path / "candidates", tmp_path / "runs")
    metrics = run_aggregate(cfg, tmp_path / "runs", tmp_path / "scenes", tmp_path / "metrics")
    assert set(metrics["planners"]) == {"first_candidate", "sayplan"}
    rec = json.loads(next((tmp_path / "runs" / "first_candidate").rglob("m000.json")).read_text())
    assert len(rec["commands"]) == 3 and rec["commands"][0]["summary"]["selected_plan"]
    assert not any(c["summary"]["selected_plan"] for c in rec["commands"][1:])  # no shared candidates there
    assert metrics["planners"]["first_candidate"]["n_objects"] == 9


@pytest.mark.integration
def test_a_new_backend_and_proposal_mode_run_the_quick_experiment(registered, tmp_path, monkeypatch):
    monkeypatch.setenv("INTERLLM_PROGRESS", "0")
    cfg = _quick(tmp_path, backend="overlap", proposal_mode="nearest", cost_inference_mode="score")
    cfg.planner.names = ["first_candidate", "inter_llm"]
    run_scenes(cfg, tmp_path / "scenes")
    run_candidates(cfg, tmp_path / "scenes", tmp_path / "candidates")
    cands = json.loads(next((tmp_path / "candidates").glob("*.json")).read_text())
    first = cands["m000"]["breakfast"]
    assert len(first) == 1 and first[0][-1]["action"] == "place"  # the proposal mode's one plan
    run_missions(cfg, tmp_path / "scenes", tmp_path / "candidates", tmp_path / "runs")
    calls = [json.loads(x) for x in (tmp_path / "runs" / "llm_calls.jsonl").read_text().splitlines()]
    assert calls and {c["backend"] for c in calls} == {"overlap"}  # Inter-LLM's cost inference scored
    assert {c["purpose"] for c in calls} == {"score_cost"}
    assert any((tmp_path / "cache").rglob("*.json"))  # answers cached under the new backend's identity


def test_unregistered_names_fail_before_any_output(tmp_path):
    cfg = _quick(tmp_path, backend="nope")
    with pytest.raises(ConfigError, match=r"'llm.backend': 'nope' is not a registered LLM backend; choose one "
                                          r"of \['embedded', 'ollama', 'openai', 'oracle'\]"):
        run_candidates(cfg, tmp_path / "scenes", tmp_path / "candidates")
    assert not (tmp_path / "candidates").exists()


# -- "Adding a planner" as docs/extending.md writes it: a module outside the package, a conf/ file,
# Hydra composition and the missions stage's worker processes -----------------------------------------
OUTSIDE_PLANNER = '''"""A planner defined outside the interllm package, with a setting of its own."""
from dataclasses import dataclass

from interllm.planners.base import PLANNERS
from interllm.planners.execution import execute_plan, finish, new_result


@dataclass
class SharedPickConfig:
    pick: int = 0  # which of the shared candidates to execute (0: the first)


@PLANNERS.register("shared_pick", label="Picked shared candidate", color="tab:purple", order=5,
                   config=SharedPickConfig)
class SharedPickPlanner:
    name = "shared_pick"

    def __init__(self, settings):
        self.settings = settings  # planner.shared_pick

    def run_command(self, command, ctx):
        ctx.start_command()
        result = new_result(command)
        proposed = ctx.shared_candidates(command)
        if proposed:
            chosen = proposed[min(self.settings.pick, len(proposed) - 1)]
            result.selected_plan, result.candidates = chosen, proposed
            execute_plan(ctx, command, chosen, result)
        return finish(ctx, result)
'''


@pytest.mark.integration
def test_the_planner_recipe_through_conf_hydra_and_two_worker_processes(tmp_path, monkeypatch):
    from pipeline._hydra import compose, to_config

    monkeypatch.setenv("INTERLLM_PROGRESS", "0")
    (tmp_path / "my_planners").mkdir()
    (tmp_path / "my_planners" / "__init__.py").write_text("")
    (tmp_path / "my_planners" / "shared_pick.py").write_text(OUTSIDE_PLANNER)
    monkeypatch.syspath_prepend(str(tmp_path))  # the spawned workers start with the parent's sys.path
    conf = tmp_path / "conf"
    shutil.copytree(ROOT / "conf", conf)
    (conf / "planner" / "shared_pick.yaml").write_text(  # step 3 of the recipe: its own node included
        "names: [shared_pick, sayplan]\nmodules: [my_planners.shared_pick]\nshared_pick:\n  pick: 1\n")
    cfg = to_config(compose(["experiment=quick", "planner=shared_pick", "jobs=2", "metrics.judge=shared_pick",
                             f"llm.cache_dir={ROOT / 'data' / 'llm_cache'}", "llm.cache_mode=replay"], conf))
    assert cfg.planner.names == ["shared_pick", "sayplan"] and cfg.jobs == 2
    assert cfg.planner.external == {"shared_pick": {"pick": 1}}
    assert "my_planners.shared_pick" not in PLANNERS.builtins  # nothing in the package names it
    run_scenes(cfg, tmp_path / "scenes")
    run_candidates(cfg, tmp_path / "scenes", tmp_path / "candidates")
    run_missions(cfg, tmp_path / "scenes", tmp_path / "candidates", tmp_path / "runs")
    metrics = run_aggregate(cfg, tmp_path / "runs", tmp_path / "scenes", tmp_path / "metrics")
    shown = metrics["planners"]["shared_pick"]
    assert shown["label"] == "Picked shared candidate" and shown["anchor"] is False
    assert metrics["settings"]["judge"] == "shared_pick" and set(metrics["improvement"]) == {"shared_pick_vs_sayplan"}
    summary = json.loads(next((tmp_path / "runs" / "shared_pick").rglob("m000.json")).read_text())["commands"][0]["summary"]
    assert len(summary["candidates"]) >= 2 and summary["candidates"][0] != summary["candidates"][1]
    assert summary["selected_plan"] == summary["candidates"][1]  # its setting reached the worker that ran it
    for override, message in (("planner.shared_pick.pik=2", r"'planner.shared_pick.pik'.*unknown.*did you mean "
                                                            r"planner.shared_pick.pick\?"),
                              ("planner.shared_pick.pick=one", r"'planner.shared_pick.pick'.*must be an integer"),
                              ("planner.shared_pik.pick=1", r"'planner.shared_pik' is neither.*did you mean "
                                                            r"planner.shared_pick\?")):
        with pytest.raises(ConfigError, match=message):
            to_config(compose(["planner=shared_pick", override], conf))
    with pytest.raises(ConfigError, match=r"planner.modules.*cannot import 'my_planners.nowhere'.*PYTHONPATH"):
        to_config(compose(["planner=shared_pick", "planner.modules=[my_planners.nowhere]"], conf))
