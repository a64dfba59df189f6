"""Generate mode (the paper's): the LLM writes plans as JSON under a schema, one plan per call
(candidate j uses ``sample_index=j`` and is asked to differ from the plans already written). Each
request shows a :class:`~interllm.planning.expansion.SceneView`: the whole scene graph, or the rooms
chosen for the command (``planning.expansion``); with ``llm.constrain_names`` the schema enumerates
the view's ids. Repair feeds the feasibility checker's violation texts back; a replan after an
execution failure feeds the failure text back. Cost inference asks for
{"cost": easy|medium|hard|unknown}.

An answer that stays malformed after the client's repair retries becomes the empty plan (which the
feasibility loop then handles) or the label "unknown".
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Optional

from interllm.config import LLMConfig
from interllm.core.actions import Action, Plan
from interllm.llm.client import complete_or_none
from interllm.llm.prompts import load_template
from interllm.llm.types import LLMOptions, LLMRequest, LLMResponse, Message
from interllm.planning.costs import COST_LABELS
from interllm.planning.expansion import SceneView
from interllm.planning.feasibility import FeasibilityReport
from interllm.planning.memory import KnownCosts
from interllm.planning.plans import parse_plan
from interllm.planning.request import PlanRequest
from interllm.planning.text import (
    action_placement,
    describe_manipulation,
    known_costs_text,
    known_manipulations_text,
    plan_text,
)
from interllm.scene.graph import SceneGraph

COST_SCHEMA = {"type": "object", "properties": {"cost": {"type": "string", "enum": list(COST_LABELS)}},
               "required": ["cost"], "additionalProperties": False}


def _options(cfg: LLMConfig, sample_index: int = 0, plan: bool = True) -> LLMOptions:
    """Options of a plan request (at ``cfg.plan_sampling_temperature``) or, with ``plan=False``, of a
    cost-inference request (at the paper's σ, ``cfg.temperature``)."""
    t = cfg.plan_sampling_temperature if plan else cfg.temperature
    return LLMOptions(temperature=t, seed=cfg.seed, top_p=cfg.top_p, max_tokens=cfg.max_tokens,
                      sample_index=sample_index)


def _parsed(resp: Optional[LLMResponse]) -> Any:
    return None if resp is None else resp.parsed


def _fields(view: SceneView, req: PlanRequest) -> dict:
    """The fields every plan-writing template shares; ``view``: what it shows of the scene graph."""
    return {"scene": view.text, "state": req.state.describe(), "command": req.command.text,
            "n_objects": req.n_objects, "known_costs": known_costs_text(req.known)}


def generate_plans(client, req: PlanRequest, cfg: LLMConfig, *, view: SceneView, n_plans: int) -> list[Plan]:
    """``n_plans`` plans for ``req`` written by the LLM over ``view``, one call per plan (sample_index j)."""
    tpl = load_template("candidates")
    schema = view.schema(cfg.constrain_names)
    plans: list[Plan] = []
    for j in range(n_plans):
        prev = ""
        if plans:
            prev = "\nPlans already proposed (write a different one):\n" + "\n".join(
                f"Plan {k + 1}: " + "; ".join(str(a) for a in p) for k, p in enumerate(plans)) + "\n"
        text = tpl.render(previous=prev, **_fields(view, req))
        resp = complete_or_none(client, LLMRequest(purpose="candidates", messages=(Message("user", text),),
                                                   schema=schema, options=_options(cfg, j), template=tpl.name,
                                                   context=req.context))
        plans.append(parse_plan(_parsed(resp)))
    return plans


def regenerate_plan_llm(client, req: PlanRequest, cfg: LLMConfig, *, view: SceneView, plan: Plan,
                        report: FeasibilityReport, attempt: int, sample_index: int = 0) -> Plan:
    """``plan`` rewritten by the LLM over ``view`` after the feasibility checker's ``report`` (round
    ``attempt`` of candidate ``sample_index``)."""
    tpl = load_template("regeneration")
    text = tpl.render(plan=plan_text(plan), feedback=report.feedback() or "(none)", **_fields(view, req))
    resp = complete_or_none(client, LLMRequest(
        purpose="regeneration", messages=(Message("user", text),), schema=view.schema(cfg.constrain_names),
        options=_options(cfg, sample_index * 100 + attempt + 1), template=tpl.name, context=req.context))
    return parse_plan(_parsed(resp))


def replan_llm(client, req: PlanRequest, cfg: LLMConfig, *, view: SceneView, executed: Sequence[str], failure: str,
               attempt: int) -> Plan:
    """The rest of ``req.command`` written by the LLM over ``view`` after an execution failure
    (``failure``: its text; ``req.exclude.objects``: the objects it lists as excluded; no known costs
    are shown)."""
    tpl = load_template("replan")
    text = tpl.render(scene=view.text, state=req.state.describe(), command=req.command.text,
                      executed="\n".join(executed) or "(nothing)", failure=failure,
                      excluded=", ".join(req.exclude.objects) or "(none)", n_objects=req.n_objects)
    resp = complete_or_none(client, LLMRequest(
        purpose="replan", messages=(Message("user", text),), schema=view.schema(cfg.constrain_names),
        options=_options(cfg, attempt), template=tpl.name, context=req.context))
    return parse_plan(_parsed(resp))


def infer_cost_by_generation(client, action: Action, scene: SceneGraph, known: KnownCosts, cfg: LLMConfig, *,
                             context: tuple = ()) -> str:
    """ĉ^text(a_man) in {easy, medium, hard, unknown}, written by the LLM under COST_SCHEMA. With no
    measured manipulation yet there is nothing to compare with: "unknown" without an LLM call."""
    known_text = known_manipulations_text(known, scene, cfg.placement_attributes)
    if not known_text:
        return "unknown"
    tpl = load_template("cost_inference")
    where = action_placement(action, scene) if cfg.placement_attributes else None
    text = tpl.render(known=known_text, action=describe_manipulation(action, scene, where))
    resp = complete_or_none(client, LLMRequest(purpose="cost_inference", messages=(Message("user", text),),
                                        schema=COST_SCHEMA, options=_options(cfg, plan=False), template=tpl.name,
                                        context=context))
    parsed = _parsed(resp)
    label = parsed.get("cost") if isinstance(parsed, dict) else None
    return label if label in COST_LABELS else "unknown"
