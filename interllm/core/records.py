"""The typed mission record: what the missions stage writes per run (``<planner>/<scene>/<mission>.json``)
and the metrics read, one dataclass per level with a schema version.

    MissionRecord(planner, scene_id, mission_id, commands=[CommandRecord(command_id, text, goal,
                  summary, actions, final_locations)], sim_time, schema_version)

``to_dict`` gives the JSON the files hold; ``from_dict`` reads it back and raises
:class:`RecordError` naming the file and the first missing or malformed key (no fallback
spellings: a record of another schema version is refused with the fix).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Optional

from interllm.core.actions import Plan, plan_from_list, plan_to_list
from interllm.core.results import ActionResult
from interllm.errors import UserError

SCHEMA_VERSION = 2  # bump when a field changes meaning or layout (2: cost inferences carry their ground truth)
# beside the records in the missions stage's folder: how tables and figures show each planner that
# ran and which are anchors ({name: {"label", "color", "order", "anchor"}}; planners.base.shown_planners)
PLANNERS_FILE = "planners.json"


class RecordError(UserError, ValueError):
    """A mission record file is malformed or of another schema version; the message says where."""


def _get(d: Any, key: str, where: str) -> Any:
    if not isinstance(d, Mapping) or key not in d:
        raise RecordError(f"{where}: missing key '{key}' (see interllm/core/records.py)")
    return d[key]


@dataclass(frozen=True)
class GoalRecord:
    """What a command asks for (ground truth for the metrics, never shown to a planner)."""

    categories: tuple[str, ...]
    target_furniture: tuple[str, ...]
    n_objects: int

    def to_dict(self) -> dict:
        return {"categories": list(self.categories), "target_furniture": list(self.target_furniture),
                "n_objects": int(self.n_objects)}

    @classmethod
    def from_dict(cls, d: Mapping, where: str) -> GoalRecord:
        return cls(tuple(_get(d, "categories", where)), tuple(_get(d, "target_furniture", where)),
                   int(_get(d, "n_objects", where)))


@dataclass(frozen=True)
class CostInference:
    """One manipulation-cost inference made while estimating a candidate (Inter-LLM), with its
    ground truth: the simulator's N_l-trial measurement of the same action in the scene as it was
    when the inference was made (``World.measure_manipulation``; the mission is untouched)."""

    action: str  # str(Action)
    predicted: str  # easy | medium | hard | unknown
    estimate: float  # decoded cost
    truth: str = ""  # f_en of the measured cost: easy | medium | hard; "" when the action could not be tried
    truth_cost: Optional[float] = None  # measured c_man
    truth_sr: Optional[float] = None  # measured sr_man

    def to_dict(self) -> dict:
        return {"action": self.action, "predicted": self.predicted, "estimate": float(self.estimate),
                "truth": self.truth, "truth_cost": None if self.truth_cost is None else float(self.truth_cost),
                "truth_sr": None if self.truth_sr is None else float(self.truth_sr)}

    @classmethod
    def from_dict(cls, d: Mapping, where: str) -> CostInference:
        opt = lambda k: None if _get(d, k, where) is None else float(_get(d, k, where))  # noqa: E731
        return cls(str(_get(d, "action", where)), str(_get(d, "predicted", where)), float(_get(d, "estimate", where)),
                   str(_get(d, "truth", where)), opt("truth_cost"), opt("truth_sr"))


@dataclass
class CommandSummary:
    """A planner's account of one command: its candidates, choice and LLM usage."""

    command_id: str
    selected_plan: Plan = ()
    candidates: list[Plan] = field(default_factory=list)  # after feasibility repair
    estimated_costs: list[float] = field(default_factory=list)  # per candidate (Inter-LLM only)
    dropped_candidates: int = 0  # hit the regeneration bound
    regenerations: int = 0
    replans: int = 0
    llm_calls: int = 0
    llm_tokens_in: int = 0
    llm_tokens_out: int = 0
    notes: list[str] = field(default_factory=list)
    cost_inferences: list[CostInference] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"command_id": self.command_id, "selected_plan": plan_to_list(self.selected_plan),
                "candidates": [plan_to_list(p) for p in self.candidates],
                "estimated_costs": [float(c) for c in self.estimated_costs],
                "dropped_candidates": self.dropped_candidates, "regenerations": self.regenerations,
                "replans": self.replans, "llm_calls": self.llm_calls, "llm_tokens_in": self.llm_tokens_in,
                "llm_tokens_out": self.llm_tokens_out, "notes": list(self.notes),
                "cost_inferences": [c.to_dict() for c in self.cost_inferences]}

    @classmethod
    def from_dict(cls, d: Mapping, where: str) -> CommandSummary:
        g = lambda k: _get(d, k, where)  # noqa: E731
        return cls(str(g("command_id")), plan_from_list(g("selected_plan")),
                   [plan_from_list(p) for p in g("candidates")], [float(c) for c in g("estimated_costs")],
                   int(g("dropped_candidates")), int(g("regenerations")), int(g("replans")), int(g("llm_calls")),
                   int(g("llm_tokens_in")), int(g("llm_tokens_out")), [str(n) for n in g("notes")],
                   [CostInference.from_dict(c, f"{where}.cost_inferences[{i}]")
                    for i, c in enumerate(g("cost_inferences"))])


