"""How plan candidates and manipulation-cost labels come from the LLM: one interface, one
implementation per LLM mode, built once from the LLM config (``make_proposer``). Planners call it
and never branch on the mode.

- :class:`PlanProposer` — ``propose`` M candidates for a command, ``repair`` a plan the
  feasibility checker rejected, ``replan`` the rest of a command after an execution failure. Each
  takes a :class:`~interllm.planning.request.PlanRequest` (scene graph, state, command, how many
  objects, known costs, exclusions, call-log labels) and, as keywords, what differs per call.
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
from dataclasses import dataclass, replace
from typing import Any, Optional, Protocol

from interllm.config import LLMConfig
from interllm.core.actions import Action, Plan
from interllm.llm.types import LLMClientProtocol
from interllm.planning import expansion, generation, oracle, scoring
from interllm.planning.costs import decode_cost
from interllm.planning.feasibility import FeasibilityReport
from interllm.planning.memory import KnownCosts
from interllm.planning.request import PlanRequest
from interllm.planning.text import execution_text
from interllm.registry import Registry
from interllm.scene.graph import SceneGraph


class PlanProposer(Protocol):
    """Plan candidates from the LLM for a :class:`~interllm.planning.request.PlanRequest` (its
    ``context``: the call-log labels of the calls)."""

    def propose(self, req: PlanRequest, *, n_plans: int, seed: int) -> list[Plan]:
        """Up to ``n_plans`` candidates delivering ``req.n_objects`` objects for ``req.command``."""

    def repair(self, req: PlanRequest, plan: Plan, report: FeasibilityReport, *, round_index: int,
               candidate: int) -> Plan:
        """A new version of ``plan`` after the feasibility checker's ``report`` (round ``round_index``
        of candidate ``candidate``)."""

    def replan(self, req: PlanRequest, *, executed: Sequence[str], failure: str, attempt: int, seed: int) -> Plan:
        """The rest of ``req.command`` after an execution failure (``failure``: its text;
        ``executed``: the actions run so far, as text); a replan shows no known costs."""


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

    def view(self, req: PlanRequest, purpose: str) -> expansion.SceneView:
        """What ``req``'s plan request (``purpose``: candidates | regeneration | replan) shows: the
        whole scene graph (``llm.room_beam`` = 0), or the command's selected rooms, selected or
        widened now if needed."""
        scene = req.scene
        if not self.cfg.room_beam:
            return expansion.flat_view(scene)
        key = (scene.id, req.command.id, tuple(sorted(req.context)))
        sel = expansion.select(self.client, req, self.cfg, purpose=purpose, start=self._selections.get(key))
        self._selections[key] = sel
        return expansion.rooms_view(scene, sel.rooms, req.state.holding)

    def propose(self, req, *, n_plans, seed):
        return generation.generate_plans(self.client, req, self.cfg, view=self.view(req, "candidates"),
                                         n_plans=n_plans)

    def repair(self, req, plan, report, *, round_index, candidate):
        return generation.regenerate_plan_llm(self.client, req, self.cfg, view=self.view(req, "regeneration"),
                                              plan=plan, report=report, attempt=round_index,
                                              sample_index=candidate)

    def replan(self, req, *, executed, failure, attempt, seed):
        req = replace(req, known=None)
        return generation.replan_llm(self.client, req, self.cfg, view=self.view(req, "replan"), executed=executed,
                                     failure=failure, attempt=attempt)


@PLAN_PROPOSERS.register("score")
class ScorePlans:
    """Plans sampled from the LLM's scores of objects and targets. The scores of a command are
    computed once per (command, whether known costs are shown, how many) and reused."""

    def __init__(self, client: LLMClientProtocol, cfg: LLMConfig) -> None:
        self.client, self.cfg = client, cfg
        self._scores: dict[tuple, scoring.SemanticScores] = {}

    def scores(self, req: PlanRequest) -> scoring.SemanticScores:
        """The scores of ``req``'s command with its known costs shown."""
        known = req.known
        key = (req.command.id, known is not None, len(known) if known else 0)
        if key not in self._scores:
            self._scores[key] = scoring.score_command(self.client, req.scene, req.command, self.cfg, known=known,
                                                      context=req.context)
        return self._scores[key]

    def propose(self, req, *, n_plans, seed):
        return scoring.propose_by_scores(self.scores(req), req, n_plans=n_plans,
                                         temperature=self.cfg.plan_sampling_temperature, seed=seed,
                                         diversity=self.cfg.candidate_diversity)

    def repair(self, req, plan, report, *, round_index, candidate):
        return scoring.repair_by_scores(plan, self.scores(req), req)

    def replan_scores(self, req: PlanRequest, executed: Sequence[str], failure: str) -> scoring.SemanticScores:
        """The command's scores for a replan: the execution so far and the failure's text shown
        before the request (as generate mode's replan prompt shows them), no known costs."""
        return scoring.score_command(self.client, req.scene, req.command, self.cfg, known=None, context=req.context,
                                     history=execution_text(executed, failure))

    def replan(self, req, *, executed, failure, attempt, seed):
        req = replace(req, known=None)
        plans = scoring.propose_by_scores(self.replan_scores(req, executed, failure), req, n_plans=1,
                                          temperature=self.cfg.plan_sampling_temperature, seed=seed)
        return plans[0] if plans else ()


@COST_INFERRERS.register("generate")
class GenerateCosts:
    def __init__(self, client: LLMClientProtocol, cfg: LLMConfig) -> None:
        self.client, self.cfg = client, cfg

    def infer(self, action, scene, known, *, seed_parts, context):
        return generation.infer_cost_by_generation(self.client, action, scene, known, self.cfg, context=context)


@COST_INFERRERS.register("score")
class ScoreCosts:
    def __init__(self, client: LLMClientProtocol, cfg: LLMConfig) -> None:
        self.client, self.cfg = client, cfg

    def infer(self, action, scene, known, *, seed_parts, context):
        return scoring.infer_cost_by_scores(self.client, action, scene, known, self.cfg, seed_parts=seed_parts,
                                            context=context)


@PLAN_PROPOSERS.register("oracle")
class OraclePlans(ScorePlans):
    """Score-mode proposals over the oracle's ground-truth scores (``planning.oracle``); no LLM call."""

    def replan_scores(self, req: PlanRequest, executed: Sequence[str], failure: str) -> scoring.SemanticScores:
        """The oracle's scores: ground truth, which no execution text changes."""
        return self.scores(req)

    def scores(self, req: PlanRequest) -> scoring.SemanticScores:
        """The oracle's scores of ``req``'s command (known costs play no part)."""
        key = (req.scene.id, req.command.id, oracle.where(req.context))
        if key not in self._scores:
            self._scores[key] = oracle.oracle_scores(req.scene, req.command, self.cfg, req.context)
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
