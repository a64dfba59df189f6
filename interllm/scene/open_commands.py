"""Open-set commands: household goals generated from what a house holds, beside the catalog's 12.

The paper's problem is an open set of human commands over whatever the house holds; the catalog
(``catalog/commands.json``) names 12 commands over the object categories *it* knows, so a house of
other objects (a ProcTHOR house holds ~100 object types) hosts few or none of them. Here a command is
made from the house itself, with ProcTHOR's statistics of what stands where (``procthor_db``):

- a *target* is a category of reachable furniture in a room type ("desk" in a "bedroom");
- what goes on it: the object categories ProcTHOR's scenes put on that receptacle type
  (``receptacles.json``, with their frequencies), among those present and reachable elsewhere in the
  house and plausible in that room type (``placement-annotations.json``: never in that room type
  leaves them out); where the database has no statistics for the furniture (a category of our own
  catalog, e.g. ``nightstand``), the catalog's ``holds`` list, all weighted alike;
- the command asks for the most frequent ``GROUP`` categories ("Put the apple, the bread and the egg
  on the dining table in the kitchen."), then the next ``GROUP`` for a second command of the same
  target, and so on up to ``PER_TARGET`` commands.

Like the catalog's commands, the ground truth accepts any reachable object of the named categories
on any reachable furniture of the target category in a room of the target type, and the mission draw
(``missions``) decides how many objects a command asks for (``mission.objects_per_command``, fewer
when the measurement cannot fill them). Which source a run uses is ``mission.commands``
(``commands_for``): ``catalog``, ``open`` (the catalog's and the generated ones), or ``auto`` (the
catalog's, and the generated ones only for a house that hosts none of them).
"""

from __future__ import annotations

import dataclasses

from interllm.config import MISSION_COMMANDS
from interllm.scene.catalog import Catalog, CommandSpec
from interllm.scene.graph import SceneGraph
from interllm.scene.procthor_db import ProcthorDatabase, load_database
from interllm.scene.procthor_format import ALIASES, snake_case

GROUP = 3  # object categories a generated command names
PER_TARGET = 2  # generated commands per (furniture category, room type)


def our_category(procthor_type: str) -> str:
    """Our category of a ProcTHOR object type, as the importer names it (``CellPhone`` -> ``cellphone``,
    ``CounterTop`` -> ``kitchen_counter``, ``AlarmClock`` -> ``alarm_clock``)."""
    return ALIASES.get(procthor_type.lower(), snake_case(procthor_type))


def procthor_types(db: ProcthorDatabase) -> dict[str, str]:
    """{our category: ProcTHOR type} of every type the database knows."""
    types = {a.object_type for a in db.assets.values()} | set(db.receptacles) | set(db.rooms)
    return {our_category(t): t for t in sorted(types)}


def goes_on(furniture_category: str, room_type: str, db: ProcthorDatabase, cat: Catalog) -> dict[str, float]:
    """{object category: weight} of what stands on ``furniture_category`` (module doc): ProcTHOR's
    receptacle frequencies less the types never seen in ``room_type``, else the catalog's ``holds``."""
    types = procthor_types(db)
    ptype = types.get(furniture_category)
    stats = db.receptacle_objects(ptype) if ptype else {}
    if stats:
        annotated = room_type in ("kitchen", "living_room", "bedroom", "bathroom")
        return {our_category(t): p for t, p in stats.items()
                if p > 0 and not (annotated and t in db.rooms and db.room_frequency(t, room_type) == 0)}
    holds = cat.furniture[furniture_category].holds if furniture_category in cat.furniture else ()
    return {c: 1.0 for c in holds}


def _text(categories: tuple[str, ...], furniture_category: str, room_type: str) -> str:
    names = [f"the {c.replace('_', ' ')}" for c in categories]
    listed = names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
    return f"Put {listed} on the {furniture_category.replace('_', ' ')} in the {room_type.replace('_', ' ')}."


def open_commands(scene: SceneGraph, cat: Catalog, db: ProcthorDatabase | None = None) -> tuple[CommandSpec, ...]:
    """The commands generated for ``scene`` (module doc), sorted by target then by frequency; ids
    ``put_<categories>_on_<furniture>_in_<room type>``. A command names only categories with a
    reachable instance that is not on a furniture of its target."""
    db = db or load_database()
    out = []
    targets = sorted({(f.category, scene.rooms[f.room].type) for f in scene.furniture.values() if not f.unreachable})
    for fcat, rtype in targets:
        on_target = {f.id for f in scene.furniture.values() if f.category == fcat and scene.rooms[f.room].type == rtype}
        present = {o.category for o in scene.objects.values()
                   if not o.unreachable and o.placement != "inside" and o.furniture not in on_target}
        weights = goes_on(fcat, rtype, db, cat)
        ranked = sorted((c for c in present if weights.get(c, 0) > 0), key=lambda c: (-weights[c], c))
        for g in range(PER_TARGET):
            group = tuple(ranked[g * GROUP:(g + 1) * GROUP])
            if not group:
                break
            cid = f"put_{'_'.join(group)}_on_{fcat}_in_{rtype}"
            out.append(CommandSpec(cid, _text(group, fcat, rtype), group, (fcat,), rtype))
    return tuple(out)


def hosts_a_catalog_command(scene: SceneGraph, cat: Catalog, n_objects: int) -> bool:
    """Whether some catalog command has a reachable target and ``n_objects`` reachable instances."""
    return any(c.resolve_targets(scene) and len(c.valid_objects(scene)) >= n_objects for c in cat.commands)


def commands_for(scene: SceneGraph, cat: Catalog, source: str, n_objects: int,
                 db: ProcthorDatabase | None = None) -> Catalog:
    """The catalog a scene's missions draw from under ``mission.commands=source`` (module doc): the
    catalog itself, or the catalog with the house's generated commands after its own."""
    if source not in MISSION_COMMANDS:
        raise ValueError(f"mission.commands={source!r}; valid choices: {MISSION_COMMANDS}")
    if source == "catalog" or (source == "auto" and hosts_a_catalog_command(scene, cat, n_objects)):
        return cat
    known = {c.id for c in cat.commands}
    extra = tuple(c for c in open_commands(scene, cat, db) if c.id not in known)
    return dataclasses.replace(cat, commands=cat.commands + extra)
