import pytest

from interllm.core.actions import Action, State
from interllm.planning.feasibility import InfeasibleAction, apply, check_plan, simulate_plan


def nav(f, r):
    return Action("navigate", f, room=r)


def pick(o, f):
    return Action("pickup", f, obj=o)


def place(o, f):
    return Action("place", f, obj=o)


AT_COUNTER = State("counter_1", "kitchen_1")
HOLD_APPLE = State("counter_1", "kitchen_1", "apple_1")

# (name, start state, plan, expected rules, index of the first violation)
CASES = [
    ("unknown object", AT_COUNTER, [pick("pear_9", "counter_1")], {"unknown_object"}, 0),
    ("unknown furniture", AT_COUNTER, [nav("fridge_9", "kitchen_1")], {"unknown_furniture"}, 0),
    ("unknown room", AT_COUNTER, [nav("sofa_1", "garage_9")], {"unknown_room"}, 0),
    ("pick elsewhere", AT_COUNTER, [nav("sofa_1", "living_room_1"), pick("apple_1", "counter_1")],
     {"pickup_not_at_furniture"}, 1),
    ("place elsewhere", HOLD_APPLE, [place("apple_1", "sofa_1")], {"place_not_at_furniture"}, 0),
    ("place never picked", AT_COUNTER, [place("apple_1", "counter_1")], {"object_not_held"}, 0),
    ("hand not free", HOLD_APPLE, [pick("banana_1", "counter_1")], {"hand_not_free"}, 0),
    ("object elsewhere", State("sofa_1", "living_room_1"), [pick("apple_1", "sofa_1")],
     {"object_not_on_furniture"}, 0),
    ("holding other", HOLD_APPLE, [place("banana_1", "counter_1")], {"holding_other_object"}, 0),
    ("room mismatch", AT_COUNTER, [nav("sofa_1", "kitchen_1")], {"room_mismatch"}, 0),
    ("missing object", AT_COUNTER, [Action("pickup", "counter_1")], {"missing_object"}, 0),
    ("empty plan", AT_COUNTER, [], {"empty_plan"}, 0),
]


@pytest.mark.parametrize("name,state,plan,rules,index", CASES, ids=[c[0] for c in CASES])
def test_each_rule_is_triggered_by_a_minimal_plan(name, state, plan, rules, index, tiny_scene):
    rep = check_plan(tuple(plan), tiny_scene, state)
    assert not rep.valid
    assert {v.rule for v in rep.violations} == rules
    assert rep.violations[0].index == index


def test_violation_text_is_actionable(tiny_scene):
    rep = check_plan((nav("sofa_1", "living_room_1"), pick("apple_1", "counter_1")), tiny_scene, AT_COUNTER)
    assert rep.violations[0].text == ("step 2 pickup(apple_1, counter_1): the robot is at sofa_1; navigate "
                                      "to counter_1 first (navigate(counter_1, kitchen_1))")
    rep = check_plan((nav("sofa_1", "garage_9"),), tiny_scene, AT_COUNTER)
    assert "kitchen_1" in rep.violations[0].text  # lists valid rooms


def test_valid_multistep_plan_applies_effects_in_sequence(tiny_scene):
    scene = tiny_scene
    plan = (pick("apple_1", "counter_1"), nav("sofa_1", "living_room_1"), place("apple_1", "sofa_1"),
            pick("apple_1", "sofa_1"))  # picking it again from its NEW place is valid
    rep = check_plan(plan, scene, AT_COUNTER)
    assert rep.valid, rep.feedback()
    assert rep.final_state == State("sofa_1", "living_room_1", "apple_1")
    assert scene.objects["apple_1"].furniture == "counter_1"  # input not modified
    # picking it from the OLD place after moving it is not
    bad = plan[:3] + (nav("counter_1", "kitchen_1"), pick("apple_1", "counter_1"))
    rep = check_plan(bad, scene, AT_COUNTER)
    assert [v.rule for v in rep.violations] == ["object_not_on_furniture"] and rep.violations[0].index == 4


def test_optimistic_effects_do_not_cascade(tiny_scene):
    # wrong pickup location (one violation); the later place of the same object is not flagged again
    plan = (pick("apple_1", "counter_1"), nav("sofa_1", "living_room_1"), place("apple_1", "sofa_1"))
    rep = check_plan(plan, tiny_scene, State("desk_1", "living_room_1"))
    assert [v.rule for v in rep.violations] == ["pickup_not_at_furniture"]


def test_apply_is_strict_and_pure(tiny_scene):
    scene = tiny_scene
    s2, st2 = apply(pick("apple_1", "counter_1"), scene, AT_COUNTER)
    assert st2.holding == "apple_1" and s2 is not scene
    s3, st3 = apply(place("apple_1", "counter_1"), s2, st2)
    assert st3.hand_free
    with pytest.raises(InfeasibleAction, match="navigate to sofa_1 first"):
        apply(place("apple_1", "sofa_1"), s2, st2)
    final_scene, final = simulate_plan((pick("banana_1", "counter_1"), nav("desk_1", "living_room_1"),
                                        place("banana_1", "desk_1")), scene, AT_COUNTER)
    assert final_scene.objects["banana_1"].furniture == "desk_1" and final.hand_free
    assert scene.objects["banana_1"].furniture == "counter_1"
