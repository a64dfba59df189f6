"""Initial plan candidates: M for the mission's first command, from the initial scene and the
mission's start state.

Made once (the ``candidates`` stage) and given to every planner, so all three start from the same
plans (the paper's fair comparison). Only what is read is made: later commands run in a state the
earlier ones changed, so every planner proposes them then (``PlannerContext.candidates``); with
``planner.fair_baselines=false`` the baselines repair mission-start candidates for every command,
so those are made for every command. Seeds derive from (llm.seed, "candidates", mission id,
command id), never from the planner.
"""

from __future__ import annotations

from interllm.config import ExperimentConfig
from interllm.core.actions import Plan, State, plan_from_list, plan_to_list
from interllm.core.seeding import planning_seed
from interllm.llm.types import LLMClientProtocol
from interllm.planning.proposers import make_proposer
from interllm.planning.request import PlanRequest
from interllm.scene.graph import Mission, SceneGraph


def start_state(scene: SceneGraph, mission: Mission) -> State:
    if mission.start_furniture not in scene.furniture:
        raise ValueError(f"mission {mission.id!r}: start_furniture {mission.start_furniture!r} is not a "
                         f"furniture of scene {scene.id!r}")
    return State(mission.start_furniture, scene.furniture[mission.start_furniture].room, None)


def initial_commands(mission: Mission, cfg: ExperimentConfig) -> tuple:
    """The commands whose shared initial candidates a planner reads: the first (every command with
    ``planner.fair_baselines=false``, whose baselines repair mission-start candidates throughout)."""
    return tuple(mission.commands) if not cfg.planner.fair_baselines else tuple(mission.commands[:1])


def generate_initial_candidates(scene: SceneGraph, mission: Mission, client: LLMClientProtocol,
                                cfg: ExperimentConfig) -> dict:
    """{command_id: [plan as list of action dicts, ...] (``planner.M`` each)} for the commands whose
    initial candidates are read (``initial_commands``) — JSON-able; the plans come from the
    proposer of ``llm.proposal_mode`` over ``client``."""
    proposer, M, seed_base = make_proposer(client, cfg.llm).plans, cfg.planner.M, cfg.llm.seed
    state = start_state(scene, mission)
    out: dict[str, list[list[dict]]] = {}
    for cmd in initial_commands(mission, cfg):
        labels = (("stage", "candidates"), ("scene", scene.id), ("mission", mission.id), ("command", cmd.id))
        plans = proposer.propose(PlanRequest(scene, state, cmd, int(cmd.goal.n_objects), context=labels), n_plans=M,
                                 seed=planning_seed(seed_base, "candidates", mission.id, cmd.id))
        out[cmd.id] = [plan_to_list(p) for p in plans]
    return out


def candidates_from_json(d: dict) -> dict[str, list[Plan]]:
    """The inverse of ``generate_initial_candidates``' output: {command_id: [Plan, ...]}."""
    if not isinstance(d, dict):
        raise ValueError("initial candidates must be a dict {command_id: [plan, ...]}")
    return {cid: [plan_from_list(p) for p in plans] for cid, plans in d.items()}
