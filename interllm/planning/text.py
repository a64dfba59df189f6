"""Text views of the scene graph, the state and the known costs, as the prompts show them."""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Optional

from interllm.core.actions import Action, Plan
from interllm.planning.costs import encode_cost
from interllm.planning.memory import KnownCosts
from interllm.scene.graph import SceneGraph
from interllm.scene.placement import Placement, placement_of, placement_text, surface_placement


def words(s: str) -> str:
    """An id-like name as words: ``dining_table`` -> ``dining table``."""
    return s.replace("_", " ")


def scene_json(scene: SceneGraph) -> str:
    """The scene graph the LLM sees (rooms > furniture > objects with semantics), compact JSON."""
    return json.dumps(scene.to_prompt_dict(), sort_keys=True, separators=(",", ":"))


def describe_manipulation(action: Action, scene: SceneGraph, placement: Optional[Placement] = None) -> str:
    """'pickup mug (for drinking) from the desk in the office' — location, category, usage. With a
    ``placement`` (``llm.placement_attributes``) the location is the furniture instance and the
    object's place on it: 'from desk_1, the desk in the office (0.42 m in from the open side, ...)'."""
    o = scene.objects.get(action.obj or "")
    f = scene.furniture.get(action.furniture)
    cat = words(o.category) if o else str(action.obj)
    usage = f" ({o.usage})" if o and o.usage else ""
    if f is not None:
        room = scene.rooms.get(f.room)
        loc = f"the {words(f.category)} in the {words(room.type) if room else f.room}"
    else:
        loc = f"the {action.furniture}"
    if placement is not None:
        loc = f"{action.furniture}, {loc} ({placement_text(placement)})"
    prep = "from" if action.kind == "pickup" else "on"
    return f"{action.kind} {cat}{usage} {prep} {loc}"


def action_placement(action: Action, scene: SceneGraph) -> Optional[Placement]:
    """Where a manipulation not yet measured would act: the object where it stands (pickup), the
    target surface (place); None for an action the scene cannot place."""
    if action.furniture not in scene.furniture:
        return None
    if action.kind == "pickup" and (action.obj or "") in scene.objects \
            and scene.objects[action.obj].furniture == action.furniture:
        return placement_of(scene, action.obj)
    return surface_placement(scene, action.furniture)


def known_manipulations_text(known: Optional[KnownCosts], scene: SceneGraph, placement: bool = False) -> str:
    """The measured manipulations with their cost class, one per line ('' when none); with
    ``placement`` each says where its object was when it was measured."""
    if known is None or not known.maned:
        return ""
    return "\n".join(f"- {describe_manipulation(r.action, scene, r.placement if placement else None)}: "
                     f"{encode_cost(r.cost)}" for r in known.maned)


def known_costs_text(known: Optional[KnownCosts]) -> str:
    """The measured costs shown to the planner LLM (Inter-LLM's later commands); '' when none."""
    if known is None or len(known) == 0:
        return ""
    lines = ["Measured action costs so far (prefer cheap actions; avoid hard manipulations and "
             "navigations that collided):"]
    for r in known.naved:
        lines.append(f"- {r.action}: cost {r.cost:.1f}")
    for r in known.maned:
        lines.append(f"- {r.action}: {encode_cost(r.cost)} ({r.cost:.1f})")
    return "\n".join(lines) + "\n"


def execution_text(executed: Sequence[str], failure: str) -> str:
    """What a replan is told of the command's execution: the actions executed so far (each with
    " ok" or " FAILED") and the failure's text; the prefix of the score prompts of a score-mode
    replan (generate mode puts the same two into its replan prompt)."""
    done = "; ".join(executed) or "(nothing)"
    return f"Executed so far: {done}\nAn action failed during execution: {failure}\n"


def plan_text(plan: Plan) -> str:
    """A plan as numbered lines ('(empty)' for none)."""
    return "\n".join(f"{i + 1}. {a}" for i, a in enumerate(plan)) or "(empty)"
