"""ProcTHOR houses as ProcTHOR writes them: each feature on a small house built here, checked against
expectations worked out by hand (graph, grid, picture, report), and the paper's mission on one."""

from __future__ import annotations

import dataclasses
import json
import logging
import shutil
from pathlib import Path

import numpy as np
import pytest
from procthor_houses import child, door, obj, paper_house, rect, room_walls, wall_id

from interllm.config import ExperimentConfig, MissionConfig
from interllm.scene import generate_missions, import_procthor, rasterize, validate_scene
from interllm.scene.importer import ImportOptions, ImportReport

REPO = Path(__file__).resolve().parents[1]


def two_rooms(east_empty: bool = False, walls: bool = True, doors: bool = True) -> dict:
    """Kitchen [0,4]x[0,3] (room|2) and living room [4,8]x[0,3] (room|3) sharing x = 4; a door at
    z in [1, 2] on it (unless ``east_empty``: ProcTHOR's open connection)."""
    h = {"rooms": [{"id": "room|2", "roomType": "Kitchen", "floorPolygon": rect(0, 0, 4, 3)},
                   {"id": "room|3", "roomType": "LivingRoom", "floorPolygon": rect(4, 0, 8, 3)}],
         "walls": [], "doors": [], "objects": [obj("CounterTop", 2, 0, 2.0, 0.4), obj("Sofa", 3, 0, 6.0, 2.5)]}
    if walls:
        h["walls"] = (room_walls(2, 0, 0, 4, 3, {"S", "N", "W"}, {"E"} if east_empty else set())
                      + room_walls(3, 4, 0, 8, 3, {"S", "N", "E"}, {"W"} if east_empty else set()))
    if doors and not east_empty:
        h["doors"] = [door(2, 3, wall_id(2, (4, 0), (4, 3)), wall_id(3, (4, 3), (4, 0)), 1.0, 2.0)]
    return h


def _free(grid, x, y) -> bool:
    r, c = grid.world_to_cell(np.array([x, y]))
    return not bool(grid.occupied[r, c])


def test_an_exterior_door_is_dropped_and_its_wall_stays_closed():
    h = two_rooms()
    h["doors"].append(door(2, 2, wall_id(2, (0, 0), (4, 0)), "wall|exterior|0.00|0.00|4.00|0.00", 1.5, 2.5, None))
    rep = ImportReport()
    s = import_procthor(h, report=rep)
    assert [d.rooms for d in s.doors.values()] == [("kitchen_1", "living_room_1")]
    assert any(line.startswith("1 × exterior door: dropped") for line in rep.lines())
    south = sorted((w.start, w.end) for w in s.walls.values() if w.start[1] == w.end[1] == 0.0)
    assert south == [((0.0, 0.0), (4.0, 0.0)), ((4.0, 0.0), (8.0, 0.0))]  # not cut at x in [1.5, 2.5]
    validate_scene(s)


def test_an_empty_wall_is_an_opening_as_wide_as_the_shared_edge():
    s = import_procthor(two_rooms(east_empty=True))
    assert not [w for w in s.walls.values() if w.start[0] == w.end[0] == 4.0]  # no wall at x = 4
    (d,) = s.doors.values()
    assert (d.rooms, d.center, d.axis, d.width, d.open_fraction) == \
        (("kitchen_1", "living_room_1"), (4.0, 1.5), "y", 3.0, 1.0)
    grid = rasterize(s, 0.05, 0.25)
    assert all(_free(grid, 4.0, z) for z in (0.8, 1.5, 2.2))  # open across the whole edge, walls aside
    validate_scene(s)


@pytest.mark.parametrize("with_doors", [True, False])
def test_a_house_without_walls_gets_them_from_its_room_polygons(with_doors):
    rep = ImportReport()
    s = import_procthor(two_rooms(walls=False, doors=with_doors), report=rep)
    outline = sorted((w.start, w.end) for w in s.walls.values() if not (w.start[0] == w.end[0] == 4.0))
    assert outline == [((0.0, 0.0), (0.0, 3.0)), ((0.0, 0.0), (8.0, 0.0)), ((0.0, 3.0), (8.0, 3.0)),
                       ((8.0, 0.0), (8.0, 3.0))]  # the outline, the collinear room edges joined
    x4 = sorted((w.start[1], w.end[1]) for w in s.walls.values() if w.start[0] == w.end[0] == 4.0)
    text = " ".join(rep.lines())
    assert "no walls in the file: walls derived from the room polygons" in text
    if with_doors:  # the shared edge is a wall, cut at the file's door (z in [1, 2])
        assert x4 == [(0.0, 1.0), (2.0, 3.0)] and len(s.doors) == 1
        # the only warning: the two bare rooms hold nothing a command could ask for
        assert [w.split(':')[0] for w in rep.warnings] == ["no command can be hosted"]
    else:  # neither walls nor doors: open inside, and the report says so
        assert x4 == [] and "no doors in the file either" in text
        assert rep.lines()[0].startswith("warning: the file has no walls and no doors: the house is open inside")
        (d,) = s.doors.values()
        assert d.width == 3.0
    validate_scene(s)


