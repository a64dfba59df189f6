"""The reference planners (nothing, optimal), the assignment search behind optimal, candidates that
differ in objects, the oracle's relevant-only proposals and the cost encodings (paper, expected,
numeric oracle)."""

import itertools
import json
import logging
import math
from pathlib import Path

import numpy as np
import pytest
from helpers.planners import (
    FakeScoreClient,
    ListRecorder,
    SymbolicWorld,
    run_tiny_mission,
    tiny_mission,
    tiny_scene,
)

from interllm.config import ExperimentConfig, LLMConfig
from interllm.core.actions import Action, State
from interllm.core.results import ActionResult
from interllm.planners import PLANNERS
from interllm.planners.base import shown_planners
from interllm.planners.runner import run_mission
from interllm.planning import oracle
from interllm.planning.assignment import (
    MAX_NODES,
    CommandSlots,
    Delivery,
    _MissionSearch,
    cheapest_assignment,
    cheapest_mission,
)
from interllm.planning.costs import expected_failure_cost, failure_chance
from interllm.planning.proposers import OracleCosts, estimate_of, success_rate_of
from interllm.planning.scoring import SemanticScores, sample_selections
from interllm.scene.graph import Command, Goal, Mission

# ---- the assignment search -------------------------------------------------------------------


def _line_nav(pos: dict):
    return lambda a, b: 0.0 if a == b else abs(pos[a] - pos[b])


def _random_line_nav(rng, n_furniture: int):
    """Navigation along a line of ``n_furniture`` furniture f0, f1, ... and the start "@s", each
    at a random position in [0, 20]."""
    pos = {f"f{i}": float(rng.uniform(0, 20)) for i in range(n_furniture)}
    pos["@s"] = float(rng.uniform(0, 20))
    return _line_nav(pos)


def _brute(start, deliveries, n, nav):
    """The least cost among the ordered plans with the most deliveries, by enumerating them all."""
    plans = list(_command_plans_brute(start, deliveries, n, set(), nav))
    most = max(k for *_, k in plans)
    return min(c for *_, c, k in plans if k == most) if most else 0.0


def test_the_assignment_is_the_exhaustive_optimum_on_random_instances():
    rng = np.random.default_rng(0)
    for _ in range(25):
        pos = {f"f{i}": float(rng.uniform(0, 20)) for i in range(6)}
        pos["@s"] = float(rng.uniform(0, 20))
        source = {i: f"f{int(rng.integers(4))}" for i in range(5)}  # where each object stands
        ds = [Delivery(f"o{i}", source[i], t, float(rng.uniform(1, 30)), float(rng.uniform(1, 30)))
              for i in range(5) for t in ("f4", "f5") if rng.random() < 0.8]
        chosen, cost = cheapest_assignment("@s", ds, 3, _line_nav(pos))
        assert cost == pytest.approx(_brute("@s", ds, 3, _line_nav(pos)))
        assert len({d.obj for d in chosen}) == len(chosen) == min(3, len({d.obj for d in ds}))


def test_the_assignment_takes_more_deliveries_before_lower_cost():
    pos = {"@s": 0.0, "a": 1.0, "b": 50.0, "t": 2.0}
    ds = [Delivery("cheap", "a", "t", 1.0, 1.0), Delivery("dear", "b", "t", 90.0, 90.0)]
    chosen, cost = cheapest_assignment("@s", ds, 2, _line_nav(pos))
    assert [d.obj for d in chosen] == ["cheap", "dear"]
    # an object with no path is never chosen, and the plan takes fewer
    nav = lambda a, b: math.inf if b == "b" else _line_nav(pos)(a, b)  # noqa: E731
    chosen, _ = cheapest_assignment("@s", ds, 2, nav)
    assert [d.obj for d in chosen] == ["cheap"]


