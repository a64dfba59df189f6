"""The oracle input source (``llm=oracle``): the LLM-capability axis's far end, answering from
ground truth instead of a model, so that what Inter-LLM's look-ahead does can be told apart from
what the model knows.

The modes themselves (``OraclePlans``, ``OracleCosts``) are registered in ``planning.proposers``.

- **Plans** (``llm.proposal_mode=oracle``): an object is relevant to a command when its category
  is one the command's goal asks for (``Command.goal.categories``) and it does not already stand
  on one of the goal's target furniture (it would be no progress); the target furniture is the
  goal's (``Command.goal.target_furniture``). These answers become score-mode scores (relevant 0,
  irrelevant ``-IRRELEVANT``) with a floor, so candidates, repairs and replans are sampled exactly
  as in score mode (``planning.scoring``) among the objects answered relevant only: a command with
  fewer relevant objects than it asks for gets shorter plans (one log line says so), never
  irrelevant fillers. The oracle knows what the command asks for, not how hard an object is to
  reach.
- **Cost classes** (``llm.cost_inference_mode=oracle``): f_en of the simulator's scratch
  measurement of the action (``GroundTruth.measure_manipulation``, the same one Table II judges
  against); "unknown" when the action cannot be tried. With ``llm.oracle_costs=numeric`` the
  estimate is the measured cost itself instead of the class's decoded value (``oracle_cost_value``),
  so the report can tell the three-class encoding's limit from the model's.
- **Controlled error** (``llm.oracle_error`` = e in [0, 1]): each answer — each object's
  relevance, a command's target, each cost class — is replaced with probability e by a seeded
  random one (a fair coin for relevance, a uniformly drawn furniture for the target, a uniformly
  drawn class for a cost). The draws are seeded by what is asked (scene, mission, command, object
  or action), never by the planner, so all three planners meet the same wrong answers.

It calls no LLM: nothing reaches the LLM cache or the call log, and the runs are labelled
"oracle" wherever results are shown (``config.LLMConfig.source_label``).
"""

from __future__ import annotations

import logging
from typing import Any, Optional, Protocol

import numpy as np

from interllm.config import LLMConfig
from interllm.core.actions import Action
from interllm.core.results import ActionResult
from interllm.core.seeding import derive_seed
from interllm.planning.costs import decode_cost, encode_cost
from interllm.planning.scoring import SemanticScores
from interllm.scene.graph import Command, SceneGraph

IRRELEVANT = 1000.0  # score gap between a relevant and an irrelevant answer (far beyond any Gumbel draw)
CLASSES = ("easy", "medium", "hard")
log = logging.getLogger(__name__)


class GroundTruth(Protocol):
    """What the oracle reads the true cost of a manipulation from (the simulated world)."""

    def measure_manipulation(self, action: Action) -> Optional[ActionResult]:
        """The N_l-trial measurement of ``action`` now, changing nothing; None if it cannot be tried."""


def _draw(cfg: LLMConfig, *question: Any) -> np.random.Generator:
    """The generator of the error draws for one question."""
    return np.random.default_rng(derive_seed("oracle", int(cfg.seed), *question))


def oracle_scores(scene: SceneGraph, command: Command, cfg: LLMConfig, context: tuple = ()) -> SemanticScores:
    """Relevance of every object and the target of ``command`` from its goal, with the share
    ``llm.oracle_error`` of answers replaced by seeded random ones (module doc)."""
    sid, mid = where(context)
    wanted = set(command.goal.categories)
    goal_targets = set(command.goal.target_furniture)
    instances: dict[str, float] = {}
    for oid in sorted(scene.objects):
        o = scene.objects[oid]
        relevant = o.category in wanted and o.furniture not in goal_targets
        rng = _draw(cfg, sid, mid, command.id, "object", oid)
        if rng.random() < cfg.oracle_error:
            relevant = bool(rng.random() < 0.5)
        instances[oid] = 0.0 if relevant else -IRRELEVANT
    furniture = sorted(scene.furniture)
    targets = {f for f in command.goal.target_furniture if f in scene.furniture}
    rng = _draw(cfg, sid, mid, command.id, "target")
    if rng.random() < cfg.oracle_error or not targets:
        targets = {furniture[int(rng.integers(len(furniture)))]}
    categories = {c: 0.0 if c in wanted else -IRRELEVANT for c in sorted({o.category for o in scene.objects.values()})}
    n_relevant = sum(v == 0.0 for v in instances.values())
    if n_relevant < command.goal.n_objects:
        log.warning("oracle: scene %s mission %s command %s: %d relevant object(s) not yet on a goal target, "
                    "the command asks for %d; its plans take only those", sid, mid, command.id, n_relevant,
                    command.goal.n_objects)
    return SemanticScores(categories, instances, {f: 0.0 if f in targets else -IRRELEVANT for f in furniture},
                          floor=-IRRELEVANT / 2)


def oracle_cost_label(measured: Optional[ActionResult], cfg: LLMConfig, scene: str, mission: str,
                      *question: Any) -> str:
    """f_en of the measured cost ("unknown" when the action could not be tried), replaced with
    probability ``llm.oracle_error`` by a uniformly drawn class; the scene, mission and ``question``
    seed the draw."""
    label = "unknown" if measured is None else encode_cost(measured.cost)
    rng = _draw(cfg, scene, mission, "cost", *question)
    if rng.random() < cfg.oracle_error:
        label = CLASSES[int(rng.integers(len(CLASSES)))]
    return label


def oracle_cost_value(measured: Optional[ActionResult], label: str, cfg: LLMConfig) -> float:
    """The estimate the oracle's answer stands for [cost units]: with ``llm.oracle_costs=numeric``
    the measured cost when ``label`` is its true class (a replaced, wrong answer stays the drawn
    class's decoded value), else f_de(label)."""
    if cfg.oracle_costs == "numeric" and measured is not None and label == encode_cost(measured.cost):
        return float(measured.cost)
    return decode_cost(label)


def where(context: tuple) -> tuple[str, str]:
    """(scene, mission) of a call's labels: what the oracle's error draws are seeded by."""
    labels = dict(context)
    return str(labels.get("scene", "")), str(labels.get("mission", ""))