def test_a_rotated_table_has_its_turned_footprint_and_a_child_near_its_edge_is_moved_onto_it():
    h = two_rooms()
    # dining table 1.8 x 1.0 m turned by 90°: 1.0 (x) by 1.8 (z), x in [5.5, 6.5], z in [0.6, 2.4];
    # the apple (Apple_1: a 0.106 x 0.106 x 0.1135 m box in ProcTHOR's asset database) at x = 6.49 sticks
    # 0.043 m out: moved to 6.5 - 0.053 - 0.01 = 6.437
    h["objects"] = [obj("DiningTable", 3, 1, 6.0, 1.5, rot=90, children=[child("Apple", 3, 2, 6.49, 1.5)])]
    rep = ImportReport()
    s = import_procthor(h, report=rep)
    t = s.furniture["dining_table_1"]
    assert t.size == (1.0, 1.8, 0.75) and t.footprint == (5.5, 0.6, 6.5, 2.4)
    apple = s.objects["apple_1"]
    assert apple.position == (6.437, 1.5, 0.8067) and apple.furniture == "dining_table_1"  # 0.75 + 0.1135 / 2
    assert any("moved onto it" in line for line in rep.lines())
    validate_scene(s)


def test_the_axis_aligned_bounding_box_wins_over_the_catalog():
    h = two_rooms()
    h["objects"] = [obj("DiningTable", 3, 1, 6.0, 1.5, y=0.4)]
    h["objects"][0]["axisAlignedBoundingBox"] = {"center": {"x": 6.0, "y": 0.4, "z": 1.5},
                                                 "size": {"x": 1.2, "y": 0.8, "z": 0.9}}
    t = import_procthor(h).furniture["dining_table_1"]
    assert t.size == (1.2, 0.9, 0.8)  # top = centre 0.4 + half height 0.4


def test_a_painting_on_a_wall_is_no_floor_obstacle():
    h = two_rooms()
    h["objects"].append(obj("Painting", 3, 5, 7.95, 1.5, y=1.6, rot=270, asset="Wall_Decor_Painting_6"))
    h["objects"].append({**obj("x", 3, 6, 7.95, 0.8, y=1.4), "id": "3|6", "assetId": "Wall_Decor_Photo_3V"})
    rep = ImportReport()
    s = import_procthor(h, report=rep)
    assert sorted(f.category for f in s.furniture.values()) == ["kitchen_counter", "sofa"]
    assert "2 × wall-mounted painting: kept off the floor grid (not imported)" in " ".join(rep.lines())
    assert _free(rasterize(s, 0.05, 0.25), 7.5, 1.5)  # where its footprint would have been


def test_unknown_types_keep_a_box_and_their_name_with_one_report_line_per_reason():
    h = two_rooms()
    h["objects"] += [obj("Xylophone", 3, k, 5.0 + 0.8 * k, 0.5) for k in range(3)]
    h["objects"][0]["children"] = [child("Kazoo", 2, 9, 2.0, 0.4)]
    rep = ImportReport()
    s = import_procthor(h, report=rep)
    xs = [f for f in s.furniture.values() if f.category == "xylophone"]
    assert len(xs) == 3 and all(f.size == (1.0, 0.6, 0.75) for f in xs)  # DEFAULT_FURNITURE_SIZE
    assert s.objects["kazoo_1"].size == (0.1, 0.1, 0.1)
    lines = rep.lines()
    assert "3 × furniture type not in the catalog: its own name as category (e.g. Xylophone)" in lines
    assert "1 × object type not in the catalog: its own name as category (e.g. Kazoo)" in lines
    assert len([ln for ln in lines if "Xylophone" in ln]) == 2  # unknown type, default size: once each