def _command_plans_brute(loc, options, n, used, nav):
    """Every ordered plan of one command from loc: (objects, end, cost, deliveries)."""
    objs = sorted({d.obj for d in options} - used)
    for k in range(min(n, len(objs)) + 1):
        for perm in itertools.permutations(objs, k):
            for choice in itertools.product(*[[d for d in options if d.obj == o] for o in perm]):
                at, c = loc, 0.0
                for d in choice:
                    c += nav(at, d.source) + d.pick + nav(d.source, d.target) + d.place
                    at = d.target
                if math.isfinite(c):
                    yield set(perm), at, c, len(choice)


def _mission_brute(loc, commands, used=frozenset()):
    """(deliveries, cost) of the best mission plan by enumerating every combination of plans."""
    if not commands:
        return 0, 0.0
    best = (-1, math.inf)
    for objs, end, c, k in _command_plans_brute(loc, commands[0][1], commands[0][0], set(used), commands[0][2]):
        d_rest, c_rest = _mission_brute(end, commands[1:], frozenset(used | objs))
        if (k + d_rest, -(c + c_rest)) > (best[0], -best[1]):
            best = (k + d_rest, c + c_rest)
    return best


def test_the_mission_assignment_is_the_exhaustive_optimum_over_all_commands_at_once():
    """Commands compete for objects (the books the reading command and the bedtime command both
    want) and each starts where the last ended: the mission plan is the brute-force optimum."""
    rng = np.random.default_rng(1)
    shared_objects = 0
    for _ in range(40):
        nav = _random_line_nav(rng, 7)
        pool = [(f"o{i}", f"f{int(rng.integers(4))}") for i in range(5)]
        commands = []
        for targets in (("f4",), ("f5", "f6"), ("f4", "f6")):
            objs = [p for p in pool if rng.random() < 0.5]
            ds = tuple(Delivery(o, src, t, float(rng.uniform(1, 30)), float(rng.uniform(1, 30)))
                       for o, src in objs for t in targets if rng.random() < 0.8)
            commands.append((int(rng.integers(1, 3)), ds, nav))
        got = cheapest_mission("@s", [CommandSlots(n, ds) for n, ds, _ in commands], nav)
        want = _mission_brute("@s", commands)
        assert got.deliveries == want[0] and got.cost == pytest.approx(want[1])
        by_milp = cheapest_mission("@s", [CommandSlots(n, ds) for n, ds, _ in commands], nav, max_nodes=0)
        assert (by_milp.method, by_milp.bound, by_milp.deliveries) == ("milp", None, want[0])
        assert by_milp.cost == pytest.approx(want[1])
        chosen = [d.obj for plan in got.plans for d in plan]
        assert len(chosen) == len(set(chosen)) == got.deliveries  # no object serves two commands
        sets = [{d.obj for d in ds} for _, ds, _ in commands]
        shared_objects += bool(sets[0] & sets[1] or sets[1] & sets[2] or sets[0] & sets[2])
    assert shared_objects > 20  # most instances make commands compete


def test_the_mission_assignment_is_exact_where_many_commands_compete_for_the_same_few_objects():
    """Five commands want the same four objects, the cheapest ones most: the relaxed plan gives the
    cheap objects to every command, and the search must split on object after object, several
    levels deep, to reach the brute-force optimum."""
    rng = np.random.default_rng(2)
    deepest = 0
    for _ in range(12):
        nav = _random_line_nav(rng, 6)
        pool = [(f"o{i}", f"f{i}") for i in range(4)]
        commands = []
        for c in range(5):
            ds = tuple(Delivery(o, src, f"f{4 + c % 2}", float(rng.uniform(1, 5)) * (1 + k), float(rng.uniform(1, 5)))
                       for k, (o, src) in enumerate(pool) if rng.random() < 0.9)
            commands.append((int(rng.integers(1, 3)), ds, nav))
        search = _CountingSearch("@s", [CommandSlots(n, ds) for n, ds, _ in commands], nav)
        plans = search.run()
        want = _mission_brute("@s", commands)
        assert sum(len(p[2]) for p in plans) == want[0] and sum(p[1] for p in plans) == pytest.approx(want[1])
        assert cheapest_mission("@s", [CommandSlots(n, ds) for n, ds, _ in commands], nav).cost == pytest.approx(want[1])
        by_milp = cheapest_mission("@s", [CommandSlots(n, ds) for n, ds, _ in commands], nav, max_nodes=1)
        assert by_milp.deliveries == want[0] and by_milp.cost == pytest.approx(want[1])
        deepest = max(deepest, search.nodes)
    assert deepest >= 10  # the search had to split many times, not only once


