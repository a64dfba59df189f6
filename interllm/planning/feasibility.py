"""Symbolic feasibility checker F^c (paper §IV-A) and the symbolic simulator.

Rules (the paper's six, rule names in parentheses):

1. object not in the scene graph (``unknown_object``)
2. furniture not in the scene graph (``unknown_furniture``)
3. room not in the scene graph (``unknown_room``)
4. object picked from a furniture other than the one navigated to (``pickup_not_at_furniture``)
5. object placed on a furniture other than the one navigated to (``place_not_at_furniture``)
6. object neither picked up nor in hand when placed (``object_not_held``)

plus PDDL-style preconditions of the actions:

- ``pickup``: hand free (``hand_not_free``); the object rests on that furniture
  (``object_not_on_furniture``); a pickup names an object (``missing_object``)
- ``place``: only the held object can be placed (``holding_other_object``)
- ``navigate``: the named room contains the furniture (``room_mismatch``)

and their effects: ``navigate(f, r)`` -> at(f), at(room of f); ``pickup(o, f)`` -> holding(o);
``place(o, f)`` -> hand free and o on f. Effects are applied to a copy of the scene and state so
a multi-step plan is checked in sequence. While *checking* a plan the effects of a violating step
are still applied optimistically (as if the step had happened, where its names exist), so every
violation is reported at the step that causes it instead of cascading through the rest of the
plan. ``apply`` (the symbolic simulator SayPlan iterates against) is strict: it raises
``InfeasibleAction`` for a step that violates any rule.

Every violation text is addressed to an LLM: it names the step, the problem and the fix.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

from interllm.core.actions import Action, Plan, State, apply_effects
from interllm.scene.graph import SceneGraph

RULES = (
    "unknown_object", "unknown_furniture", "unknown_room", "pickup_not_at_furniture",
    "place_not_at_furniture", "object_not_held", "hand_not_free", "object_not_on_furniture",
    "holding_other_object", "room_mismatch", "missing_object", "empty_plan",
)


@dataclass(frozen=True)
class Violation:
    index: int  # 0-based step index in the plan
    rule: str  # one of RULES
    text: str  # actionable feedback for the LLM (1-based step numbers)

    def to_dict(self) -> dict:
        return {"index": self.index, "rule": self.rule, "text": self.text}


@dataclass
class FeasibilityReport:
    valid: bool
    violations: list[Violation] = field(default_factory=list)
    final_state: Optional[State] = None  # state after the (optimistic) effects of all steps

    def feedback(self) -> str:
        """All violation texts, one per line (what the regeneration prompt shows)."""
        return "\n".join(v.text for v in self.violations)

    def to_dict(self) -> dict:
        return {"valid": self.valid, "violations": [v.to_dict() for v in self.violations],
                "final_state": None if self.final_state is None else self.final_state.describe()}


class InfeasibleAction(ValueError):
    """``apply`` was asked to simulate an action whose preconditions do not hold."""

    def __init__(self, violations: list[Violation]):
        super().__init__("; ".join(v.text for v in violations))
        self.violations = violations


def _names(scene: SceneGraph, kind: str, limit: int = 12) -> str:
    ids = sorted(getattr(scene, kind))
    more = f", ... ({len(ids)} in total)" if len(ids) > limit else ""
    return ", ".join(ids[:limit]) + more


def action_violations(action: Action, scene: SceneGraph, state: State, index: int = 0) -> list[Violation]:
    """Every rule the single ``action`` breaks in ``scene`` at ``state`` (empty = executable)."""
    out: list[Violation] = []
    step = f"step {index + 1} {action}"

    def add(rule: str, text: str) -> None:
        out.append(Violation(index, rule, f"{step}: {text}"))

    furn_ok = action.furniture in scene.furniture
    if not furn_ok:
        add("unknown_furniture", f"furniture '{action.furniture}' is not in the scene graph; use one of "
            f"the furniture ids of the scene graph ({_names(scene, 'furniture')})")
    if action.kind == "navigate":
        if action.room is not None and action.room not in scene.rooms:
            add("unknown_room", f"room '{action.room}' is not in the scene graph; use one of "
                f"{_names(scene, 'rooms')}")
        elif furn_ok and action.room is not None and scene.furniture[action.furniture].room != action.room:
            add("room_mismatch", f"{action.furniture} is in {scene.furniture[action.furniture].room}, "
                f"not in {action.room}; write navigate({action.furniture}, "
                f"{scene.furniture[action.furniture].room})")
        return out

    obj = action.obj
    if not obj:
        add("missing_object", f"{action.kind} needs an object id; write {action.kind}(<object id>, "
            f"{action.furniture})")
        return out
    if obj not in scene.objects:
        add("unknown_object", f"object '{obj}' is not in the scene graph; use one of the object ids of "
            f"the scene graph ({_names(scene, 'objects')})")
        return out
    where = state.at_furniture
    if action.kind == "pickup":
        if furn_ok and where != action.furniture:
            add("pickup_not_at_furniture", f"the robot is at {where}; navigate to {action.furniture} first "
                f"(navigate({action.furniture}, {scene.furniture[action.furniture].room}))")
        if state.holding is not None and state.holding != obj:
            add("hand_not_free", f"the robot is holding {state.holding}; place it before picking up {obj}")
        if state.holding == obj:
            add("hand_not_free", f"the robot is already holding {obj}; do not pick it up again")
        elif furn_ok and scene.objects[obj].furniture != action.furniture:
            actual = scene.objects[obj].furniture
            add("object_not_on_furniture", f"{obj} is on {actual}, not on {action.furniture}; navigate to "
                f"{actual} and write pickup({obj}, {actual})")
    else:  # place
        if furn_ok and where != action.furniture:
            add("place_not_at_furniture", f"the robot is at {where}; navigate to {action.furniture} first "
                f"(navigate({action.furniture}, {scene.furniture[action.furniture].room}))")
        if state.holding is None:
            add("object_not_held", f"{obj} was neither picked up nor is it in hand; pick it up from "
                f"{scene.objects[obj].furniture} before placing it")
        elif state.holding != obj:
            add("holding_other_object", f"the robot is holding {state.holding}, not {obj}; only the held "
                f"object can be placed (place({state.holding}, {action.furniture}))")
    return out


def _effects(action: Action, scene: SceneGraph, state: State) -> State:
    """The new state after ``action`` (``core.actions.apply_effects``); a place also moves the
    object onto the furniture in ``scene`` (in place)."""
    if action.kind == "place" and action.obj and action.obj == state.holding and action.furniture in scene.furniture:
        scene.move_object(action.obj, action.furniture)
    return apply_effects(action, state, scene.furniture_rooms, scene.objects)


def apply(action: Action, scene: SceneGraph, state: State) -> tuple[SceneGraph, State]:
    """Symbolic simulator: the (new scene, new state) after ``action``; inputs are not modified.

    Raises ``InfeasibleAction`` (with the violation texts) if a precondition does not hold.
    """
    v = action_violations(action, scene, state)
    if v:
        raise InfeasibleAction(v)
    new_scene = scene.copy()
    return new_scene, _effects(action, new_scene, state)


def check_plan(plan: Plan, scene: SceneGraph, state: State) -> FeasibilityReport:
    """Check every step of ``plan`` in sequence from ``state``; inputs are not modified."""
    sc = scene.copy()
    st = state
    violations: list[Violation] = []
    if len(plan) == 0:
        violations.append(Violation(0, "empty_plan", "the plan is empty (or could not be parsed); write "
                                    "at least one navigate -> pickup -> navigate -> place sequence"))
    for i, action in enumerate(plan):
        violations.extend(action_violations(action, sc, st, i))
        st = _effects(action, sc, st)
    return FeasibilityReport(valid=not violations, violations=violations, final_state=st)


def simulate_plan(plan: Plan, scene: SceneGraph, state: State) -> tuple[SceneGraph, State]:
    """Run ``plan`` through ``apply`` step by step (raises at the first infeasible step)."""
    for i, action in enumerate(plan):
        v = action_violations(action, scene, state, i)
        if v:
            raise InfeasibleAction(v)
        scene, state = apply(action, scene, state)
    return scene, state
