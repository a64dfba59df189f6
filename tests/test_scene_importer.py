"""ProcTHOR-style house import: geometry mapping, doors, receptacles, warnings and errors."""

from __future__ import annotations

import copy
import json

import pytest

from interllm.scene import SceneValidationError, import_procthor, rasterize, validate_scene
from interllm.scene.importer import ImportOptions, ImportReport


def _wall(room, x0, z0, x1, z1):
    return {"id": f"wall|{room}|{x0:.2f}|{z0:.2f}|{x1:.2f}|{z1:.2f}", "roomId": f"room|{room}",
            "polygon": [{"x": x0, "y": 0, "z": z0}, {"x": x1, "y": 0, "z": z1},
                        {"x": x1, "y": 2.5, "z": z1}, {"x": x0, "y": 2.5, "z": z0}]}


def _house():
    # two 4 x 4 m rooms side by side: kitchen x in [0, 4], living room x in [4, 8]; z in [0, 4]
    sq = lambda x0: [{"x": x0, "y": 0, "z": 0}, {"x": x0 + 4, "y": 0, "z": 0},  # noqa: E731
                     {"x": x0 + 4, "y": 0, "z": 4}, {"x": x0, "y": 0, "z": 4}]
    walls = [_wall(2, 0, 0, 4, 0), _wall(2, 4, 0, 4, 4), _wall(2, 4, 4, 0, 4), _wall(2, 0, 4, 0, 0),
             _wall(3, 4, 0, 8, 0), _wall(3, 8, 0, 8, 4), _wall(3, 8, 4, 4, 4), _wall(3, 4, 4, 4, 0)]
    return {
        "id": "house_test",
        "rooms": [{"id": "room|2", "roomType": "Kitchen", "floorPolygon": sq(0)},
                  {"id": "room|3", "roomType": "LivingRoom", "floorPolygon": sq(4)}],
        "walls": walls,
        "doors": [{"id": "door|2|3", "room0": "room|2", "room1": "room|3", "wall0": walls[1]["id"],
                   "wall1": walls[7]["id"], "openable": True, "openness": 0.3,
                   "holePolygon": [{"x": 1.5, "y": 0, "z": 0}, {"x": 2.5, "y": 2.1, "z": 0}],
                   "assetPosition": {"x": 2.0, "y": 1.05, "z": 0}}],
        "objects": [
            {"id": "CounterTop|2|0", "position": {"x": 2.0, "y": 0.45, "z": 0.4}, "rotation": {"y": 0},
             "children": [{"id": "Apple|surface|2|1", "position": {"x": 1.8, "y": 0.95, "z": 0.45}},
                          {"id": "Bread|surface|2|2", "position": {"x": 2.4, "y": 0.95, "z": 0.4}}]},
            {"id": "CoffeeTable|3|0", "position": {"x": 6.0, "y": 0.2, "z": 2.0}, "rotation": {"y": 90},
             "children": [{"id": "Book|surface|3|1", "position": {"x": 6.0, "y": 0.5, "z": 2.1}}]},
        ],
    }


def test_import_small_house_geometry():
    s = import_procthor(_house())
    assert sorted(r.type for r in s.rooms.values()) == ["kitchen", "living_room"]
    assert set(s.furniture) == {"kitchen_counter_1", "coffee_table_1"}
    assert sorted(o.category for o in s.objects.values()) == ["apple", "book", "bread"]
    assert s.objects["book_1"].furniture == "coffee_table_1"
    assert s.room_of("apple_1") == "kitchen_1"
    # coffee table 1.2 x 0.6 rotated by 90 degrees -> footprint 0.6 x 1.2
    assert s.furniture["coffee_table_1"].size[:2] == (0.6, 1.2)
    # object z = surface height + half its height (counter 0.9 m, apple 0.08 m)
    assert s.objects["apple_1"].position == (1.8, 0.45, 0.94)
    (door,) = s.doors.values()
    assert door.center == (4.0, 2.0) and door.axis == "y" and door.width == 1.0
    assert door.open_fraction == 0.3
    # the shared wall x = 4 is imported once and split around the 1 m opening: [0, 1.5] and [2.5, 4]
    x4 = sorted((w.start[1], w.end[1]) for w in s.walls.values() if w.start[0] == w.end[0] == 4.0)
    assert x4 == [(0.0, 1.5), (2.5, 4.0)]
    assert len(s.walls) == 8  # 6 outer sides + 2 pieces of the shared wall
    validate_scene(s)
    # the door is 30 % open: the true grid separates the rooms, the presumed grid does not
    from interllm.scene import free_components

    for doors, joined in (("presumed", True), ("true", False)):
        g = rasterize(s, 0.05, 0.25, doors=doors)
        labels, _ = free_components(g)
        a = labels[tuple(g.world_to_cell((1.0, 3.5)))]
        b = labels[tuple(g.world_to_cell((7.0, 3.5)))]
        assert a > 0 and b > 0 and (a == b) == joined