class _CountingSearch(_MissionSearch):
    """The mission search, counting the nodes it examines."""

    nodes = 0

    def expand(self, forbidden, plans):
        self.nodes += 1
        return super().expand(forbidden, plans)


def test_the_mission_assignment_searches_few_nodes_on_a_ten_command_mission_whose_commands_share_categories():
    """Ten commands of three slots over eight categories, each category wanted by three or four
    commands, 60 objects in 12 rooms' worth of furniture (the mechanism experiment's missions): the
    state-space DP this search replaced did not finish such a mission in 10 minutes; the search
    examines a few hundred nodes at most and every object serves one command."""
    rng = np.random.default_rng(3)
    furniture = [f"f{i}" for i in range(24)]
    pos = {f: (float(rng.uniform(0, 30)), float(rng.uniform(0, 30))) for f in furniture}
    pos["@s"] = (15.0, 15.0)
    nav = lambda a, b: 0.0 if a == b else math.dist(pos[a], pos[b]) * 2.0  # noqa: E731
    objects = [(f"c{k % 8}_{k}", f"c{k % 8}", furniture[int(rng.integers(24))]) for k in range(60)]
    commands = []
    for c in range(10):
        cats = {f"c{(c + j) % 8}" for j in range(3)}
        targets = [furniture[int(t)] for t in rng.choice(24, size=int(rng.integers(1, 4)), replace=False)]
        commands.append(CommandSlots(3, tuple(Delivery(o, src, t, float(rng.uniform(5, 40)), float(rng.uniform(5, 40)))
                                              for o, cat, src in objects if cat in cats and src not in targets
                                              for t in targets)))
    search = _CountingSearch("@s", commands, nav)
    plans = search.run()
    chosen = [d.obj for plan in plans for d in plan[2]]
    assert len(chosen) == len(set(chosen)) == 30
    assert 1 < search.nodes <= 300


def _captured_problem(commands: list[int]):
    """Those commands of the assignment the optimal reference solved first on mechanism-v2
    medium_s0007 m000 (tests/golden): 10 commands of 3 slots competing for bowls, cellphones and
    books, whose search outgrew 21 GB of memory before it had a node budget."""
    data = json.loads((Path(__file__).parent / "golden" / "mission_assignment_medium_s0007_m000.json").read_text())
    table = {(a, b): v for a, b, v in data["nav"]}
    slots = [CommandSlots(c["n"], tuple(Delivery(*d) for d in c["options"])) for c in data["commands"]]
    return data["start"], [slots[i] for i in commands], lambda a, b: table[(a, b)]


def test_the_integer_programme_finds_the_search_optimum_of_a_real_mission_the_budget_cuts_short():
    """Six of the captured commands: the search closes after a few hundred nodes; with a budget of
    20 it stops there, and the integer programme over the same plans returns the same deliveries
    and cost, proved optimal."""
    start, commands, nav = _captured_problem([0, 3, 4, 6, 7, 8])
    exact = _MissionSearch(start, commands, nav, max_nodes=10_000).run()
    assert exact is not None
    search = _CountingSearch(start, commands, nav, 20)
    assert search.run() is None and search.nodes == 20
    plan = cheapest_mission(start, commands, nav, max_nodes=20)
    assert (plan.method, plan.bound, plan.gap()) == ("milp", None, 0.0)
    assert plan.deliveries == sum(len(p[2]) for p in exact) == 18
    assert plan.cost == pytest.approx(sum(p[1] for p in exact), rel=1e-12)


