"""What a planner works with for one mission.

``PlannerContext`` holds the world (a :class:`~interllm.planners.world_view.WorldView`), the
proposer (the LLM), the known-cost memory, the recorder, the planner config, the mission, the
shared initial candidates and the objects already delivered by earlier commands. It tallies the
LLM calls of the current command (an observer of the client, which also logs every call to the
run log's ``/llm/calls``). The feasibility repair loop is in :mod:`interllm.planners.repair`,
plan execution with the skip / put-back rule in :mod:`interllm.planners.execution`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from interllm.config import PlannerConfig
from interllm.core.actions import Action, Plan
from interllm.core.records import CostInference
from interllm.core.seeding import planning_seed
from interllm.llm.types import LLMRequest, LLMResponse, ScoreRequest, ScoreResponse
from interllm.planners.world_view import WorldView
from interllm.planning.costs import encode_cost
from interllm.planning.memory import KnownCosts
from interllm.planning.proposers import Proposer, estimate_of, success_rate_of
from interllm.planning.request import Exclusions, PlanRequest
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


@dataclass
class LLMTally:
    """LLM calls and tokens of the current command."""

    calls: int = 0
    tokens_in: int = 0
    tokens_out: int = 0


@dataclass
class LLMCallObserver:
    """The client's observer for one mission run: counts each call in the current command's tally
    and logs it on the run log's /llm/calls at the world's simulated time [s]."""

    world: WorldView
    recorder: Any  # interllm.record.api.Recorder
    tally: LLMTally = field(default_factory=LLMTally)

    def __call__(self, request: Any, response: Any) -> None:
        self.tally.calls += 1
        self.tally.tokens_in += int(response.tokens_in)
        if isinstance(response, LLMResponse):
            self.tally.tokens_out += int(response.tokens_out)
        self.recorder.event(LLM_TOPIC, float(self.world.clock), llm_call_record(request, response))


@dataclass
class PlannerContext:
    world: WorldView
    proposer: Proposer
    memory: KnownCosts
    recorder: Any  # interllm.record.api.Recorder
    cfg: PlannerConfig
    mission: Mission
    planner: str
    seed_base: int = 0  # llm.seed: every planner seed derives from it
    base_speed: float = 0.5  # [m/s] sim.base_speed, for the cost of a presumed path without history
    gamma_obj: float = 100.0  # metrics.gamma_obj: what losing an object costs (planner.inter_llm.cost_encoding=expected)
    initial_candidates: dict[str, list[Plan]] = field(default_factory=dict)  # command id -> M plans
    delivered: set[str] = field(default_factory=set)  # objects delivered by earlier commands
    command_delivered: list[str] = field(default_factory=list)  # delivered by the current command
    llm_calls: LLMCallObserver | None = None  # the observer of ``proposer``'s client (None: not counted)

    # ---- the LLM calls of the current command ---------------------------------------------
    @property
    def tally(self) -> LLMTally:
        """The current command's LLM calls and tokens (zero when the client is not observed)."""
        return self.llm_calls.tally if self.llm_calls is not None else LLMTally()

    def start_command(self) -> None:
        if self.llm_calls is not None:
            self.llm_calls.tally = LLMTally()

    # ---- labels, seeds, logging ---------------------------------------------------------
    def labels(self, command: Command) -> tuple[tuple[str, str], ...]:
        return (("planner", self.planner), ("scene", self.mission.scene_id),
                ("mission", self.mission.id), ("command", command.id))

    def seed(self, *parts: Any) -> int:
        """Seed derived from the base seed, planner, mission and ``parts`` (``core.seeding.planning_seed``)."""
        return planning_seed(self.seed_base, self.planner, self.mission.id, *parts)

    def event(self, topic: str, command: Command, payload: dict) -> None:
        self.recorder.event(topic, float(self.world.clock), {
            "planner": self.planner, "mission": self.mission.id, "command": command.id, **payload})

    def n_objects(self, command: Command) -> int:
        return int(command.goal.n_objects)

    def infer_cost(self, action: Action, command: Command, known: KnownCosts | None = None) -> CostInference:
        """The proposer's cost class of a manipulation from the known costs (``known``, default the
        planner's memory), beside its ground truth (the world's scratch measurement of the same
        action now; Table II judges every inference)."""
        known = self.memory if known is None else known
        truth = self.world.measure_manipulation(action)
        label = self.proposer.costs.infer(action, self.world.scene, known,
                                          seed_parts=(self.mission.id, command.id, len(known)),
                                          context=self.labels(command))
        estimate = estimate_of(self.proposer.costs, action, label)
        if truth is None:
            return CostInference(str(action), label, estimate)
        return CostInference(str(action), label, estimate, encode_cost(truth.cost), float(truth.cost),
                             float(truth.success_rate))

    def answered_success_rate(self, action: Action, label: str) -> float | None:
        """The success rate the proposer's cost answer ``label`` for ``action`` carries besides its class
        (only the numeric oracle's does), or None."""
        return success_rate_of(self.proposer.costs, action, label)

    def shared_candidates(self, command: Command) -> list[Plan]:
        """The shared initial candidates of ``command`` (made by the candidates stage for the first
        command only, unless ``planner.fair_baselines=false``; empty when there are none)."""
        return list(self.initial_candidates.get(command.id, []))

    def is_first_command(self, command: Command) -> bool:
        return bool(self.mission.commands) and command.id == self.mission.commands[0].id

    def request(self, command: Command, *, known: KnownCosts | None = None, n_objects: int | None = None,
                avoid: Exclusions = Exclusions()) -> PlanRequest:
        """A proposer request for ``command`` in the current scene graph and state: ``n_objects``
        objects (default: the command's), ``known``: the known costs its prompts may show; it
        avoids the objects earlier commands delivered and ``avoid``'s objects and targets."""
        w = self.world
        n = self.n_objects(command) if n_objects is None else n_objects
        exclude = Exclusions(tuple(sorted(self.delivered | set(avoid.objects))), avoid.targets)
        return PlanRequest(w.scene, w.state, command, n, known, exclude, self.labels(command))

    def propose_from_state(self, command: Command, known: KnownCosts | None = None) -> list[Plan]:
        """M new candidates from the current scene graph and state, excluding the objects earlier
        commands delivered; ``known``: the known costs the prompts carry (Inter-LLM only)."""
        return self.proposer.plans.propose(self.request(command, known=known), n_plans=self.cfg.M,
                                           seed=self.seed("propose", command.id))

    def candidates(self, command: Command, known: KnownCosts | None = None) -> tuple[list[Plan], str]:
        """(candidates, source) of ``command`` for any planner, made for the state it runs in: the
        shared initial ones ("initial") for the first command, else M proposed now from the current
        state ("reproposed"; ``known``: the known costs their prompts carry, for a planner that
        learns). With ``planner.fair_baselines=false`` a planner without known costs keeps the
        shared mission-start candidates for every command, as the baselines did before."""
        shared = self.shared_candidates(command)
        if shared and (self.is_first_command(command) or (known is None and not self.cfg.fair_baselines)):
            return shared, "initial"
        return self.propose_from_state(command, known=known), "reproposed"
