"""How plan candidates and manipulation-cost inferences are proposed by the LLM.

Two modes (``llm.proposal_mode`` for plans, ``llm.cost_inference_mode`` for costs):

``generate`` (the paper's): the LLM writes plans as JSON under a schema (one plan per call;
candidate j uses ``sample_index=j`` and is asked to differ from the plans already written). With
``llm.constrain_names`` the schema enumerates the valid ids of the scene graph. Regeneration
feeds the feasibility checker's violation texts back; MoMa-LLM's replan feeds the execution
failure text back. Cost inference asks for {"cost": easy|medium|hard|unknown}.

``score`` (default for the embedded 270M base model, which cannot write plans): the LLM only
ranks continuations (``client.score``), calibrated against a content-free prompt
(command "N/A") when ``llm.calibrate``:
  1. object categories present in the scene for the command text;
  2. instances: "<category> on the <furniture category> in the <room type>" (instance score =
     category score + instance-phrase score);
  3. the target furniture: its category after "Put them on the:" plus its room type after
     "Room:" (few-shot templates; see ``SCORE_MODES`` for the measured score combination).
  The goal's ``target_furniture`` is ground truth for metrics and is never read here; only
  ``goal.n_objects`` (how many objects the command asks for) is used.
  Plans are assembled navigate -> pickup -> navigate -> place per object, and M distinct
  candidates ((object set, target) pairs) are sampled from softmax(scores / temperature) with a
  seeded numpy Generator (Gumbel top-k = sequential sampling without replacement); temperature 0
  gives the argmax first and then the next best combinations. Regeneration in score mode is a
  repair: the plan's deliveries are re-assembled from the current scene graph (inserting the
  missing navigate, fixing the furniture an object is actually on) and infeasible choices
  (unknown ids, excluded or already-delivered objects, unknown target) are replaced by the next
  best remaining ones. Cost inference scores " easy", " medium", " hard", " unknown" after a
  prompt listing the measured actions and samples at the temperature.

Seeds are derived with sha256 of strings (never ``hash()``), so runs are reproducible.
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Optional

import numpy as np

from interllm.config import ExperimentConfig
from interllm.core.actions import Action, Plan, State, plan_from_list, plan_to_list
from interllm.core.seeding import planning_seed
from interllm.llm.types import LLMOptions, LLMRequest, Message, ScoreRequest
from interllm.planning.costs import COST_LABELS, encode_cost
from interllm.planning.feasibility import FeasibilityReport
from interllm.planning.memory import KnownCosts
from interllm.scene.graph import Command, SceneGraph

CALIBRATION_COMMAND = "N/A"


def _template(name: str):
    from interllm.llm.prompts import load_template

    return load_template(name)


def _words(s: str) -> str:
    return s.replace("_", " ")


# ---------------------------------------------------------------------------------------------
# text views of the scene, state and known costs
# ---------------------------------------------------------------------------------------------
def scene_json(scene: SceneGraph) -> str:
    return json.dumps(scene.to_prompt_dict(), sort_keys=True, separators=(",", ":"))


def describe_manipulation(action: Action, scene: SceneGraph) -> str:
    """'pickup mug (for drinking) from the desk in the office' — location, category, usage."""
    o = scene.objects.get(action.obj or "")
    f = scene.furniture.get(action.furniture)
    cat = _words(o.category) if o else str(action.obj)
    usage = f" ({o.usage})" if o and o.usage else ""
    if f is not None:
        room = scene.rooms.get(f.room)
        loc = f"the {_words(f.category)} in the {_words(room.type) if room else f.room}"
    else:
        loc = f"the {action.furniture}"
    prep = "from" if action.kind == "pickup" else "on"
    return f"{action.kind} {cat}{usage} {prep} {loc}"


def known_manipulations_text(known: Optional[KnownCosts], scene: SceneGraph) -> str:
    if known is None or not known.maned:
        return ""
    return "\n".join(f"- {describe_manipulation(r.action, scene)}: {encode_cost(r.cost)}"
                     for r in known.maned)


def known_costs_text(known: Optional[KnownCosts], scene: SceneGraph) -> str:
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


def _options(cfg: ExperimentConfig, sample_index: int = 0, temperature: Optional[float] = None) -> LLMOptions:
    return LLMOptions(temperature=cfg.llm.temperature if temperature is None else temperature,
                      seed=cfg.llm.seed, top_p=cfg.llm.top_p, max_tokens=cfg.llm.max_tokens,
                      sample_index=sample_index)


# ---------------------------------------------------------------------------------------------
# generate mode
# ---------------------------------------------------------------------------------------------
def plan_schema(scene: SceneGraph, constrain_names: bool = True) -> dict:
    """JSON schema of one plan {"actions": [...]}; ids enumerated when ``constrain_names``."""
    def ids(d):
        return {"type": "string", "enum": sorted(d) + [""]} if constrain_names else {"type": "string"}

    action = {
        "type": "object",
        "properties": {
            "action": {"type": "string", "enum": ["navigate", "pickup", "place"]},
            "furniture": ({"type": "string", "enum": sorted(scene.furniture)} if constrain_names
                          else {"type": "string"}),
            "room": ids(scene.rooms),
            "object": ids(scene.objects),
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


def _complete(client, request: LLMRequest):
    """client.complete, with an answer that stays malformed after the client's repair retries
    turned into ``None`` (an empty, infeasible plan the feasibility loop then handles)."""
    from interllm.llm.client import LLMOutputError

    try:
        return client.complete(request)
    except LLMOutputError:
        return None


def _parsed(resp) -> Any:
    return None if resp is None else resp.parsed


def _plan_text(plan: Plan) -> str:
    return "\n".join(f"{i + 1}. {a}" for i, a in enumerate(plan)) or "(empty)"


def _static_fields(scene: SceneGraph, state: State, command: Command, n_objects: int,
                   known: Optional[KnownCosts]) -> dict:
    return {"scene_json": scene_json(scene), "state": state.describe(), "command": command.text,
            "n_objects": n_objects, "known_costs": known_costs_text(known, scene)}


def generate_plans(client, scene: SceneGraph, state: State, command: Command, cfg: ExperimentConfig,
                   M: int, n_objects: int, known: Optional[KnownCosts] = None,
                   context: tuple = ()) -> list[Plan]:
    """``M`` plans written by the LLM, one call per plan (sample_index j)."""
    tpl = _template("candidates")
    schema = plan_schema(scene, cfg.llm.constrain_names)
    plans: list[Plan] = []
    for j in range(M):
        prev = ""
        if plans:
            prev = "\nPlans already proposed (write a different one):\n" + "\n".join(
                f"Plan {k + 1}: " + "; ".join(str(a) for a in p) for k, p in enumerate(plans)) + "\n"
        text = tpl.render(previous=prev, **_static_fields(scene, state, command, n_objects, known))
        resp = _complete(client, LLMRequest(purpose="candidates", messages=(Message("user", text),),
                                          schema=schema, options=_options(cfg, j), template=tpl.name,
                                          context=context))
        plans.append(parse_plan(_parsed(resp)))
    return plans


def regenerate_plan_llm(client, scene: SceneGraph, state: State, command: Command, cfg: ExperimentConfig,
                        plan: Plan, report: FeasibilityReport, n_objects: int, attempt: int,
                        sample_index: int = 0, known: Optional[KnownCosts] = None,
                        context: tuple = ()) -> Plan:
    tpl = _template("regeneration")
    text = tpl.render(plan=_plan_text(plan), feedback=report.feedback() or "(none)",
                      **_static_fields(scene, state, command, n_objects, known))
    resp = _complete(client, LLMRequest(
        purpose="regeneration", messages=(Message("user", text),),
        schema=plan_schema(scene, cfg.llm.constrain_names),
        options=_options(cfg, sample_index * 100 + attempt + 1), template=tpl.name, context=context))
    return parse_plan(_parsed(resp))


def replan_llm(client, scene: SceneGraph, state: State, command: Command, cfg: ExperimentConfig,
               executed: Sequence[str], failure: str, n_objects: int, excluded: Sequence[str],
               attempt: int, context: tuple = ()) -> Plan:
    tpl = _template("replan")
    text = tpl.render(scene_json=scene_json(scene), state=state.describe(), command=command.text,
                      executed="\n".join(executed) or "(nothing)", failure=failure,
                      excluded=", ".join(excluded) or "(none)", n_objects=n_objects)
    resp = _complete(client, LLMRequest(
        purpose="replan", messages=(Message("user", text),),
        schema=plan_schema(scene, cfg.llm.constrain_names), options=_options(cfg, attempt),
        template=tpl.name, context=context))
    return parse_plan(_parsed(resp))


# ---------------------------------------------------------------------------------------------
# score mode
# ---------------------------------------------------------------------------------------------
@dataclass
class SemanticScores:
    """Calibrated LLM scores for one command (higher = more relevant)."""

    categories: dict[str, float] = field(default_factory=dict)
    instances: dict[str, float] = field(default_factory=dict)  # object id -> score
    targets: dict[str, float] = field(default_factory=dict)  # furniture id -> score

    def to_dict(self) -> dict:
        return {"categories": self.categories, "instances": self.instances, "targets": self.targets}


def _instance_phrase(scene: SceneGraph, obj_id: str) -> str:
    o = scene.objects[obj_id]
    f = scene.furniture[o.furniture]
    return f" {_words(o.category)} on the {_words(f.category)} in the {_words(scene.rooms[f.room].type)}"


# How each scoring purpose combines the raw score r = mean log p(c | prompt) with the calibrated
# one k = r − mean log p(c | content-free prompt), when ``llm.calibrate`` (else always raw):
# "cal" = k, "half" = r + k, "raw" = r. Chosen by measurement with the embedded 270M model over the
# 12 catalog commands (top-5 category precision / top-1 target accuracy against the catalog's
# ground truth; the few-shot templates below, `python benchmarks/bench_scoring.py`):
# categories: cal 0.58 vs half 0.48 vs raw 0.37; target furniture: raw 0.92 vs half 0.83 vs cal
# 0.67; target room: half 1.00 vs raw 0.90 vs cal 0.90.
SCORE_MODES = {"score_objects": "cal", "score_instances": "half", "score_target": "raw",
               "score_target_room": "half", "score_cost": "half"}


def _score(client, purpose: str, tpl, fields: dict, continuations: Sequence[str], calibrate: bool,
           context: tuple, cal_field: str, cal_value: str) -> list[float]:
    """Scores of the continuations, combined per ``SCORE_MODES[purpose]`` (see above)."""
    mode = SCORE_MODES.get(purpose, "half") if calibrate else "raw"
    prompt = tpl.render(**fields).rstrip("\n")
    cal = tpl.render(**{**fields, cal_field: cal_value}).rstrip("\n") if mode != "raw" else None
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


def score_command(client, scene: SceneGraph, command: Command, cfg: ExperimentConfig,
                  known: Optional[KnownCosts] = None, context: tuple = ()) -> SemanticScores:
    """Score categories, instances and target furniture of ``scene`` for ``command.text``.

    Few-shot prompts (``score_objects``, ``score_target``, ``score_room`` templates) and a
    per-purpose calibration mode (``SCORE_MODES``). Target score of a furniture = score of its
    category + score of its room type (both short continuations: mean token log-probs of long
    phrases are dominated by the shared words). Instance score = category score + score of
    "<category> on the <furniture> in the <room>".
    """
    if not scene.objects or not scene.furniture:
        raise ValueError(f"scene {scene.id!r} has no objects or no furniture to plan with")
    kc = known_costs_text(known, scene)
    cats = sorted({o.category for o in scene.objects.values()})
    tpl_o = _template("score_objects")
    base = {"known_costs": kc, "command": command.text}
    cat_scores = _score(client, "score_objects", tpl_o, {**base, "query": "Useful item:"},
                        [f" {_words(c)}" for c in cats], cfg.llm.calibrate, context,
                        "command", CALIBRATION_COMMAND)
    categories = dict(zip(cats, cat_scores, strict=True))
    obj_ids = sorted(scene.objects)
    inst = _score(client, "score_instances", tpl_o, {**base, "query": "Useful item and where it is:"},
                  [_instance_phrase(scene, o) for o in obj_ids], cfg.llm.calibrate, context,
                  "command", CALIBRATION_COMMAND)
    instances = {o: categories[scene.objects[o].category] + s for o, s in zip(obj_ids, inst, strict=True)}
    fcats = sorted({f.category for f in scene.furniture.values()})
    rtypes = sorted({r.type for r in scene.rooms.values()})
    fsc = dict(zip(fcats, _score(client, "score_target", _template("score_target"),
                                 {**base, "query": "Put them on the:"},
                                 [f" {_words(c)}" for c in fcats], cfg.llm.calibrate, context,
                                 "command", CALIBRATION_COMMAND), strict=True))
    rsc = dict(zip(rtypes, _score(client, "score_target_room", _template("score_room"),
                                  {**base, "query": "Room:"},
                                  [f" {_words(r)}" for r in rtypes], cfg.llm.calibrate, context,
                                  "command", CALIBRATION_COMMAND), strict=True))
    targets = {f.id: fsc[f.category] + rsc[scene.rooms[f.room].type] for f in scene.furniture.values()}
    return SemanticScores(categories, instances, dict(sorted(targets.items())))


def assemble_plan(scene: SceneGraph, state: State, objects: Sequence[str], target: str) -> Plan:
    """navigate -> pickup -> navigate -> place for each object (a held object is delivered first);
    a navigate to the furniture the robot is already at is omitted."""
    out: list[Action] = []
    cur = state.at_furniture

    def go(fid: str) -> None:
        nonlocal cur
        if cur != fid:
            out.append(Action("navigate", fid, room=scene.furniture[fid].room))
            cur = fid

    if state.holding is not None:
        go(target)
        out.append(Action("place", target, obj=state.holding))
    for o in objects:
        f = scene.objects[o].furniture
        go(f)
        out.append(Action("pickup", f, obj=o))
        go(target)
        out.append(Action("place", target, obj=o))
    return tuple(out)


def _eligible_objects(scene: SceneGraph, state: State, target: str, exclude: set[str]) -> list[str]:
    return [o for o in sorted(scene.objects) if o not in exclude and o != state.holding
            and scene.objects[o].furniture != target]


def sample_selections(scores: SemanticScores, scene: SceneGraph, state: State, n_objects: int, M: int,
                      temperature: float, rng: np.random.Generator, exclude_objects: Sequence[str] = (),
                      exclude_targets: Sequence[str] = ()) -> list[tuple[tuple[str, ...], str]]:
    """Up to ``M`` distinct (ordered objects, target) selections; see the module docstring."""
    excl = set(exclude_objects)
    targets = [f for f in sorted(scores.targets) if f in scene.furniture and f not in set(exclude_targets)]
    if not targets:
        raise ValueError("no target furniture left to choose from (all excluded)")
    n_held = 1 if state.holding is not None else 0
    n = max(n_objects - n_held, 0)
    out: list[tuple[tuple[str, ...], str]] = []
    seen: set = set()

    def add(objs: tuple[str, ...], tgt: str) -> None:
        key = (frozenset(objs), tgt)
        if key not in seen and len(out) < M:
            seen.add(key)
            out.append((objs, tgt))

    def ranked(tgt: str) -> list[str]:
        el = _eligible_objects(scene, state, tgt, excl)
        return sorted(el, key=lambda o: (-scores.instances.get(o, -1e9), o))

    if temperature > 0:
        t_logit = np.array([scores.targets[f] for f in targets]) / temperature
        p = np.exp(t_logit - t_logit.max())
        p /= p.sum()
        for _ in range(50 * M):
            if len(out) >= M:
                break
            tgt = targets[int(rng.choice(len(targets), p=p))]
            el = _eligible_objects(scene, state, tgt, excl)
            keys = np.array([scores.instances.get(o, -1e9) for o in el]) / temperature
            keys = keys + rng.gumbel(size=len(el))
            order = np.argsort(-keys, kind="stable")[:n]
            add(tuple(el[i] for i in order), tgt)
    if len(out) < M:
        # deterministic: best combinations by summed score (argmax first, then next best)
        t_sorted = sorted(targets, key=lambda f: (-scores.targets[f], f))[:M]
        combos = []
        for tgt in t_sorted:
            r = ranked(tgt)
            pool = r[:min(len(r), n + min(M - 1, 4))]
            for comb in itertools.combinations(pool, min(n, len(pool))):
                objs = tuple(sorted(comb, key=lambda o: (-scores.instances.get(o, -1e9), o)))
                total = scores.targets[tgt] + sum(scores.instances.get(o, -1e9) for o in objs)
                combos.append((-total, tgt, objs))
        for _, tgt, objs in sorted(combos):
            add(objs, tgt)
    return out


def propose_by_scores(scores: SemanticScores, scene: SceneGraph, state: State, n_objects: int, M: int,
                      temperature: float, seed: int, exclude_objects: Sequence[str] = (),
                      exclude_targets: Sequence[str] = ()) -> list[Plan]:
    rng = np.random.default_rng(seed)
    sels = sample_selections(scores, scene, state, n_objects, M, temperature, rng, exclude_objects,
                             exclude_targets)
    return [assemble_plan(scene, state, objs, tgt) for objs, tgt in sels]


def repair_by_scores(plan: Plan, scores: SemanticScores, scene: SceneGraph, state: State, n_objects: int,
                     exclude_objects: Sequence[str] = (), exclude_targets: Sequence[str] = ()) -> Plan:
    """Score-mode regeneration: re-assemble the plan's deliveries from the current scene graph,
    replacing infeasible choices with the next best remaining ones."""
    excl = set(exclude_objects)
    targets = [a.furniture for a in plan if a.kind == "place" and a.furniture in scene.furniture
               and a.furniture not in set(exclude_targets)]
    if targets:
        target = targets[-1]
    else:
        cands = [f for f in scores.targets if f in scene.furniture and f not in set(exclude_targets)]
        if not cands:
            raise ValueError("no target furniture left to repair the plan with")
        target = min(cands, key=lambda f: (-scores.targets[f], f))
    n = max(n_objects - (1 if state.holding is not None else 0), 0)
    eligible = set(_eligible_objects(scene, state, target, excl))
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


# ---------------------------------------------------------------------------------------------
# manipulation-cost inference
# ---------------------------------------------------------------------------------------------
COST_SCHEMA = {"type": "object", "properties": {"cost": {"type": "string", "enum": list(COST_LABELS)}},
               "required": ["cost"], "additionalProperties": False}


def infer_manipulation_cost(client, action: Action, scene: SceneGraph, known: KnownCosts,
                            cfg: ExperimentConfig, seed_parts: Sequence[Any] = (),
                            context: tuple = ()) -> str:
    """ĉ^text(a_man) in {easy, medium, hard, unknown}. With no measured manipulation yet there is
    nothing to compare with: "unknown" is returned without an LLM call."""
    known_text = known_manipulations_text(known, scene)
    if not known_text:
        return "unknown"
    desc = describe_manipulation(action, scene)
    if cfg.llm.cost_inference_mode == "generate":
        tpl = _template("cost_inference")
        text = tpl.render(known=known_text, action=desc)
        resp = _complete(client, LLMRequest(purpose="cost_inference", messages=(Message("user", text),),
                                          schema=COST_SCHEMA, options=_options(cfg), template=tpl.name,
                                          context=context))
        parsed = _parsed(resp)
        label = parsed.get("cost") if isinstance(parsed, dict) else None
        return label if label in COST_LABELS else "unknown"
    tpl = _template("score_cost")
    scores = _score(client, "score_cost", tpl, {"known": known_text, "action": desc},
                    [f" {c}" for c in COST_LABELS], cfg.llm.calibrate, context, "action",
                    CALIBRATION_COMMAND)
    return sample_label(scores, cfg.llm.temperature,
                        planning_seed(cfg.llm.seed, "cost_inference", *seed_parts, str(action)))


def sample_label(scores: Sequence[float], temperature: float, seed: int) -> str:
    """Sample one of COST_LABELS from softmax(scores / temperature) (argmax at temperature 0)."""
    s = np.asarray(scores, dtype=float)
    if temperature <= 0:
        return COST_LABELS[int(np.argmax(s))]
    z = s / temperature
    p = np.exp(z - z.max())
    p /= p.sum()
    return COST_LABELS[int(np.random.default_rng(seed).choice(len(p), p=p))]


__all__ = [
    "SemanticScores", "assemble_plan", "describe_manipulation", "generate_plans",
    "infer_manipulation_cost", "known_costs_text", "parse_plan", "plan_schema", "plan_to_list",
    "plan_from_list", "propose_by_scores", "regenerate_plan_llm", "repair_by_scores", "replan_llm",
    "sample_label", "sample_selections", "score_command",
]