def test_a_mission_search_that_would_not_close_stops_at_its_budget_with_a_mission_plan():
    """Eight of the captured commands: the search has not closed after 20,000 nodes (measured); it
    stops at its budget (500 here, ``MAX_NODES`` by default) and the mission plan comes from the
    integer programme, every slot filled and no object in two commands."""
    start, commands, nav = _captured_problem([0, 3, 4, 5, 6, 7, 8, 9])
    search = _CountingSearch(start, commands, nav, 500)
    assert search.run() is None and search.nodes == 500 < MAX_NODES
    plan = cheapest_mission(start, commands, nav, max_nodes=500)
    chosen = [d.obj for p in plan.plans for d in p]
    assert len(chosen) == len(set(chosen)) == plan.deliveries == 24
    assert (plan.method, plan.bound, plan.missed) == ("milp", None, 0)


def test_a_mission_plan_leaves_an_earlier_command_the_object_a_later_command_cannot_do_without():
    """Command 1 can take the book or the glasses, command 2 only the book: per command, the book
    (cheaper) would go to command 1 and command 2 would deliver nothing."""
    pos = {"@s": 0.0, "shelf": 1.0, "desk": 30.0, "sofa": 2.0, "bed": 3.0}
    nav = _line_nav(pos)
    first = CommandSlots(1, (Delivery("book", "shelf", "sofa", 1.0, 1.0), Delivery("glasses", "desk", "sofa", 1.0, 1.0)))
    second = CommandSlots(1, (Delivery("book", "shelf", "bed", 1.0, 1.0),))
    alone, _ = cheapest_assignment("@s", first.options, 1, nav)
    assert [d.obj for d in alone] == ["book"]
    plan = cheapest_mission("@s", [first, second], nav)
    assert [[d.obj for d in p] for p in plan.plans] == [["glasses"], ["book"]] and plan.deliveries == 2


# ---- the anchors (nothing, optimal) ----------------------------------------------------------------


def test_the_anchors_are_registered_and_recorded_as_anchors():
    assert PLANNERS.entry("nothing").meta.get("anchor") and PLANNERS.entry("optimal").meta.get("anchor")
    assert not PLANNERS.entry("inter_llm").meta.get("anchor")
    shown = shown_planners(["inter_llm", "nothing", "optimal"])  # what the missions stage writes beside the runs
    assert [p for p, d in shown.items() if d["anchor"]] == ["nothing", "optimal"]
    assert shown["inter_llm"] == {"label": "Inter-LLM (ours)", "color": "tab:green", "order": 2, "anchor": False}


def test_nothing_does_nothing():
    rec, world = run_tiny_mission("nothing")
    assert world.executed == [] and all(c["actions"] == [] for c in rec["commands"])


def test_optimal_delivers_every_reachable_object_and_skips_the_unreachable():
    # banana_1 can never be picked up: the optimum takes the apple only, and no other planner
    # input (candidates, LLM) matters to it
    rec, world = run_tiny_mission("optimal", hard=("banana_1",))
    c1 = rec["commands"][0]
    assert c1["final_locations"] == {"apple_1": "dining_table_1"}
    assert not any("banana_1" in a for a in world.executed)
    # the book already lies on the sofa (the reading command's target): no goal, never taken
    assert rec["commands"][1]["final_locations"] == {"mug_1": "sofa_1"}


def test_optimal_replans_without_an_object_whose_execution_fails(monkeypatch):
    class Liar(SymbolicWorld):  # measures the apple as easy, but its pickup fails
        def measure_manipulation(self, action):
            return super().measure_manipulation(Action(action.kind, action.furniture, obj="x")
                                                if action.obj == "apple_1" else action)

    import helpers.planners

    monkeypatch.setattr(helpers.planners, "SymbolicWorld",
                        lambda scene, sim, hard, blocked: Liar(scene, sim, ("apple_1",), blocked))
    rec, world = run_tiny_mission("optimal")
    c1 = rec["commands"][0]
    assert c1["final_locations"] == {"banana_1": "dining_table_1"} and c1["summary"]["replans"] >= 1


