"""Test doubles for the planner tests: a tiny two-room scene, a symbolic world with straight-line
navigation, and deterministic fake LLM clients (the LLM is not what these tests test)."""

from __future__ import annotations

import copy
import json
import re

import numpy as np

from interllm.config import ExperimentConfig
from interllm.core.actions import Action, State
from interllm.core.results import ActionResult, ManipulationTrial, man_cost, nav_cost
from interllm.llm.types import LLMResponse, ScoreResponse
from interllm.planners.candidates import generate_initial_candidates
from interllm.planners.runner import run_mission
from interllm.planning.costs import path_length
from interllm.planning.feasibility import action_violations, apply
from interllm.scene.graph import Command, Door, Furniture, Goal, Mission, Room, SceneGraph, SceneObject


def tiny_scene() -> SceneGraph:
    s = SceneGraph(id="tiny", seed=0)
    s.rooms["kitchen_1"] = Room("kitchen_1", "kitchen", ((0, 0), (4, 0), (4, 4), (0, 4)))
    s.rooms["living_room_1"] = Room("living_room_1", "living_room", ((4, 0), (8, 0), (8, 4), (4, 4)))
    s.doors["door_1"] = Door("door_1", ("kitchen_1", "living_room_1"), (4.0, 2.0), "y", 1.0)
    for fid, cat, room, c in [("counter_1", "counter", "kitchen_1", (1.0, 3.5)),
                              ("dining_table_1", "dining_table", "kitchen_1", (2.0, 1.0)),
                              ("sofa_1", "sofa", "living_room_1", (6.0, 3.5)),
                              ("desk_1", "desk", "living_room_1", (7.0, 1.0))]:
        s.furniture[fid] = Furniture(fid, cat, room, c, (0.8, 0.6, 0.75))
    for oid, cat, fid, usage in [("apple_1", "apple", "counter_1", "for eating"),
                                 ("banana_1", "banana", "counter_1", "for eating"),
                                 ("mug_1", "mug", "desk_1", "for drinking coffee"),
                                 ("book_1", "book", "sofa_1", "for reading"),
                                 ("laptop_1", "laptop", "desk_1", "for online meetings")]:
        f = s.furniture[fid]
        s.objects[oid] = SceneObject(oid, cat, fid, (f.center[0], f.center[1], 0.8), (0.1, 0.1, 0.1), usage)
    return s


def two_apples() -> tuple[SceneGraph, Mission]:
    """``tiny_scene`` with a second apple on the sofa and a two-command mission that asks for one
    apple each (on the dining table, then on the desk)."""
    s = tiny_scene()
    f = s.furniture["sofa_1"]
    s.objects["apple_2"] = SceneObject("apple_2", "apple", "sofa_1", (f.center[0] + 0.2, f.center[1], 0.8),
                                       (0.1, 0.1, 0.1), "for eating")
    c1 = Command("breakfast", "Put an apple on the dining table", Goal(("apple",), ("dining_table_1",), 1))
    c2 = Command("snack", "Put an apple on the desk", Goal(("apple",), ("desk_1",), 1))
    return s, Mission("m000", "tiny", (3.0, 2.0, 0.0), "dining_table_1", (c1, c2))


def tiny_mission(n_objects: int = 2) -> Mission:
    c1 = Command("breakfast", "Put an apple and a banana on the dining table",
                 Goal(("apple", "banana"), ("dining_table_1",), n_objects))
    c2 = Command("reading", "Bring a book and a mug to the sofa",
                 Goal(("book", "mug"), ("sofa_1",), n_objects))
    return Mission("m000", "tiny", (3.0, 2.0, 0.0), "dining_table_1", (c1, c2))


