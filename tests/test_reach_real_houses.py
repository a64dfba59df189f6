"""What the robot can pick up in houses furnished the way ProcTHOR houses are (``procthor_realistic``):
chairs ringing the dining table, an L of deep counters against the walls, a bed and a dresser against
walls, objects over whole surfaces, objects inside the fridge.

The figures pinned here are measured (``interllm scene reach``, the scenes stage's measurement) on
seeds 0-2: 84 objects, 78 on open surfaces. The v1 ``generic`` robot picks up 22 of them (28%, the
"about a quarter" measured on real ProcTHOR-10k houses); ManipulaTHOR, the default, 46 (59%). What
stays out of reach is named by cause: chairs around the dining table and deep counters leave no
base pose within the arm's reach.
"""

from __future__ import annotations

import json

import pytest
from procthor_realistic import INSIDE, realistic_house

from interllm.config import SimConfig
from interllm.overrides import compose_config
from interllm.scene.catalog import load_catalog
from interllm.scene.importer import ImportReport, import_procthor
from interllm.sim.reach_report import reach_report
from interllm.stages.feasibility import feasibility_record, measure_scene
from interllm.stages.scenes import unpickable_markers

SEEDS = (0, 1, 2)


def _house(seed: int, tmp_path):
    path = tmp_path / f"house_{seed}.json"
    path.write_text(json.dumps(realistic_house(seed)))
    report = ImportReport()
    return import_procthor(path, report=report), report


@pytest.fixture(scope="module")
def houses(tmp_path_factory):
    return [_house(s, tmp_path_factory.mktemp("houses")) for s in SEEDS]


def _open_surface_share(houses, cfg: SimConfig) -> tuple[int, int, dict]:
    picked = total = 0
    by_cat: dict[str, list[int]] = {}
    for scene, _ in houses:
        for cat, row in reach_report(scene, cfg).items():
            if cat == "fridge":
                continue
            picked, total = picked + row.pickable, total + row.objects
            acc = by_cat.setdefault(cat, [0, 0])
            acc[0] += row.pickable
            acc[1] += row.objects
    return picked, total, by_cat


def test_objects_inside_the_fridge_are_marked_and_left_out_of_missions(houses):
    cat = load_catalog()
    for scene, report in houses:
        inside = [o for o in scene.objects.values() if o.placement == "inside"]
        assert sorted(o.category for o in inside) == sorted(t.lower() for t in INSIDE)
        assert all(scene.furniture[o.furniture].category == "fridge" and "does not open doors" in o.unreachable
                   for o in inside)
        assert all(o.position[2] < scene.furniture[o.furniture].surface_height for o in inside)
        assert any("inside a closed receptacle" in line for line in report.lines())
        for spec in cat.commands:
            assert not {o.id for o in inside} & set(spec.valid_objects(scene))


def test_the_default_robot_reaches_most_open_surfaces_and_the_v1_robot_a_quarter(houses):
    picked, total, by_cat = _open_surface_share(houses, SimConfig())
    assert SimConfig().robot == "manipulathor" and total == 78
    assert picked >= 0.70 * total  # the bar; 64/78 (82%) measured when the arm root moved
    for cat in ("kitchen_counter", "side_table", "sink", "dresser"):
        assert by_cat[cat][0] >= by_cat[cat][1] - 2, (cat, by_cat[cat])
    # ringed by chairs: out of reach from some sides (10 of 15 measured). A coffee table's top (0.45 m) is
    # at the arm root's lowest height (0.451 m); with its objects' true sizes (ProcTHOR's asset database:
    # a Book_1 and a Laptop_1 stand taller than the catalog's) all 6 are pickable (5 before)
    assert by_cat["dining_table"][0] < by_cat["dining_table"][1]
    assert by_cat["coffee_table"][0] >= by_cat["coffee_table"][1] - 1
    v1, _, _ = _open_surface_share(houses, SimConfig(**compose_config(["sim/robot=generic"])["sim"]))
    assert v1 <= 25 and picked >= v1 + 20


def test_the_scenes_stage_records_reach_per_category_and_crosses_out_what_cannot_be_picked_up(houses):
    scene, _ = houses[0]
    cfg = SimConfig()
    meas = measure_scene(scene, cfg, 0.05, 3)
    record = feasibility_record(meas, [], "measured", "imported", 3)
    assert record["schema_version"] == 3 and record["objects_measured"] == "all"
    direct = reach_report(scene, cfg)
    assert record["reach"] == {c: {"objects": r.objects, "pickable": r.pickable, "causes": dict(r.causes)}
                               for c, r in direct.items()}
    assert record["reach"]["fridge"]["causes"] == {"closed": 2}
    bad = {o for o, e in record["objects"].items() if e["pickup_sr"] <= 0}
    assert bad and all(record["objects"][o]["cause"] for o in bad)
    assert all(record["objects"][o]["cause"] == "" for o in record["objects"] if o not in bad)
    markers = unpickable_markers(scene, record)
    assert len(markers) == len(bad) and all(m[2:] == ("x", "#d62828") for m in markers)
