"""High-level planning domain (paper §III-B): state, actions, plans and their effects.

``apply_effects`` is the one state-transition rule (PDDL effects) the feasibility checker, the
simulator and the planners' cost look-ahead all use: ``navigate(f, r)`` -> at(f), at(room of f);
``pickup(o, f)`` -> holding(o) when the hand is free; ``place(o, f)`` -> hand free when o is
held. Preconditions are the feasibility checker's business (``planning.feasibility``).
"""

from __future__ import annotations

from collections.abc import Container, Mapping
from dataclasses import dataclass
from typing import Optional

ACTION_KINDS = ("navigate", "pickup", "place")


@dataclass(frozen=True)
class Action:
    """navigate(furniture, room) | pickup(object, furniture) | place(object, furniture)."""

    kind: str  # one of ACTION_KINDS
    furniture: str
    room: Optional[str] = None  # navigate only
    obj: Optional[str] = None  # pickup / place only

    def __post_init__(self) -> None:
        if self.kind not in ACTION_KINDS:
            raise ValueError(f"action kind {self.kind!r} is not one of {list(ACTION_KINDS)}")

    def __str__(self) -> str:
        if self.kind == "navigate":
            return f"navigate({self.furniture}, {self.room})"
        return f"{self.kind}({self.obj}, {self.furniture})"

    def to_dict(self) -> dict:
        if self.kind == "navigate":
            return {"action": "navigate", "furniture": self.furniture, "room": self.room}
        return {"action": self.kind, "object": self.obj, "furniture": self.furniture}

    @classmethod
    def from_dict(cls, d: dict) -> Action:
        kind = d.get("action") or d.get("kind")
        if kind == "navigate":
            return cls("navigate", furniture=str(d.get("furniture")), room=d.get("room"))
        return cls(str(kind), furniture=str(d.get("furniture")), obj=d.get("object") or d.get("obj"))


Plan = tuple[Action, ...]


def plan_to_list(plan: Plan) -> list[dict]:
    return [a.to_dict() for a in plan]


def plan_from_list(items: list[dict]) -> Plan:
    return tuple(Action.from_dict(d) for d in items)


@dataclass(frozen=True)
class State:
    """holding(object) / hand_free, at(furniture), at(room)."""

    at_furniture: Optional[str]
    at_room: Optional[str]
    holding: Optional[str] = None

    @property
    def hand_free(self) -> bool:
        return self.holding is None

    def describe(self) -> str:
        hand = f"holding({self.holding})" if self.holding else "hand_free"
        return f"at({self.at_furniture}), at({self.at_room}), {hand}"


def apply_effects(action: Action, state: State, furniture_room: Mapping[str, str],
                  objects: Optional[Container[str]] = None) -> State:
    """The high-level state after ``action`` takes effect from ``state``.

    furniture_room: room of every furniture id (``navigate`` to an unknown furniture keeps the
    action's own room); objects: the object ids that exist (``None``: any id). A ``pickup`` with
    the hand busy or of an unknown object, or a ``place`` of an object not held, changes nothing.
    """
    if action.kind == "navigate":
        room = furniture_room[action.furniture] if action.furniture in furniture_room else action.room
        return State(at_furniture=action.furniture, at_room=room, holding=state.holding)
    if action.kind == "pickup":
        if action.obj and (objects is None or action.obj in objects) and state.holding is None:
            return State(state.at_furniture, state.at_room, holding=action.obj)
        return state
    if action.obj and action.obj == state.holding:  # place
        return State(state.at_furniture, state.at_room, holding=None)
    return state