class SymbolicWorld:
    """World API on the symbolic simulator: straight-line paths, costs from their length.

    ``hard_objects``: manipulations of these fail on every pose (sr = 0). ``blocked``: navigating
    to these furniture collides once and fails.
    """

    def __init__(self, scene: SceneGraph, sim_cfg, hard_objects=(), blocked=()):
        self.scene0 = scene
        self.scene = scene.copy()
        self.cfg = sim_cfg
        self.hard = set(hard_objects)
        self.blocked = set(blocked)
        self.clock = 0.0
        self.state = State(None, None, None)
        self.robot_pose = (0.0, 0.0, 0.0)
        self.map_version = 0  # straight-line paths: the map never changes
        self.executed: list[str] = []

    def reset(self, mission: Mission) -> State:
        self.scene = self.scene0.copy()
        self.clock = 0.0
        f = mission.start_furniture
        self.state = State(f, self.scene.furniture[f].room, None)
        self.robot_pose = tuple(mission.start)
        return self.state

    def anchor(self, fid: str):
        c = self.scene.furniture[fid].center
        return (c[0], c[1] - 0.6)

    def presumed_path(self, start_xy, fid: str):
        a, b = np.asarray(start_xy, float), np.asarray(self.anchor(fid), float)
        n = max(int(np.ceil(np.linalg.norm(b - a) / 0.05)), 1)
        return a + (b - a) * np.linspace(0, 1, n + 1)[:, None]

    def measure_manipulation(self, action: Action):
        """What ``execute`` would measure for a pickup or place, changing nothing."""
        hard = action.obj in self.hard
        t = 4.0
        return ActionResult(action, not hard, man_cost(0.0 if hard else 1.0, t, self.cfg.gamma_man), t,
                            success_rate=0.0 if hard else 1.0, trials=[ManipulationTrial((0.0, 0.0, 0.0), not hard, t)])

    def execute(self, action: Action) -> ActionResult:
        t0 = self.clock
        self.executed.append(str(action))
        if action_violations(action, self.scene, self.state):
            return ActionResult(action, False, 0.0, 0.0, t_start=t0, reason="precondition")
        if action.kind == "navigate":
            path = self.presumed_path(self.robot_pose[:2], action.furniture)
            if action.furniture in self.blocked:
                half = path[: len(path) // 2 + 1]
                d = path_length(half)
                t = d / self.cfg.base_speed + self.cfg.recovery_time
                self.clock += t
                return ActionResult(action, False, nav_cost(1, t, d, self.cfg.gamma_nav), t, t0, 1, d,
                                    presumed_path=path, driven_path=half,
                                    reason=f"navigate({action.furniture}): blocked after 1 collision")
            d = path_length(path)
            t = d / self.cfg.base_speed
            self.clock += t
            self.scene, self.state = apply(action, self.scene, self.state)
            self.robot_pose = (float(path[-1, 0]), float(path[-1, 1]), 0.0)
            return ActionResult(action, True, nav_cost(0, t, d, self.cfg.gamma_nav), t, t0, 0, d,
                                presumed_path=path, driven_path=path)
        hard = action.obj in self.hard
        sr = 0.0 if hard else 1.0
        t = 4.0
        self.clock += t
        trials = [ManipulationTrial((0.0, 0.0, 0.0), not hard, t)]
        if hard:
            return ActionResult(action, False, man_cost(sr, t, self.cfg.gamma_man), t, t0, success_rate=sr,
                                trials=trials, reason=f"{action}: IK failed from every sampled pose")
        self.scene, self.state = apply(action, self.scene, self.state)
        return ActionResult(action, True, man_cost(sr, t, self.cfg.gamma_man), t, t0, success_rate=sr,
                            trials=trials)


_WORD = re.compile(r"[a-z]+")


def _request_words(prompt: str) -> set[str]:
    for line in reversed(prompt.splitlines()):  # the last one: few-shot examples come first
        if line.startswith("Request:") or line.startswith("Action:"):
            return set(_WORD.findall(line.lower())) - {"request", "action"}
    return set()


class _Views:
    """The client protocol's views: labels are dropped, observers are called after every answer."""

    observers: tuple = ()

    def with_context(self, **labels):
        return self

    def with_observer(self, observer):
        view = copy.copy(self)
        view.observers = self.observers + (observer,)
        return view

    def _answered(self, req, resp):
        for obs in self.observers:
            obs(req, resp)
        return resp


class FakeScoreClient(_Views):
    """score(): number of continuation words found in the prompt's Request/Action line."""

    def __init__(self):
        self.n_score = 0
        self.n_complete = 0

    @staticmethod
    def _raw(prompt: str, cont: str) -> float:
        words = _WORD.findall(cont.lower())
        return len(set(words) & _request_words(prompt)) - 0.001 * len(cont)

    def score(self, req):
        self.n_score += 1
        raw = [self._raw(req.prompt, c) for c in req.continuations]
        if req.calibration_prompt is not None:
            sc = [r - self._raw(req.calibration_prompt, c) for r, c in zip(raw, req.continuations, strict=True)]
        else:
            sc = list(raw)
        return self._answered(req, ScoreResponse(scores=sc, raw=raw, tokens_in=len(req.prompt) // 4, latency=0.0,
                                                 cached=False, key="k"))

    def complete(self, req):
        raise AssertionError("FakeScoreClient does not generate")


class ScriptedClient(_Views):
    """complete(): always answers ``answer`` (parsed JSON); records the requests."""

    def __init__(self, answer):
        self.answer = answer
        self.requests = []

    def complete(self, req):
        self.requests.append(req)
        return self._answered(req, LLMResponse(text="", parsed=self.answer, tokens_in=100, tokens_out=20,
                                               latency=0.0, cached=False, key="k"))

    def score(self, req):
        raise AssertionError("ScriptedClient does not score")


class ListRecorder:
    """A run-log recorder that keeps events, actions and log lines in lists (payloads must be JSON-able)."""

    def __init__(self):
        self.events, self.actions, self.logs = [], [], []

    def event(self, topic, t, payload):
        json.dumps(payload)  # must be JSON-able
        self.events.append((topic, t, payload))

    def action(self, result, context):
        self.actions.append((result, context))

    def log(self, t, level, message):
        self.logs.append((t, level, message))


def run_tiny_mission(name, cfg=None, hard=(), blocked=(), client=None, cands=None, recorder=None):
    """Planner ``name`` on ``tiny_mission`` in a ``SymbolicWorld`` (``hard``/``blocked``: its failing
    actions); returns the mission record as a dict and the world."""
    cfg = cfg or ExperimentConfig()
    scene, mission = tiny_scene(), tiny_mission()
    client = client or FakeScoreClient()
    cands = cands if cands is not None else generate_initial_candidates(scene, mission, client, cfg)
    world = SymbolicWorld(scene, cfg.sim, hard, blocked)
    rec = run_mission(name, world, mission, cands, client, cfg, recorder=recorder or ListRecorder()).to_dict()
    return rec, world