def _optimal_on(commands, world_type=SymbolicWorld):
    """``optimal`` on a mission of ``commands`` in the tiny scene, starting at the dining table."""
    scene, cfg = tiny_scene(), ExperimentConfig()
    mission = Mission("m000", "tiny", (2.0, 0.4, 0.0), "dining_table_1", tuple(commands))
    world = world_type(scene, cfg.sim)
    rec = run_mission("optimal", world, mission, {c.id: [] for c in commands}, FakeScoreClient(), cfg,
                      recorder=ListRecorder()).to_dict()
    return [c["final_locations"] for c in rec["commands"]], rec


def test_optimal_leaves_a_later_command_the_object_it_cannot_do_without():
    # the book (on the sofa) is the cheaper of the first command's two choices, and the only one
    # the second command can take: planned one command at a time the second delivers nothing
    first = Command("tidy", "Put a book or a mug on the dining table", Goal(("book", "mug"), ("dining_table_1",), 1))
    second = Command("read", "Put a book on the counter", Goal(("book",), ("counter_1",), 1))
    finals, _ = _optimal_on([first, second])
    assert finals == [{"mug_1": "dining_table_1"}, {"book_1": "counter_1"}]
    alone, _ = _optimal_on([first])
    assert alone == [{"book_1": "dining_table_1"}]  # on its own the first command takes the book


def test_optimal_puts_an_object_a_target_refused_on_the_other_target():
    class FullTable(SymbolicWorld):  # the table is measured as free, but the apple's place there fails
        def execute(self, action):
            if action.kind == "place" and action.furniture == "dining_table_1":
                self.executed.append(str(action))
                return ActionResult(action, False, 50.0, 4.0, self.clock, success_rate=0.0,
                                    reason=f"{action}: no free spot")
            return super().execute(action)

    cmd = Command("fruit", "Put an apple on the table or the desk", Goal(("apple",), ("dining_table_1", "desk_1"), 1))
    finals, rec = _optimal_on([cmd], FullTable)
    assert finals == [{"apple_1": "desk_1"}] and rec["commands"][0]["summary"]["replans"] == 1


# ---- candidates that differ in objects ----------------------------------------------------


def _scores():
    return SemanticScores({}, {"apple_1": 0.0, "banana_1": -0.1, "mug_1": -5.0, "book_1": -6.0, "laptop_1": -7.0},
                          {"dining_table_1": 0.0, "sofa_1": -0.2})


@pytest.mark.parametrize("temperature", [0.0, 0.8])
def test_candidates_differ_in_objects_where_the_house_allows(temperature):
    scene, state = tiny_scene(), State("counter_1", "kitchen_1", None)
    rng = np.random.default_rng(1)
    objs = sample_selections(_scores(), scene, state, n_objects=2, n_plans=3, temperature=temperature, rng=rng,
                             diversity="objects")
    assert len({frozenset(o) for o, _ in objs}) == 3
    plans = sample_selections(_scores(), scene, state, n_objects=2, n_plans=3, temperature=0.0,
                              rng=np.random.default_rng(1), diversity="plans")
    assert len({frozenset(o) for o, _ in plans}) < 3  # the "plans" sampler repeats the best pair


def test_candidates_fall_back_to_other_targets_when_object_sets_run_out():
    scene, state = tiny_scene(), State("counter_1", "kitchen_1", None)
    s = _scores()
    s.floor = -1.0  # only the apple and the banana may be proposed: one object set
    out = sample_selections(s, scene, state, n_objects=2, n_plans=3, temperature=0.0, rng=np.random.default_rng(0),
                            diversity="objects")
    assert {frozenset(o) for o, _ in out} == {frozenset({"apple_1", "banana_1"})}
    assert len({t for _, t in out}) == 2