@dataclass
class CommandRecord:
    command_id: str
    text: str
    goal: GoalRecord
    summary: CommandSummary
    actions: list[ActionResult]  # executed, in order (recovery and replanned actions included)
    final_locations: dict[str, str]  # object picked up in this command -> furniture it ended on, or "held"

    def to_dict(self) -> dict:
        return {"command_id": self.command_id, "text": self.text, "goal": self.goal.to_dict(),
                "summary": self.summary.to_dict(), "actions": [a.to_record() for a in self.actions],
                "final_locations": dict(self.final_locations)}

    @classmethod
    def from_dict(cls, d: Mapping, where: str, actions: list[ActionResult] | None = None) -> CommandRecord:
        """From ``to_dict()``'s mapping; ``actions``: the command's actions already rebuilt (a run
        log keeps them on /actions and leaves them out of its /results/command records)."""
        if actions is None:
            actions = []
            for i, a in enumerate(_get(d, "actions", where)):
                try:
                    actions.append(ActionResult.from_record(a))
                except (KeyError, TypeError, ValueError) as e:
                    raise RecordError(f"{where}.actions[{i}]: malformed action result ({type(e).__name__}: {e})") from None
        return cls(str(_get(d, "command_id", where)), str(_get(d, "text", where)),
                   GoalRecord.from_dict(_get(d, "goal", where), f"{where}.goal"),
                   CommandSummary.from_dict(_get(d, "summary", where), f"{where}.summary"), actions,
                   {str(k): str(v) for k, v in _get(d, "final_locations", where).items()})


@dataclass
class MissionRecord:
    """One planner's run of one mission."""

    planner: str
    scene_id: str
    mission_id: str
    commands: list[CommandRecord] = field(default_factory=list)
    sim_time: float = 0.0  # [s] simulated mission clock at the end
    schema_version: int = SCHEMA_VERSION

    def to_dict(self) -> dict:
        return {"schema_version": self.schema_version, "planner": self.planner, "scene_id": self.scene_id,
                "mission_id": self.mission_id, "commands": [c.to_dict() for c in self.commands],
                "sim_time": float(self.sim_time)}

    @classmethod
    def from_dict(cls, d: Any, where: str = "MissionRecord") -> MissionRecord:
        version = _get(d, "schema_version", where)
        if version != SCHEMA_VERSION:
            raise RecordError(f"{where}: schema_version {version!r}, this code reads {SCHEMA_VERSION}; rerun "
                              f"the missions stage (dvc repro missions) to rewrite the runs")
        return cls(str(_get(d, "planner", where)), str(_get(d, "scene_id", where)), str(_get(d, "mission_id", where)),
                   [CommandRecord.from_dict(c, f"{where}: commands[{i}]") for i, c in enumerate(_get(d, "commands", where))],
                   float(_get(d, "sim_time", where)), int(version))
