"""ProcTHOR's asset database as the PyPI package ``procthor`` ships it (interllm.scene.procthor_db):
read without importing ``procthor.databases`` (which needs AI2-THOR), checked, and a clear error
naming the fix when the package or a file is missing."""

from __future__ import annotations

import json
import sys

import pytest

from interllm.scene import procthor_db
from interllm.scene.procthor_db import ProcthorDatabaseError, counter_shape, database_folder, load_database


@pytest.fixture(scope="module")
def db():
    return load_database()


def test_sizes_are_the_asset_databases_bounding_boxes_for_a_sample_of_ids(db):
    raw = json.loads((database_folder() / "asset-database.json").read_text())
    sample = {a["assetId"]: a for t in ("CounterTop", "DiningTable", "Chair", "Apple", "Laptop", "Fridge")
              for a in raw[t][:3]}
    assert len(sample) == 18
    for aid, a in sample.items():
        bb = a["boundingBox"]
        assert db.assets[aid].size == (bb["x"], bb["z"], bb["y"])  # ProcTHOR's x, z (floor), y (up)
        assert db.assets[aid].object_type == a["objectType"]
    assert len(db.assets) == 1653 and len({a.object_type for a in db.assets.values()}) == 109
    assert db.assets["Apple_1"].pickupable and not db.assets["Countertop_L_10x4"].pickupable


def test_receptacles_rooms_and_groups_are_read(db):
    on_table = db.receptacle_objects("DiningTable")
    assert on_table["Plate"] > on_table["Watch"] > 0
    assert db.room_frequency("Toilet", "bathroom") == 2 and db.room_frequency("Toilet", "kitchen") == 0
    assert db.room_frequency("Apple", "hallway") == 0  # room types ProcTHOR does not annotate
    table, *chairs = db.groups["chair-diningtable-4"]
    assert table.object_type == "DiningTable" and table.offset == (0.0, 0.0)
    assert [c.object_type for c in chairs] == ["Chair"] * 4
    assert all(0.5 < max(abs(c.offset[0]), abs(c.offset[1])) < 1.5 for c in chairs)  # around the table
    assert {c.yaw for c in chairs} >= {0.0, 180.0}  # facing it from both sides
    desk, chair = db.groups["desk-with-chair"]
    assert desk.object_type == "Desk" and chair.object_type == "Chair" and "Chair_007_1" in chair.asset_ids


def test_counter_ids_name_their_shape_and_size_in_feet():
    assert counter_shape("Countertop_L_10x4") == ("L", pytest.approx(3.048), pytest.approx(1.2192))
    assert counter_shape("Countertop_C_8x6")[0] == "C"
    assert counter_shape("Countertop_Island_6x3")[0] == "Island"
    assert counter_shape("Dining_Table_201_1") is None
    raw = load_database().assets
    for aid, a in raw.items():
        shape = counter_shape(aid)
        if shape is not None:  # the id's feet agree with the bounding box: to 5 mm along x, 5 cm in depth
            # (the deepest miss, 4.1 cm, is a C counter whose arms overhang their 2 ft)
            assert a.size[0] == pytest.approx(shape[1], abs=0.005) and a.size[1] == pytest.approx(shape[2], abs=0.05)


def test_a_missing_package_says_how_to_install_it(monkeypatch):
    monkeypatch.setattr(procthor_db.importlib.util, "find_spec", lambda name: None)
    with pytest.raises(ProcthorDatabaseError, match=r"pip install --no-deps procthor==0\.0\.1\.dev2"):
        database_folder()


def test_the_package_is_never_imported(db):
    assert db.assets and "procthor.databases" not in sys.modules  # its __init__ imports ai2thor


def test_a_broken_file_is_named_with_the_fix(tmp_path):
    folder = tmp_path / "databases"
    (folder / "asset_groups").mkdir(parents=True)
    (folder / "asset-database.json").write_text('{"Apple": [{"assetId": "Apple_1", "boundingBox": {"x": 0.1}}]}')
    with pytest.raises(ProcthorDatabaseError, match=r"asset-database\.json: \$\.Apple\[0\]: no assetId or "
                                                    r"boundingBox.*make install"):
        load_database(folder)
    (folder / "asset-database.json").write_text("{not json")
    with pytest.raises(ProcthorDatabaseError, match="not readable JSON"):
        load_database(folder)
