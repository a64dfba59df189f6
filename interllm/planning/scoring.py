"""Score mode: the LLM only ranks continuations (``client.score``), for models that cannot write
plans (the embedded 270M base model), calibrated against a content-free prompt (command "N/A")
when ``llm.calibrate``:

1. object categories present in the scene for the command text;
2. instances, hierarchically (as SayPlan expands a collapsed scene graph): room types as the place
   of the useful items ("Useful items are in the:"); the ``llm.room_beam`` rooms ranked highest by
   their type's score plus the best category score among their objects are expanded, then the
   ``llm.furniture_beam`` furniture in them with the best category score, and only the objects on
   those are scored as "<category> on the <furniture category> in the <room type>" (instance
   score = category score + instance-phrase score). An object outside the beam scores its
   category plus its room type's score less ``OUT_OF_BEAM``: never preferred, still there when the
   beam runs out of eligible objects. So the tokens per command grow with the catalog (categories,
   room types), not with the house (a beam of 0 expands everything: one phrase per object);
3. the target furniture: its category after "Put them on the:" plus its room type after
   "Room:" (few-shot templates; see ``SCORE_MODES`` for the measured score combination).

The goal's ``target_furniture`` is ground truth for metrics and is never read here; only
``goal.n_objects`` (how many objects the command asks for) is used. Plans are assembled
navigate -> pickup -> navigate -> place per object, and M distinct candidates ((object set,
target) pairs) are sampled from softmax(scores / temperature) with a seeded numpy Generator
(Gumbel top-k = sequential sampling without replacement); temperature 0 gives the argmax first and
then the next best combinations. Repair re-assembles a plan's deliveries from the current scene
graph (inserting the missing navigate, fixing the furniture an object is actually on) and replaces
infeasible choices (unknown ids, excluded or already-delivered objects, unknown target) by the next
best remaining ones. Cost inference scores " easy", " medium", " hard", " unknown" after a prompt
listing the measured actions and samples at the temperature.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Optional

import numpy as np

from interllm.config import LLMConfig
from interllm.core.actions import Action, Plan, State
from interllm.core.seeding import planning_seed
from interllm.llm.prompts import load_template
from interllm.llm.types import ScoreRequest
from interllm.planning.costs import COST_LABELS
from interllm.planning.memory import KnownCosts
from interllm.planning.plans import assemble_plan
from interllm.planning.request import Exclusions, PlanRequest
from interllm.planning.text import (
    action_placement,
    describe_manipulation,
    known_costs_text,
    known_manipulations_text,
    words,
)
from interllm.scene.graph import Command, SceneGraph

CALIBRATION_COMMAND = "N/A"
OUT_OF_BEAM = 100.0  # score penalty of an object outside the expanded rooms and furniture (module doc)


@dataclass
class SemanticScores:
    """Calibrated LLM scores for one command (higher = more relevant)."""

    categories: dict[str, float] = field(default_factory=dict)
    instances: dict[str, float] = field(default_factory=dict)  # object id -> score
    targets: dict[str, float] = field(default_factory=dict)  # furniture id -> score
    # objects scoring below this are never proposed (the oracle: irrelevant ones); None: any object
    floor: Optional[float] = None

    def to_dict(self) -> dict:
        return {"categories": self.categories, "instances": self.instances, "targets": self.targets}


def _instance_phrase(scene: SceneGraph, obj_id: str) -> str:
    o = scene.objects[obj_id]
    f = scene.furniture[o.furniture]
    return f" {words(o.category)} on the {words(f.category)} in the {words(scene.rooms[f.room].type)}"


# How each scoring purpose combines the raw score r = mean log p(c | prompt) with the calibrated
# one k = r − mean log p(c | content-free prompt), when ``llm.calibrate`` (else always raw):
# "cal" = k, "half" = r + k, "raw" = r. Chosen by measurement with the embedded 270M model over the
# 12 catalog commands (top-5 category precision / top-1 target accuracy against the catalog's
# ground truth; the few-shot templates below, `python benchmarks/bench_scoring.py`):
# categories: cal 0.58 vs half 0.48 vs raw 0.37; target furniture: raw 0.92 vs half 0.83 vs cal
# 0.67; target room: half 1.00 vs raw 0.90 vs cal 0.90.
SCORE_MODES = {"score_objects": "cal", "score_instances": "half", "score_target": "raw",
               "score_target_room": "half", "score_source_room": "half", "score_cost": "half"}


def _score(client, purpose: str, tpl, fields: dict, continuations: Sequence[str], *, calibrate: bool,
           context: tuple, cal_field: str = "command") -> list[float]:
    """Scores of the continuations, combined per ``SCORE_MODES[purpose]`` (see above); the
    content-free prompt has ``CALIBRATION_COMMAND`` in the field ``cal_field``."""
    mode = SCORE_MODES.get(purpose, "half") if calibrate else "raw"
    prompt = tpl.render(**fields).rstrip("\n")
    cal = tpl.render(**{**fields, cal_field: CALIBRATION_COMMAND}).rstrip("\n") if mode != "raw" else None
    resp = client.score(ScoreRequest(purpose=purpose, prompt=prompt, continuations=tuple(continuations),
                                     calibration_prompt=cal, template=tpl.name, context=context))
    if mode == "half":
        scores = [float(r) + float(c) for r, c in zip(resp.raw, resp.scores, strict=False)]
    elif mode == "cal":
        scores = [float(c) for c in resp.scores]
    else:
        scores = [float(r) for r in resp.raw]
    if len(scores) != len(continuations) or not all(np.isfinite(scores)):
        raise RuntimeError(f"LLM scoring for {purpose!r} returned {len(scores)} scores for "
                           f"{len(continuations)} continuations or non-finite values: {scores}")
    return scores


def score_command(client, scene: SceneGraph, command: Command, cfg: LLMConfig, *,
                  known: Optional[KnownCosts] = None, context: tuple = (), history: str = "") -> SemanticScores:
    """Score categories, instances and target furniture of ``scene`` for ``command.text``.

    Few-shot prompts (``score_objects``, ``score_source_room``, ``score_target``, ``score_room``
    templates) and a per-purpose calibration mode (``SCORE_MODES``). Target score of a furniture =
    score of its category + score of its room type (both short continuations: mean token log-probs
    of long phrases are dominated by the shared words). Instance score = category score + score of
    "<category> on the <furniture> in the <room>" for the objects the hierarchy expands (module doc).
    ``history``: text shown before the request after the known costs (a replan's execution so far
    and failure, ``text.execution_text``)."""
    if not scene.objects or not scene.furniture:
        raise ValueError(f"scene {scene.id!r} has no objects or no furniture to plan with")
    kc = known_costs_text(known)
    cats = sorted({o.category for o in scene.objects.values()})
    tpl_o = load_template("score_objects")
    base = {"known_costs": kc + history, "command": command.text}
    cat_scores = _score(client, "score_objects", tpl_o, {**base, "query": "Useful item:"},
                        [f" {words(c)}" for c in cats], calibrate=cfg.calibrate, context=context)
    categories = dict(zip(cats, cat_scores, strict=True))
    instances = _score_instances(client, scene, cfg, categories=categories, base=base, context=context)
    fcats = sorted({f.category for f in scene.furniture.values()})
    rtypes = sorted({r.type for r in scene.rooms.values()})
    fsc = dict(zip(fcats, _score(client, "score_target", load_template("score_target"),
                                 {**base, "query": "Put them on the:"},
                                 [f" {words(c)}" for c in fcats], calibrate=cfg.calibrate, context=context),
                   strict=True))
    rsc = dict(zip(rtypes, _score(client, "score_target_room", load_template("score_room"),
                                  {**base, "query": "Room:"},
                                  [f" {words(r)}" for r in rtypes], calibrate=cfg.calibrate, context=context),
                   strict=True))
    targets = {f.id: fsc[f.category] + rsc[scene.rooms[f.room].type] for f in scene.furniture.values()}
    return SemanticScores(categories, instances, dict(sorted(targets.items())))


def expanded_objects(scene: SceneGraph, categories: dict[str, float], room_types: dict[str, float],
                     room_beam: int, furniture_beam: int) -> list[str]:
    """The objects on the furniture the hierarchy expands (module doc, step 2): the ``room_beam``
    rooms with the highest room-type score + best category score of their objects, then the
    ``furniture_beam`` furniture in them with the best category score of their objects (0: all)."""
    def best(objs) -> float:
        return max((categories[o.category] for o in objs), default=-np.inf)

    by_furniture = {f: scene.objects_on(f) for f in sorted(scene.furniture)}
    rooms = sorted({scene.furniture[f].room for f, objs in by_furniture.items() if objs})
    room_score = {r: room_types.get(scene.rooms[r].type, 0.0)
                  + best(o for f, objs in by_furniture.items() if scene.furniture[f].room == r for o in objs)
                  for r in rooms}
    kept_rooms = sorted(rooms, key=lambda r: (-room_score[r], r))[:room_beam or None]
    furniture = [f for f, objs in by_furniture.items() if objs and scene.furniture[f].room in kept_rooms]
    kept = sorted(furniture, key=lambda f: (-best(by_furniture[f]), f))[:furniture_beam or None]
    return sorted(o.id for f in kept for o in by_furniture[f])


def _score_instances(client, scene: SceneGraph, cfg: LLMConfig, *, categories: dict[str, float], base: dict,
                     context: tuple) -> dict[str, float]:
    """Instance scores (module doc, step 2): room types, then the phrases of the expanded objects."""
    def room_type(oid: str) -> str:
        return scene.rooms[scene.furniture[scene.objects[oid].furniture].room].type

    rtypes = sorted({room_type(o) for o in scene.objects})
    if cfg.room_beam or cfg.furniture_beam:
        rsc = _score(client, "score_source_room", load_template("score_source_room"),
                     {**base, "query": "Useful items are in the:"}, [f" {words(r)}" for r in rtypes],
                     calibrate=cfg.calibrate, context=context)
        room_types = dict(zip(rtypes, rsc, strict=True))
    else:
        room_types = {r: 0.0 for r in rtypes}
    expanded = expanded_objects(scene, categories, room_types, cfg.room_beam, cfg.furniture_beam)
    inst = _score(client, "score_instances", load_template("score_objects"),
                  {**base, "query": "Useful item and where it is:"},
                  [_instance_phrase(scene, o) for o in expanded], calibrate=cfg.calibrate, context=context)
    phrase = dict(zip(expanded, inst, strict=True))
    return {o: categories[scene.objects[o].category] + phrase.get(o, room_types[room_type(o)] - OUT_OF_BEAM)
            for o in sorted(scene.objects)}


def _eligible_objects(scene: SceneGraph, state: State, target: str, exclude: set[str],
                      scores: Optional[SemanticScores] = None) -> list[str]:
    """Objects a plan to ``target`` may take: not excluded, not held, not on the target, and not
    below ``scores.floor`` when the scores set one."""
    floor = None if scores is None else scores.floor
    return [o for o in sorted(scene.objects) if o not in exclude and o != state.holding
            and scene.objects[o].furniture != target
            and (floor is None or scores.instances.get(o, -1e9) >= floor)]


def sample_selections(scores: SemanticScores, scene: SceneGraph, state: State, *, n_objects: int, n_plans: int,
                      temperature: float, rng: np.random.Generator, exclude: Exclusions = Exclusions(),
                      diversity: str = "plans") -> list[tuple[tuple[str, ...], str]]:
    """Up to ``n_plans`` distinct (ordered objects, target) selections of ``n_objects`` objects in
    ``scene`` from ``state``, avoiding ``exclude``; see the module docstring.

    diversity: "plans": selections differ in (object set, target); "objects": first selections that
    differ in their object sets, then, if the house offers fewer than n_plans such sets, ones that differ
    in the target only (``llm.candidate_diversity``)."""
    if diversity == "objects":
        first = _sample_selections(scores, scene, state, n_objects=n_objects, n_plans=n_plans,
                                   temperature=temperature, rng=rng, exclude=exclude, by_objects=True)
        if len(first) < n_plans:
            seen = {(frozenset(o), t) for o, t in first}
            more = _sample_selections(scores, scene, state, n_objects=n_objects, n_plans=n_plans,
                                      temperature=temperature, rng=rng, exclude=exclude, by_objects=False)
            first += [(o, t) for o, t in more if (frozenset(o), t) not in seen][:n_plans - len(first)]
        return first
    return _sample_selections(scores, scene, state, n_objects=n_objects, n_plans=n_plans, temperature=temperature,
                              rng=rng, exclude=exclude, by_objects=False)


def _sample_selections(scores: SemanticScores, scene: SceneGraph, state: State, *, n_objects: int, n_plans: int,
                       temperature: float, rng: np.random.Generator, exclude: Exclusions,
                       by_objects: bool) -> list[tuple[tuple[str, ...], str]]:
    """``sample_selections`` with one notion of distinct: by object set alone (``by_objects``) or by
    (object set, target)."""
    excl = set(exclude.objects)
    targets = [f for f in sorted(scores.targets) if f in scene.furniture and f not in set(exclude.targets)]
    above = [f for f in targets if scores.floor is None or scores.targets[f] >= scores.floor]
    targets = above or targets  # every answered target excluded: the others stay possible
    if not targets:
        raise ValueError("no target furniture left to choose from (all excluded)")
    n_held = 1 if state.holding is not None else 0
    n = max(n_objects - n_held, 0)
    out: list[tuple[tuple[str, ...], str]] = []
    seen: set = set()

    def add(objs: tuple[str, ...], tgt: str) -> None:
        key = frozenset(objs) if by_objects else (frozenset(objs), tgt)
        if n and not objs:  # nothing left to take to this target
            return
        if key not in seen and len(out) < n_plans:
            seen.add(key)
            out.append((objs, tgt))

    def ranked(tgt: str) -> list[str]:
        el = _eligible_objects(scene, state, tgt, excl, scores)
        return sorted(el, key=lambda o: (-scores.instances.get(o, -1e9), o))

    if temperature > 0:
        t_logit = np.array([scores.targets[f] for f in targets]) / temperature
        p = np.exp(t_logit - t_logit.max())
        p /= p.sum()
        for _ in range(50 * n_plans):
            if len(out) >= n_plans:
                break
            tgt = targets[int(rng.choice(len(targets), p=p))]
            el = _eligible_objects(scene, state, tgt, excl, scores)
            keys = np.array([scores.instances.get(o, -1e9) for o in el]) / temperature
            keys = keys + rng.gumbel(size=len(el))
            order = np.argsort(-keys, kind="stable")[:n]
            add(tuple(el[i] for i in order), tgt)
    if len(out) < n_plans:
        # deterministic: best combinations by summed score (argmax first, then next best)
        t_sorted = sorted(targets, key=lambda f: (-scores.targets[f], f))[:n_plans]
        combos = []
        for tgt in t_sorted:
            r = ranked(tgt)
            pool = r[:min(len(r), n + min(n_plans - 1, 4))]
            for comb in itertools.combinations(pool, min(n, len(pool))):
                objs = tuple(sorted(comb, key=lambda o: (-scores.instances.get(o, -1e9), o)))
                total = scores.targets[tgt] + sum(scores.instances.get(o, -1e9) for o in objs)
                combos.append((-total, tgt, objs))
        for _, tgt, objs in sorted(combos):
            add(objs, tgt)
    return out


def propose_by_scores(scores: SemanticScores, req: PlanRequest, *, n_plans: int, temperature: float, seed: int,
                      diversity: str = "plans") -> list[Plan]:
    """Up to ``n_plans`` plans for ``req`` sampled from ``scores`` (``sample_selections``, a numpy
    Generator seeded with ``seed``) and assembled from its scene graph and state."""
    rng = np.random.default_rng(seed)
    sels = sample_selections(scores, req.scene, req.state, n_objects=req.n_objects, n_plans=n_plans,
                             temperature=temperature, rng=rng, exclude=req.exclude, diversity=diversity)
    return [assemble_plan(req.scene, req.state, objs, tgt) for objs, tgt in sels]


def repair_by_scores(plan: Plan, scores: SemanticScores, req: PlanRequest) -> Plan:
    """Score-mode regeneration: re-assemble the plan's deliveries from ``req``'s scene graph,
    replacing infeasible choices with the next best remaining ones."""
    scene, state, n_objects = req.scene, req.state, req.n_objects
    excl = set(req.exclude.objects)
    targets = [a.furniture for a in plan if a.kind == "place" and a.furniture in scene.furniture
               and a.furniture not in set(req.exclude.targets)]
    if targets:
        target = targets[-1]
    else:
        cands = [f for f in scores.targets if f in scene.furniture and f not in set(req.exclude.targets)]
        if not cands:
            raise ValueError("no target furniture left to repair the plan with")
        target = min(cands, key=lambda f: (-scores.targets[f], f))
    n = max(n_objects - (1 if state.holding is not None else 0), 0)
    eligible = set(_eligible_objects(scene, state, target, excl, scores))
    objs: list[str] = []
    for a in plan:
        if a.kind in ("pickup", "place") and a.obj in eligible and a.obj not in objs:
            objs.append(a.obj)
    objs = objs[:n]
    for o in sorted(eligible, key=lambda o: (-scores.instances.get(o, -1e9), o)):
        if len(objs) >= n:
            break
        if o not in objs:
            objs.append(o)
    return assemble_plan(scene, state, objs, target)


def infer_cost_by_scores(client, action: Action, scene: SceneGraph, known: KnownCosts, cfg: LLMConfig, *,
                         seed_parts: Sequence[Any] = (), context: tuple = ()) -> str:
    """ĉ^text(a_man) in {easy, medium, hard, unknown} by scoring the four labels and sampling one
    at the temperature. With no measured manipulation yet there is nothing to compare with:
    "unknown" is returned without an LLM call."""
    known_text = known_manipulations_text(known, scene, cfg.placement_attributes)
    if not known_text:
        return "unknown"
    desc = describe_manipulation(action, scene, action_placement(action, scene) if cfg.placement_attributes else None)
    tpl = load_template("score_cost")
    scores = _score(client, "score_cost", tpl, {"known": known_text, "action": desc},
                    [f" {c}" for c in COST_LABELS], calibrate=cfg.calibrate, context=context, cal_field="action")
    return sample_label(scores, cfg.temperature,
                        planning_seed(cfg.seed, "cost_inference", *seed_parts, str(action)))


def sample_label(scores: Sequence[float], temperature: float, seed: int) -> str:
    """Sample one of COST_LABELS from softmax(scores / temperature) (argmax at temperature 0)."""
    s = np.asarray(scores, dtype=float)
    if temperature <= 0:
        return COST_LABELS[int(np.argmax(s))]
    z = s / temperature
    p = np.exp(z - z.max())
    p /= p.sum()
    return COST_LABELS[int(np.random.default_rng(seed).choice(len(p), p=p))]
