"""Plans as the LLM writes them and as the score mode assembles them: the JSON schema of one plan,
its parser, and the navigate -> pickup -> navigate -> place assembly of a delivery."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any, Optional

from interllm.core.actions import Action, Plan, State
from interllm.scene.graph import SceneGraph


def plan_schema(scene: SceneGraph, constrain_names: bool = True) -> dict:
    """JSON schema of one plan {"actions": [...]} over the whole scene graph; ids enumerated when
    ``constrain_names``."""
    return plan_schema_of(scene.rooms, scene.furniture, scene.objects, constrain_names)


def plan_schema_of(rooms: Iterable[str], furniture: Iterable[str], objects: Iterable[str],
                   constrain_names: bool = True) -> dict:
    """JSON schema of one plan {"actions": [...]} whose ids are among the given rooms, furniture and
    objects (enumerated when ``constrain_names``; an empty room or object id is allowed)."""
    def ids(d, empty: bool = True):
        return {"type": "string", "enum": sorted(d) + ([""] if empty else [])} if constrain_names \
            else {"type": "string"}

    action = {
        "type": "object",
        "properties": {
            "action": {"type": "string", "enum": ["navigate", "pickup", "place"]},
            "furniture": ids(furniture, empty=False),
            "room": ids(rooms),
            "object": ids(objects),
        },
        "required": ["action", "furniture", "room", "object"],
        "additionalProperties": False,
    }
    return {"type": "object", "properties": {"actions": {"type": "array", "items": action,
                                                          "minItems": 1, "maxItems": 40}},
            "required": ["actions"], "additionalProperties": False}


def parse_plan(parsed: Any) -> Plan:
    """A plan from the parsed JSON answer; malformed answers give the empty plan (infeasible)."""
    if isinstance(parsed, dict) and isinstance(parsed.get("plans"), list) and parsed["plans"]:
        parsed = parsed["plans"][0]
    if not isinstance(parsed, dict) or not isinstance(parsed.get("actions"), list):
        return ()
    out = []
    for d in parsed["actions"]:
        if not isinstance(d, dict):
            return ()
        try:
            a = Action.from_dict(d)
        except (ValueError, TypeError):
            return ()
        if a.kind == "navigate" and not a.room:
            a = Action("navigate", a.furniture, room=None)
        out.append(a)
    return tuple(out)


def assemble_plan(scene: SceneGraph, state: State, objects: Sequence[str], target: str) -> Plan:
    """navigate -> pickup -> navigate -> place for each object (a held object is delivered first);
    a navigate to the furniture the robot is already at is omitted."""
    return assemble_deliveries(scene, state, [(o, target) for o in objects], held_target=target)


def assemble_deliveries(scene: SceneGraph, state: State, deliveries: Sequence[tuple[str, str]],
                        held_target: Optional[str] = None) -> Plan:
    """navigate -> pickup -> navigate -> place for each (object, target) delivery, from the
    object's furniture in ``scene``; a held object is first put on ``held_target`` (default: the
    first delivery's target; dropped when there is neither). A navigate to the furniture the robot
    is already at is omitted."""
    out: list[Action] = []
    cur = state.at_furniture

    def go(fid: str) -> None:
        nonlocal cur
        if cur != fid:
            out.append(Action("navigate", fid, room=scene.furniture[fid].room))
            cur = fid

    held_target = held_target or (deliveries[0][1] if deliveries else None)
    if state.holding is not None and held_target is not None:
        go(held_target)
        out.append(Action("place", held_target, obj=state.holding))
    for o, target in deliveries:
        f = scene.objects[o].furniture
        go(f)
        out.append(Action("pickup", f, obj=o))
        go(target)
        out.append(Action("place", target, obj=o))
    return tuple(out)
