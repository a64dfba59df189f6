"""What a planner works with for one mission, and the machinery the three planners share.

``PlannerContext`` holds the world (simulator), the LLM client (wrapped to count calls and
tokens per command), the known-cost memory, the recorder, the config, the mission, the shared
initial candidates and the objects already delivered by earlier commands of the mission.

Shared steps:
- ``check_and_repair``: feasibility check + bounded regeneration (violation text fed back to the
  LLM in ``generate`` mode; repair/resample in ``score`` mode); a candidate that is still
  infeasible after ``max_rounds`` regenerations is dropped (returns None) and recorded.
- ``execute_plan``: executes a plan action by action with ``world.execute`` and the rule for
  failures: when an action fails (or is not executable in the current state, checked
  symbolically just before execution), the rest of that object's actions are skipped (the object
  is not delivered) and execution continues with the next object. If the robot still holds the
  object, it first puts it back on the furniture it came from (recovery actions are executed and
  counted like any other). A planner may pass a ``replanner`` (MoMa-LLM) that returns new
  remaining actions after a failure.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Optional

import numpy as np

from interllm.config import ExperimentConfig
from interllm.core.actions import Action, Plan, State, plan_to_list
from interllm.core.results import ActionResult
from interllm.core.seeding import planning_seed
from interllm.llm.types import LLMRequest, LLMResponse, ScoreRequest, ScoreResponse
from interllm.planners.base import CommandResult
from interllm.planning import proposals as P
from interllm.planning.feasibility import action_violations, check_plan
from interllm.planning.memory import KnownCosts
from interllm.scene.graph import Command, Mission

LLM_TOPIC = "/llm/calls"


def llm_call_record(request: LLMRequest | ScoreRequest, response: LLMResponse | ScoreResponse) -> dict:
    """What the run log keeps of one LLM call: the cache key (the full prompt and answer are in the
    response cache under it), purpose, labels, token counts and the answer. Nothing that differs
    between a cold and a warm run (latency, cache hit), so run logs stay byte-identical."""
    rec: dict[str, Any] = {"key": response.key, "purpose": request.purpose, "template": request.template,
                           "context": dict(request.context), "tokens_in": int(response.tokens_in)}
    if isinstance(request, ScoreRequest):
        rec.update(kind="score", continuations=list(request.continuations),
                   scores=[float(v) for v in response.scores], calibrated=request.calibration_prompt is not None)
    else:
        rec.update(kind="complete", tokens_out=int(response.tokens_out), temperature=request.options.temperature,
                   sample_index=request.options.sample_index,
                   answer=response.parsed if response.parsed is not None else response.text)
    return rec


class CountingClient:
    """Wraps an LLM client; counts calls and tokens (reset per command) and reports every call
    to ``on_call(request, response)`` (the run log's ``/llm/calls``)."""

    def __init__(self, client: Any, on_call: Optional[Callable[[Any, Any], None]] = None):
        self.inner = client
        self.on_call = on_call
        self.calls = 0
        self.tokens_in = 0
        self.tokens_out = 0

    def reset(self) -> None:
        self.calls = self.tokens_in = self.tokens_out = 0

    def complete(self, request: LLMRequest) -> LLMResponse:
        r = self.inner.complete(request)
        self.calls += 1
        self.tokens_in += int(r.tokens_in)
        self.tokens_out += int(r.tokens_out)
        if self.on_call is not None:
            self.on_call(request, r)
        return r

    def score(self, request: ScoreRequest) -> ScoreResponse:
        r = self.inner.score(request)
        self.calls += 1
        self.tokens_in += int(r.tokens_in)
        if self.on_call is not None:
            self.on_call(request, r)
        return r


@dataclass
class PlannerContext:
    world: Any  # interllm.sim.world.World (or any object with its API)
    client: Any  # LLMClientProtocol
    memory: KnownCosts
    recorder: Any  # interllm.record.api.Recorder
    cfg: ExperimentConfig
    mission: Mission
    planner: str
    initial_candidates: dict[str, list[Plan]] = field(default_factory=dict)  # command id -> M plans
    delivered: set[str] = field(default_factory=set)  # objects delivered by earlier commands
    command_delivered: list[str] = field(default_factory=list)  # delivered by the current command
    _scores: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.client, CountingClient):
            self.client = CountingClient(self.client, on_call=self._log_llm_call)

    def _log_llm_call(self, request: Any, response: Any) -> None:
        self.recorder.event(LLM_TOPIC, float(self.world.clock), llm_call_record(request, response))

    # ---- labels, seeds, logging ---------------------------------------------------------
    def labels(self, command: Command) -> tuple[tuple[str, str], ...]:
        return (("planner", self.planner), ("scene", self.mission.scene_id),
                ("mission", self.mission.id), ("command", command.id))

    def seed(self, *parts: Any) -> int:
        """Seed derived from the base seed, planner, mission and ``parts`` (sha256-based)."""
        return planning_seed(self.cfg.llm.seed, self.planner, self.mission.id, *parts)

    def event(self, topic: str, command: Command, payload: dict) -> None:
        self.recorder.event(topic, float(self.world.clock), {
            "planner": self.planner, "mission": self.mission.id, "command": command.id, **payload})

    def n_objects(self, command: Command) -> int:
        return int(command.goal.n_objects)

    def candidates_for(self, command: Command) -> list[Plan]:
        return list(self.initial_candidates.get(command.id, []))

    def scores(self, command: Command, known: Optional[KnownCosts] = None) -> P.SemanticScores:
        """Score-mode semantic scores of the current scene for ``command`` (memoised)."""
        key = (command.id, known is not None, len(known) if known else 0)
        if key not in self._scores:
            self._scores[key] = P.score_command(self.client, self.world.scene, command, self.cfg, known,
                                                self.labels(command))
        return self._scores[key]

    # ---- feasibility --------------------------------------------------------------------
    def first_feasible(self, command: Command, proposed: list[Plan], max_rounds: int,
                       result: CommandResult) -> Optional[Plan]:
        """The first candidate that passes the feasibility checker within ``max_rounds`` repairs
        (SayPlan's and MoMa-LLM's selection); logs it on /planner/selected. None if none does."""
        for j, plan in enumerate(proposed):
            ok = self.check_and_repair(command, plan, j, max_rounds, result)
            if ok is not None:
                result.candidates = [ok]
                self.event("/planner/selected", command, {"index": j, "plan": plan_to_list(ok)})
                return ok
        return None

    def check_and_repair(self, command: Command, plan: Plan, index: int, max_rounds: int,
                         result: CommandResult, known: Optional[KnownCosts] = None,
                         exclude_targets: tuple[str, ...] = (),
                         exclude_objects: tuple[str, ...] = (),
                         n_objects: Optional[int] = None) -> Optional[Plan]:
        """Check ``plan``; regenerate at most ``max_rounds`` times; None = dropped at the bound.
        ``n_objects``: objects the plan should deliver (default: the command's)."""
        scene, state = self.world.scene, self.world.state
        n = self.n_objects(command) if n_objects is None else n_objects
        for rnd in range(max_rounds + 1):
            report = check_plan(plan, scene, state)
            self.event("/planner/feasibility", command, {"candidate": index, "round": rnd,
                                                         "plan": plan_to_list(plan), **report.to_dict()})
            if report.valid:
                return plan
            if rnd == max_rounds:
                break
            result.regenerations += 1
            if self.cfg.llm.proposal_mode == "generate":
                plan = P.regenerate_plan_llm(self.client, scene, state, command, self.cfg, plan, report,
                                             n, rnd, index, known,
                                             self.labels(command))
            else:
                plan = P.repair_by_scores(plan, self.scores(command, known), scene, state,
                                          n, sorted(self.delivered | set(exclude_objects)),
                                          exclude_targets)
        result.dropped_candidates += 1
        result.notes.append(f"candidate {index} dropped: still infeasible after {max_rounds} regenerations")
        return None

    # ---- execution ----------------------------------------------------------------------
    def execute(self, action: Action, command: Command, result: CommandResult) -> ActionResult:
        before: State = self.world.state
        res = self.world.execute(action)
        self.memory.add_result(res, before)
        result.actions.append(res)
        self.recorder.action(res, {"planner": self.planner, "scene": self.mission.scene_id,
                                   "mission": self.mission.id, "command": command.id})
        return res

    def _put_back(self, command: Command, result: CommandResult) -> None:
        held = self.world.state.holding
        if held is None:
            return
        src = self.world.scene.objects[held].furniture
        steps = []
        if self.world.state.at_furniture != src:
            steps.append(Action("navigate", src, room=self.world.scene.furniture[src].room))
        steps.append(Action("place", src, obj=held))
        for a in steps:
            if action_violations(a, self.world.scene, self.world.state) or \
                    not self.execute(a, command, result).success:
                result.notes.append(f"could not put {held} back on {src}; the robot keeps holding it")
                return
        result.notes.append(f"put {held} back on {src} after a failure")

    def execute_plan(self, command: Command, plan: Plan, result: CommandResult,
                     replanner: Optional[Callable[[ActionResult | None, str, Action, list[str]],
                                                  Optional[Plan]]] = None) -> list[str]:
        """Execute ``plan`` with the skip rule (module docstring); returns the delivered objects.

        ``replanner(failed_result_or_None, failure_text, failed_action, delivered)`` may return a
        new plan for the rest of the command (or None to continue with the remaining segments).
        """
        queue = segments(plan)
        delivered: list[str] = []
        while queue:
            seg = queue.pop(0)
            failure: Optional[tuple[Optional[ActionResult], str, Action]] = None
            for a in seg:
                v = action_violations(a, self.world.scene, self.world.state)
                if v:
                    failure = (None, "not executable: " + "; ".join(x.text for x in v), a)
                    break
                res = self.execute(a, command, result)
                if not res.success:
                    failure = (res, res.reason or f"{a} failed", a)
                    break
                if a.kind == "place":
                    delivered.append(a.obj)
                    self.command_delivered.append(a.obj)
            if failure is None:
                continue
            res, text, a = failure
            head = "" if text.startswith(str(a)) else f"{a}: "
            result.notes.append(f"{head}{text}; skipping the rest of this object's actions")
            self._put_back(command, result)
            if replanner is not None:
                new = replanner(res, text, a, list(delivered))
                if new is not None:
                    queue = segments(new)
        return delivered


def segments(plan: Plan) -> list[list[Action]]:
    """Split a plan into per-object segments, each ending with a place (the tail may not)."""
    out: list[list[Action]] = []
    cur: list[Action] = []
    for a in plan:
        cur.append(a)
        if a.kind == "place":
            out.append(cur)
            cur = []
    if cur:
        out.append(cur)
    return out


def robot_xy(world: Any) -> np.ndarray:
    return np.asarray(world.robot_pose, dtype=float).reshape(-1)[:2]


def new_result(command: Command) -> CommandResult:
    return CommandResult(command_id=command.id, selected_plan=(), candidates=[], estimated_costs=[],
                         actions=[])


def finish(ctx: PlannerContext, result: CommandResult) -> CommandResult:
    result.llm_calls = ctx.client.calls
    result.llm_tokens_in = ctx.client.tokens_in
    result.llm_tokens_out = ctx.client.tokens_out
    return result