def test_the_catalog_covers_procthors_common_types():
    h = two_rooms()
    types = ["Chair", "Toilet", "Fridge", "Sink", "GarbageCan", "HousePlant", "FloorLamp", "Stool", "Dresser",
             "Bed", "ArmChair", "TVStand", "SideTable", "Desk", "ShelvingUnit", "Ottoman", "DogBed"]
    h["objects"] = [obj(t, 3, k, 4.5 + 0.2 * k, 1.5) for k, t in enumerate(types)]
    kids = ["Book", "CellPhone", "RemoteControl", "Statue", "Bowl", "Pillow", "Pencil", "Pen", "KeyChain",
            "CreditCard", "Egg", "Laptop", "Mug", "Vase", "SoapBottle", "SprayBottle", "Plate", "HousePlant",
            "Television", "Candle", "Watch", "Spoon", "ToiletPaper", "Apple", "Tomato", "DeskLamp", "Newspaper",
            "Cup"]
    h["objects"][0]["children"] = [child(t, 3, k, 4.5, 1.5) for k, t in enumerate(kids)]
    rep = ImportReport()
    import_procthor(h, report=rep, opts=ImportOptions(strict=True))  # piled up: strict keeps them all
    assert not [ln for ln in rep.lines() if "not in the catalog" in ln], rep.lines()


def test_import_procthor_writes_the_scene_the_report_and_the_picture(tmp_path):
    from interllm.cli import main

    f = tmp_path / "house.json"
    f.write_text(json.dumps(paper_house()), encoding="utf-8")
    assert main(["scene", "import-procthor", str(f), "--out", str(tmp_path / "out")]) == 0
    assert (tmp_path / "out" / "topdown.png").read_bytes()[:4] == b"\x89PNG"
    report = (tmp_path / "out" / "import_report.txt").read_text(encoding="utf-8")
    assert "exterior door: dropped" in report and "empty wall" in report and "window: ignored" in report
    validate_scene(json.loads((tmp_path / "out" / "scene.json").read_text(encoding="utf-8")))


def test_missions_on_a_house_that_cannot_host_the_paper_mission(caplog):
    h = paper_house()
    h["objects"] = [o for o in h["objects"] if not o["id"].startswith("Desk")]  # no bedroom target: no meeting
    s = import_procthor(h)
    with caplog.at_level(logging.WARNING, logger="interllm.scene.missions"):
        ms = generate_missions(s, MissionConfig(n_missions=4), 0.25, footprint_radius=0.30)
    cmds = [[c.id for c in m.commands] for m in ms]
    assert all(len(set(c)) == len(c) for c in cmds)  # never the same command twice
    assert cmds[0][:2] == ["breakfast", "reading"] and "meeting" not in sum(cmds, [])
    assert "the paper's command(s) ['meeting'] need target furniture" in caplog.text


@pytest.mark.integration
def test_the_paper_mission_runs_end_to_end_on_a_procthor_house(tmp_path):
    """Imported with zero hard errors, validated, and the quick experiment (the paper's mission,
    all three planners) run on it with the embedded model (its answers come from the committed
    cache when they are there)."""
    from interllm.stages.pipeline import run_all

    scene = import_procthor(paper_house())
    validate_scene(scene)
    (tmp_path / "house").mkdir()
    (tmp_path / "house" / "scene.json").write_text(scene.to_json(), encoding="utf-8")
    shutil.copytree(REPO / "data" / "llm_cache", tmp_path / "cache")
    cfg = ExperimentConfig()
    cfg = dataclasses.replace(
        cfg, jobs=1, experiment="quick", data_dir=str(tmp_path / "data"),
        scene=dataclasses.replace(cfg.scene, n_scenes=1, import_path=str(tmp_path / "house" / "scene.json")),
        # unchecked draw: the paper's mission as it is (the v1 robot could pick up 3 of this house's
        # 11 objects and the measured draw cut the mission down; ManipulaTHOR can fill every slot)
        mission=dataclasses.replace(cfg.mission, n_missions=1, feasibility="off"),
        llm=dataclasses.replace(cfg.llm, cache_dir=str(tmp_path / "cache")))
    metrics = run_all(cfg, tmp_path / "data")
    assert sorted(metrics["planners"]) == ["inter_llm", "moma_llm", "nothing", "optimal", "sayplan"]
    fills = json.loads((tmp_path / "data" / "scenes" / "paper_house" / "feasibility.json").read_text())
    assert fills["totals"]["slots_fulfillable"] == fills["totals"]["slots_asked"] == 9  # measured, as recorded
    for p in metrics["planners"].values():
        assert p["n_missions"] == 1 and p["n_objects"] == 9
    calls = (tmp_path / "data" / "runs" / "llm_calls.jsonl").read_text(encoding="utf-8").splitlines()
    assert calls and {json.loads(c).get("scene") for c in calls} == {"paper_house"}
