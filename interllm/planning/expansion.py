"""Generate mode on large houses: the scene graph expanded room by room, as SayPlan expands a
collapsed scene graph, so that a plan request carries a few rooms and not the whole house.

1. **Room selection.** One request (``select_rooms`` template, purpose ``rooms_for_<phase>``)
   lists the house's rooms, grouped by type, with the command, the state and the known costs,
   and asks under a JSON schema of the room ids for at most ``llm.room_beam`` of them: where
   useful objects are, and where they must go.
2. **The plan request** (candidates, regeneration, replan) shows only the chosen rooms: their
   furniture, the objects on it and what each object category is for (:func:`rooms_view`); its
   schema enumerates only those ids (plus the held object), so ``llm.constrain_names`` restricts
   the answer to them.
3. **Widening** (the bounded fallback): when the chosen rooms hold fewer objects a plan may take
   than the command asks for (after the exclusions: delivered, failed, held), or the selection
   came back empty, one more selection request over the rooms not chosen yet adds up to
   ``llm.room_beam`` rooms, at most ``llm.room_widenings`` times per command. Past the bound the
   plan is written over what was chosen (an empty selection falls back to the robot's room).

``llm.room_beam = 0`` keeps the flat prompt: the whole scene graph as JSON (:func:`flat_view`).
``llm.furniture_beam`` is a score-mode key: a plan request shows all furniture of the chosen
rooms, as the target may be any of them.

The selection of a command is kept by the proposer (``planning.proposers.GeneratePlans``) and
reused by its repairs and replans.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Optional

from interllm.config import LLMConfig
from interllm.core.actions import State
from interllm.llm.calllog import SELECTION_PREFIX
from interllm.llm.client import complete_or_none
from interllm.llm.prompts import load_template
from interllm.llm.types import LLMOptions, LLMRequest, Message
from interllm.planning.plans import plan_schema_of
from interllm.planning.request import PlanRequest
from interllm.planning.text import known_costs_text, scene_json, words
from interllm.scene.graph import SceneGraph

FLAT_HEADER = "Scene graph (JSON: rooms > furniture > objects with category and usage):\n"
ROOMS_HEADER = ("Part of the scene graph: the rooms chosen for this command, their furniture (furniture id: "
                "ids of the objects on it) and what the objects are for:\n")


@dataclass(frozen=True)
class SceneView:
    """What a plan request shows of the scene graph: the prompt's scene section (``text``) and the
    ids its answer may use."""

    text: str
    rooms: tuple[str, ...]
    furniture: tuple[str, ...]
    objects: tuple[str, ...]

    def schema(self, constrain_names: bool) -> dict:
        """The JSON schema of one plan over this view's ids (``planning.plans.plan_schema_of``)."""
        return plan_schema_of(self.rooms, self.furniture, self.objects, constrain_names)


@dataclass(frozen=True)
class RoomSelection:
    """The rooms chosen for one command, in the order chosen, and the widening requests it took."""

    rooms: tuple[str, ...]
    widenings: int = 0


def flat_view(scene: SceneGraph) -> SceneView:
    """The whole scene graph as JSON (``llm.room_beam = 0``: the prompt before the expansion)."""
    return SceneView(FLAT_HEADER + scene_json(scene), tuple(sorted(scene.rooms)), tuple(sorted(scene.furniture)),
                     tuple(sorted(scene.objects)))


def _named(node_id: str, category: str) -> str:
    """An id, with its category when the id does not start with it (imported scenes)."""
    return node_id if node_id.startswith(category) else f"{node_id} ({words(category)})"


def rooms_view(scene: SceneGraph, rooms: Iterable[str], holding: Optional[str] = None) -> SceneView:
    """The chosen rooms as the plan request shows them: per room its furniture and the ids of the
    objects on each, then the usage of every object category shown. ``holding``: the held object,
    kept among the ids a plan may name wherever it came from."""
    chosen = [r for r in sorted(set(rooms)) if r in scene.rooms]
    by_furniture: dict[str, list[str]] = {}
    for o in sorted(scene.objects.values(), key=lambda o: o.id):
        by_furniture.setdefault(o.furniture, []).append(o.id)
    lines, furniture, objects, usage = [], [], [], {}
    for r in chosen:
        lines.append(f"{r} ({words(scene.rooms[r].type)})")
        for f in sorted(scene.furniture_in(r), key=lambda f: f.id):
            on = by_furniture.get(f.id, [])
            shown = ", ".join(_named(o, scene.objects[o].category) for o in on) or "nothing"
            lines.append(f"- {_named(f.id, f.category)}: {shown}")
            furniture.append(f.id)
            objects += on
            usage.update({scene.objects[o].category: scene.objects[o].usage for o in on})
    if holding and holding in scene.objects and holding not in objects:
        objects.append(holding)
        usage[scene.objects[holding].category] = scene.objects[holding].usage
    uses = "; ".join(f"{words(c)}: {u}" if u else words(c) for c, u in sorted(usage.items()))
    text = ROOMS_HEADER + "\n".join(lines) + (f"\nObjects are for: {uses}" if uses else "")
    return SceneView(text, tuple(chosen), tuple(sorted(furniture)), tuple(sorted(objects)))