# ---- the oracle ---------------------------------------------------------------------------


def test_the_oracle_proposes_only_relevant_objects_not_on_a_goal_target(caplog):
    scene = tiny_scene()
    import dataclasses
    # the apple already stands where the command wants it
    scene.objects["apple_1"] = dataclasses.replace(scene.objects["apple_1"], furniture="dining_table_1")
    cmd = Command("breakfast", "Put an apple and a banana on the dining table",
                  Goal(("apple", "banana"), ("dining_table_1",), 2))
    with caplog.at_level(logging.WARNING):
        s = oracle.oracle_scores(scene, cmd, LLMConfig(backend="oracle", proposal_mode="oracle",
                                                         cost_inference_mode="oracle"))
    assert s.instances["apple_1"] < s.floor <= s.instances["banana_1"]
    assert "1 relevant object(s)" in caplog.text and "breakfast" in caplog.text
    out = sample_selections(s, scene, State("counter_1", "kitchen_1", None), n_objects=2, n_plans=3, temperature=0.8,
                            rng=np.random.default_rng(0))
    assert out and all(set(o) == {"banana_1"} for o, _ in out)


def _oracle_costs(mode):
    cfg = ExperimentConfig()
    scene = tiny_scene()
    world = SymbolicWorld(scene, cfg.sim, hard_objects=("mug_1",))
    world.reset(tiny_mission())
    llm = LLMConfig(backend="oracle", proposal_mode="oracle", cost_inference_mode="oracle", oracle_costs=mode)
    return OracleCosts(None, llm, ground_truth=world), world


def test_the_numeric_oracle_gives_the_measured_cost_and_success_rate():
    costs, world = _oracle_costs("numeric")
    a = Action("pickup", "desk_1", obj="mug_1")
    label = costs.infer(a, world.scene, None, seed_parts=(), context=())
    truth = world.measure_manipulation(a)
    assert label == "hard" and estimate_of(costs, a, label) == pytest.approx(truth.cost) and truth.cost > 100
    assert success_rate_of(costs, a, label) == 0.0
    assert estimate_of(costs, a, "easy") == 5.0  # a wrong (drawn) class keeps its decoded value
    classes, _ = _oracle_costs("classes")
    assert estimate_of(classes, a, label) == 20.0 and success_rate_of(classes, a, label) is None


@pytest.mark.parametrize("label,known,sr,p", [("hard", None, None, 0.5), ("medium", None, None, 0.0),
                                               ("easy", True, None, 1.0), ("hard", False, None, 0.0),
                                               ("hard", None, 0.0, 1.0), ("hard", None, 0.4, 0.0)])
def test_the_failure_chance_of_the_expected_encoding(label, known, sr, p):
    assert failure_chance(label, 0.5, known_failed=known, measured_sr=sr) == p
    assert expected_failure_cost(20.0, p, 100.0) == 20.0 + 100.0 * p


def test_the_expected_encoding_steers_inter_llm_away_from_an_object_that_always_fails():
    cfg = ExperimentConfig()
    cfg.llm = LLMConfig(backend="oracle", proposal_mode="oracle", cost_inference_mode="oracle",
                        oracle_costs="numeric", temperature=0.0)
    cfg.planner.M = 3
    rec_paper, _ = run_tiny_mission("inter_llm", cfg, hard=("banana_1",))
    cfg.planner.inter_llm.cost_encoding = "expected"
    rec_exp, _ = run_tiny_mission("inter_llm", cfg, hard=("banana_1",))
    # every breakfast candidate needs the banana (two objects asked, apple and banana the only
    # relevant ones), so the estimates grow by gamma_obj for each plan that picks it up
    e_paper = rec_paper["commands"][0]["summary"]["estimated_costs"]
    e_exp = rec_exp["commands"][0]["summary"]["estimated_costs"]
    assert e_paper and all(b >= a + 100.0 - 1e-9 for a, b in zip(e_paper, e_exp, strict=True))
