"""How plan candidates and manipulation-cost labels come from the LLM: one interface, one
implementation per LLM mode, built once from the LLM config (``make_proposer``). Planners call it
and never branch on the mode.

- :class:`PlanProposer` — ``propose`` M candidates for a command, ``repair`` a plan the
  feasibility checker rejected, ``replan`` the rest of a command after an execution failure.
  ``generate`` mode: :class:`GeneratePlans` (the LLM writes the plans; see
  ``planning.generation``); ``score`` mode: :class:`ScorePlans` (the LLM ranks objects and
  targets, plans are sampled and assembled; see ``planning.scoring``); ``oracle`` mode:
  :class:`OraclePlans` (score-mode sampling over ground-truth scores; see ``planning.oracle``).
- :class:`CostInferrer` — ``infer`` the cost class of a manipulation from the measured ones
  (``llm.cost_inference_mode``: :class:`GenerateCosts`, :class:`ScoreCosts` or, from the
  simulator's measurement, :class:`OracleCosts`).
- :class:`Proposer` holds one of each, the pair a planner works with.

Adding a mode: a class with the methods of the protocol, registered under its name with
``@PLAN_PROPOSERS.register("<mode>")`` (or ``COST_INFERRERS``); ``llm.proposal_mode=<mode>``
then selects it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Optional, Protocol

from interllm.config import LLMConfig
from interllm.core.actions import Action, Plan, State
from interllm.llm.types import LLMClientProtocol
from interllm.planning import expansion, generation, oracle, scoring
from interllm.planning.costs import decode_cost
from interllm.planning.feasibility import FeasibilityReport
from interllm.planning.memory import KnownCosts
from interllm.registry import Registry
from interllm.scene.graph import Command, SceneGraph


@dataclass(frozen=True)
class Exclusions:
    """Objects a plan must not take and furniture it must not deliver to (sorted ids)."""

    objects: tuple[str, ...] = ()
    targets: tuple[str, ...] = ()


class PlanProposer(Protocol):
    """Plan candidates from the LLM; ``context`` are the call-log labels of the calls."""

    def propose(self, scene: SceneGraph, state: State, command: Command, n_plans: int, n_objects: int, *,
                known: Optional[KnownCosts], exclude: Exclusions, seed: int, context: tuple) -> list[Plan]:
        """Up to ``n_plans`` candidates delivering ``n_objects`` objects for ``command``."""

    def repair(self, plan: Plan, report: FeasibilityReport, scene: SceneGraph, state: State, command: Command,
               n_objects: int, *, round_index: int, candidate: int, known: Optional[KnownCosts],
               exclude: Exclusions, context: tuple) -> Plan:
        """A new version of ``plan`` after the feasibility checker's ``report`` (round ``round_index``
        of candidate ``candidate``)."""

    def replan(self, scene: SceneGraph, state: State, command: Command, n_objects: int, *,
               executed: Sequence[str], failure: str, exclude: Exclusions, attempt: int, seed: int,
               context: tuple) -> Plan:
        """The rest of ``command`` after an execution failure (``failure``: its text)."""


class CostInferrer(Protocol):
    def infer(self, action: Action, scene: SceneGraph, known: KnownCosts, *, seed_parts: Sequence[Any],
              context: tuple) -> str:
        """The cost class of ``action``: easy | medium | hard | unknown.

        An inferrer may also have ``value(action, label) -> float``, the estimate its answer stands
        for, and ``measured_success_rate(action, label) -> float | None`` (the numeric oracle);
        without them the estimate is f_de(label) and only the class is known (``estimate_of``)."""


def success_rate_of(costs: CostInferrer, action: Action, label: str) -> Optional[float]:
    """The success rate ``costs``' answer carries besides its class (the numeric oracle's), or None."""
    rate = getattr(costs, "measured_success_rate", None)
    return None if rate is None else rate(action, label)


def estimate_of(costs: CostInferrer, action: Action, label: str) -> float:
    """The estimate [cost units] of ``costs``' answer ``label`` for ``action``: its ``value`` when it has
    one, else f_de(label)."""
    value = getattr(costs, "value", None)
    return float(value(action, label)) if value is not None else decode_cost(label)


PLAN_PROPOSERS: Registry = Registry("proposal mode", "llm.proposal_mode")
COST_INFERRERS: Registry = Registry("cost inference mode", "llm.cost_inference_mode")


@PLAN_PROPOSERS.register("generate")
class GeneratePlans:
    """The LLM writes, repairs and replans plans (the paper's method). With ``llm.room_beam`` > 0 it
    first chooses the rooms a command's plans look at (``planning.expansion``); the selection is kept
    per command and planner and reused, widened when short, by its repairs and replans."""

    def __init__(self, client: LLMClientProtocol, cfg: LLMConfig) -> None:
        self.client, self.cfg = client, cfg
        self._selections: dict[tuple, expansion.RoomSelection] = {}

    def view(self, request: expansion.SelectionRequest, exclude: Sequence[str]) -> expansion.SceneView:
        """What ``request``'s plan request shows: the whole scene graph (``llm.room_beam`` = 0), or the
        command's selected rooms, selected or widened now if needed."""
        scene = request.scene
        if not self.cfg.room_beam:
            return expansion.flat_view(scene)
        key = (scene.id, request.command.id, tuple(sorted(request.context)))
        sel = expansion.select(self.client, request, self.cfg, exclude, self._selections.get(key))
        self._selections[key] = sel
        return expansion.rooms_view(scene, sel.rooms, request.state.holding)

    def propose(self, scene, state, command, n_plans, n_objects, *, known, exclude, seed, context):
        view = self.view(expansion.SelectionRequest(scene, state, command, n_objects, known, "candidates", context),
                         exclude.objects)
        return generation.generate_plans(self.client, view, state, command, self.cfg, M=n_plans, n_objects=n_objects,
                                         known=known, context=context)

    def repair(self, plan, report, scene, state, command, n_objects, *, round_index, candidate, known, exclude,
               context):
        view = self.view(expansion.SelectionRequest(scene, state, command, n_objects, known, "regeneration", context),
                         exclude.objects)
        return generation.regenerate_plan_llm(self.client, view, state, command, self.cfg, plan=plan, report=report,
                                              n_objects=n_objects, attempt=round_index, sample_index=candidate,
                                              known=known, context=context)

    def replan(self, scene, state, command, n_objects, *, executed, failure, exclude, attempt, seed, context):
        view = self.view(expansion.SelectionRequest(scene, state, command, n_objects, None, "replan", context),
                         exclude.objects)
        return generation.replan_llm(self.client, view, state, command, self.cfg, executed=executed, failure=failure,
                                     n_objects=n_objects, excluded=exclude.objects, attempt=attempt, context=context)


@PLAN_PROPOSERS.register("score")
class ScorePlans:
    """Plans sampled from the LLM's scores of objects and targets. The scores of a command are
    computed once per (command, whether known costs are shown, how many) and reused."""

    def __init__(self, client: LLMClientProtocol, cfg: LLMConfig) -> None:
        self.client, self.cfg = client, cfg
        self._scores: dict[tuple, scoring.SemanticScores] = {}

    def scores(self, scene: SceneGraph, command: Command, known: Optional[KnownCosts],
               context: tuple) -> scoring.SemanticScores:
        key = (command.id, known is not None, len(known) if known else 0)
        if key not in self._scores:
            self._scores[key] = scoring.score_command(self.client, scene, command, self.cfg, known, context)
        return self._scores[key]

    def propose(self, scene, state, command, n_plans, n_objects, *, known, exclude, seed, context):
        return scoring.propose_by_scores(self.scores(scene, command, known, context), scene, state, n_objects,
                                         n_plans, self.cfg.plan_sampling_temperature, seed, exclude.objects,
                                         exclude.targets, self.cfg.candidate_diversity)

    def repair(self, plan, report, scene, state, command, n_objects, *, round_index, candidate, known, exclude,
               context):
        return scoring.repair_by_scores(plan, self.scores(scene, command, known, context), scene, state, n_objects,
                                        exclude.objects, exclude.targets)

    def replan(self, scene, state, command, n_objects, *, executed, failure, exclude, attempt, seed, context):
        plans = scoring.propose_by_scores(self.scores(scene, command, None, context), scene, state, n_objects, 1,
                                          self.cfg.plan_sampling_temperature, seed, exclude.objects,
                                          exclude.targets)
        return plans[0] if plans else ()


@COST_INFERRERS.register("generate")
class GenerateCosts:
    def __init__(self, client: LLMClientProtocol, cfg: LLMConfig) -> None:
        self.client, self.cfg = client, cfg

    def infer(self, action, scene, known, *, seed_parts, context):
        return generation.infer_cost_by_generation(self.client, action, scene, known, self.cfg, context)


@COST_INFERRERS.register("score")
class ScoreCosts:
    def __init__(self, client: LLMClientProtocol, cfg: LLMConfig) -> None:
        self.client, self.cfg = client, cfg

    def infer(self, action, scene, known, *, seed_parts, context):
        return scoring.infer_cost_by_scores(self.client, action, scene, known, self.cfg, seed_parts, context)


@PLAN_PROPOSERS.register("oracle")
class OraclePlans(ScorePlans):
    """Score-mode proposals over the oracle's ground-truth scores (``planning.oracle``); no LLM call."""

    def scores(self, scene: SceneGraph, command: Command, known: Optional[KnownCosts],
               context: tuple) -> scoring.SemanticScores:
        key = (scene.id, command.id, oracle.where(context))
        if key not in self._scores:
            self._scores[key] = oracle.oracle_scores(scene, command, self.cfg, context)
        return self._scores[key]


@COST_INFERRERS.register("oracle")
class OracleCosts:
    """The measured cost class of a manipulation, wrong with probability ``llm.oracle_error``."""

    reads_ground_truth = True

    def __init__(self, client: Any, cfg: LLMConfig, ground_truth: Optional[oracle.GroundTruth] = None) -> None:
        self.cfg, self.truth = cfg, ground_truth

    def infer(self, action, scene, known, *, seed_parts, context):
        if self.truth is None:
            raise RuntimeError("llm.cost_inference_mode=oracle needs the world's ground truth: build the proposer "
                               "with make_proposer(client, cfg, ground_truth=world)")
        return oracle.oracle_cost_label(self.truth.measure_manipulation(action), self.cfg, *oracle.where(context),
                                        *seed_parts, str(action))

    def value(self, action: Action, label: str) -> float:
        """The estimate ``label`` (this inferrer's answer for ``action``) stands for: the measured cost
        with ``llm.oracle_costs=numeric`` (``oracle.oracle_cost_value``), else f_de(label)."""
        return oracle.oracle_cost_value(self.truth.measure_manipulation(action) if self.truth else None, label,
                                        self.cfg)

    def measured_success_rate(self, action: Action, label: str) -> Optional[float]:
        """With ``llm.oracle_costs=numeric`` and a true answer: the measured success rate behind it (what
        the expected-cost encoding reads); else None (the class alone is known)."""
        m = self.truth.measure_manipulation(action) if self.truth else None
        if self.cfg.oracle_costs != "numeric" or m is None or label != oracle.encode_cost(m.cost):
            return None
        return float(m.success_rate)


@dataclass
class Proposer:
    """What a planner asks the LLM through: plan proposals and cost inference."""

    plans: PlanProposer
    costs: CostInferrer


def _build(cls: Any, client: LLMClientProtocol, cfg: LLMConfig, ground_truth: Any) -> Any:
    """An instance of a registered mode; a class with ``reads_ground_truth = True`` (the oracle)
    also gets the world's ground truth."""
    if getattr(cls, "reads_ground_truth", False):
        return cls(client, cfg, ground_truth=ground_truth)
    return cls(client, cfg)


def make_proposer(client: LLMClientProtocol, cfg: LLMConfig, ground_truth: Any = None) -> Proposer:
    """The proposer of ``llm.proposal_mode`` and ``llm.cost_inference_mode``; ``ground_truth``: the
    world (``measure_manipulation``), read only by the oracle modes (``planning.oracle``)."""
    return Proposer(_build(PLAN_PROPOSERS.get(cfg.proposal_mode), client, cfg, ground_truth),
                    _build(COST_INFERRERS.get(cfg.cost_inference_mode), client, cfg, ground_truth))