def test_import_from_file_and_json_round_trip(tmp_path):
    f = tmp_path / "house.json"
    f.write_text(json.dumps(_house()))
    s = import_procthor(f)
    assert s.meta["source_ids"]["apple_1"] == "Apple|surface|2|1"
    assert type(s).from_json(s.to_json()).to_json() == s.to_json()


def test_missing_optional_fields_are_one_report_line_each():
    h = _house()
    del h["rooms"][1]["roomType"]
    del h["doors"][0]["holePolygon"]
    del h["objects"][0]["children"][0]["position"]
    rep = ImportReport()
    s = import_procthor(h, report=rep)
    assert rep.lines() == s.meta["import_report"]
    hosting = ("catalog command without", "command generated from")  # what the house can host: not fields
    assert [ln for ln in rep.lines() if not any(h in ln for h in hosting)] == [
        "1 × door without holePolygon: 1.0 m wide at its assetPosition (e.g. door|2|3)",
        "1 × object without position: put at the centre of its parent (e.g. Apple|surface|2|1)",
        "1 × room without roomType: typed 'room' (e.g. room|3)"]
    assert "room_1" in s.rooms and len(s.doors) == 1


def _del(path_keys):
    def f(h):
        d = h
        for k in path_keys[:-1]:
            d = d[k]
        del d[path_keys[-1]]
    return f


def _set(path_keys, value):
    def f(h):
        d = h
        for k in path_keys[:-1]:
            d = d[k]
        d[path_keys[-1]] = value
    return f


ERRORS = [
    (_del(["rooms", 0, "floorPolygon"]), "$.rooms[0].floorPolygon: required field is missing"),
    (_set(["doors", 0, "room1"], "room|9"), "$.doors[0].room1: unknown room 'room|9'"),
    (_set(["doors", 0, "wall0"], "wall|7|0|0|1|1"), "$.doors[0].wall0: unknown wall"),
    (_set(["doors", 0, "holePolygon"], [{"x": 3.5, "y": 0, "z": 0}, {"x": 4.5, "y": 2, "z": 0}]),
     "$.doors[0].holePolygon: opening [3.5, 4.5] m is not inside wall"),
    (_set(["objects", 0, "position"], {"x": 20.0, "y": 0, "z": 20.0}), "$.objects[0].position:"),
    (_set(["objects", 1, "children", 0, "position"], {"x": 1.0, "y": 0.5, "z": 1.0}),
     "$.objects[1].children[0].position: (1.0, 1.0) is not over its parent 'coffee_table_1'"),
    (_del(["objects", 1, "id"]), "$.objects[1].id: required field is missing"),
]


@pytest.mark.parametrize("mutate,expected", ERRORS, ids=[e[1].split(":")[0] for e in ERRORS])
def test_import_errors_name_the_path(mutate, expected):
    h = copy.deepcopy(_house())
    mutate(h)
    with pytest.raises(SceneValidationError) as ei:
        import_procthor(h, opts=ImportOptions(strict=True))  # a stray child is repaired unless strict
    assert expected in str(ei.value), str(ei.value)