def rooms_text(scene: SceneGraph, rooms: Iterable[str]) -> str:
    """The rooms a selection may choose, one line per room type: 'kitchen: kitchen_1, kitchen_2'."""
    by_type: dict[str, list[str]] = {}
    for r in sorted(rooms):
        by_type.setdefault(scene.rooms[r].type, []).append(r)
    return "\n".join(f"{words(t)}: {', '.join(ids)}" for t, ids in sorted(by_type.items()))


def selection_schema(rooms: Sequence[str], beam: int, constrain_names: bool = True) -> dict:
    """{"rooms": [1..beam room ids]}; the ids enumerated when ``constrain_names``."""
    item = {"type": "string", "enum": sorted(rooms)} if constrain_names else {"type": "string"}
    return {"type": "object", "properties": {"rooms": {"type": "array", "items": item, "minItems": 1,
                                                        "maxItems": int(beam)}},
            "required": ["rooms"], "additionalProperties": False}


def parse_selection(parsed: object, allowed: Iterable[str], beam: int) -> tuple[str, ...]:
    """The valid room ids of a selection answer, first occurrence first, at most ``beam``."""
    ok = set(allowed)
    got = parsed.get("rooms") if isinstance(parsed, dict) else None
    out: list[str] = []
    for r in got if isinstance(got, list) else []:
        if isinstance(r, str) and r in ok and r not in out:
            out.append(r)
    return tuple(out[:beam])


def usable_objects(scene: SceneGraph, rooms: Iterable[str], state: State, exclude: Iterable[str]) -> int:
    """Objects in ``rooms`` a plan may take: not excluded and not in hand."""
    chosen, skip = set(rooms), set(exclude) | {state.holding}
    return sum(1 for o in scene.objects.values()
               if o.id not in skip and o.furniture in scene.furniture and scene.furniture[o.furniture].room in chosen)


def ask_rooms(client, req: PlanRequest, cfg: LLMConfig, *, purpose: str, chosen: Sequence[str],
              attempt: int) -> tuple[str, ...]:
    """One selection request for the plan request ``req`` (``purpose``: the plan request's,
    candidates | regeneration | replan): up to ``llm.room_beam`` rooms not in ``chosen``
    (``attempt``: 0 for the first selection of a command, k for its k-th widening; it is the
    request's sample index)."""
    scene = req.scene
    free = [r for r in sorted(scene.rooms) if r not in set(chosen)]
    if not free:
        return ()
    previous = ("" if not chosen else "These rooms were chosen already and hold too few objects a plan may take: "
                + ", ".join(chosen) + ". Choose other rooms.\n")
    tpl = load_template("select_rooms")
    text = tpl.render(rooms=rooms_text(scene, free), state=req.state.describe(), command=req.command.text,
                      n_objects=req.n_objects, known_costs=known_costs_text(req.known), previous=previous,
                      beam=cfg.room_beam)
    options = LLMOptions(temperature=cfg.plan_sampling_temperature, seed=cfg.seed, top_p=cfg.top_p,
                         max_tokens=cfg.max_tokens, sample_index=attempt)
    resp = complete_or_none(client, LLMRequest(
        purpose=SELECTION_PREFIX + purpose, messages=(Message("user", text),),
        schema=selection_schema(free, cfg.room_beam, cfg.constrain_names), options=options, template=tpl.name,
        context=req.context))
    return parse_selection(None if resp is None else resp.parsed, free, cfg.room_beam)


def select(client, req: PlanRequest, cfg: LLMConfig, *, purpose: str,
           start: Optional[RoomSelection] = None) -> RoomSelection:
    """The rooms for ``req``'s command (``purpose``: the plan request's): ``start`` (a selection
    made earlier for it) or a first selection request, widened while the rooms hold fewer usable
    objects (not in ``req.exclude.objects``) than ``req.n_objects`` or none were chosen, at most
    ``llm.room_widenings`` times (module doc, step 3)."""
    exclude = req.exclude.objects
    sel = start or RoomSelection(ask_rooms(client, req, cfg, purpose=purpose, chosen=(), attempt=0))
    while (not sel.rooms or usable_objects(req.scene, sel.rooms, req.state, exclude) < req.n_objects) \
            and sel.widenings < cfg.room_widenings and len(sel.rooms) < len(req.scene.rooms):
        more = ask_rooms(client, req, cfg, purpose=purpose, chosen=sel.rooms, attempt=sel.widenings + 1)
        sel = RoomSelection(sel.rooms + more, sel.widenings + 1)
    if not sel.rooms and req.state.at_room in req.scene.rooms:
        sel = RoomSelection((req.state.at_room,), sel.widenings)
    return sel
