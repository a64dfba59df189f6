"""Scene files: every kind of invalid file fails with the file, the JSON path and the problem."""

from __future__ import annotations

import copy
import json

import pytest

from interllm.scene import SceneValidationError, generate_scene, load_scene_file, scene_config, validate_scene


@pytest.fixture(scope="module")
def base():
    return json.loads(generate_scene(scene_config("tiny", seed=3), 0).to_json())


def _furniture_index(d, fid):
    return next(i for i, f in enumerate(d["furniture"]) if f["id"] == fid)


def _mut_unknown_furniture(d):
    d["objects"][3]["furniture"] = "desk_99"


def _mut_object_on_room(d):
    d["objects"][2]["furniture"] = d["rooms"][0]["id"]


def _mut_duplicate_id(d):
    d["objects"][1]["id"] = d["furniture"][0]["id"]


def _mut_unknown_room(d):
    d["furniture"][2]["room"] = "attic_1"


def _mut_missing_field(d):
    del d["objects"][0]["position"]


def _mut_wrong_type(d):
    d["furniture"][1]["size"] = "big"


def _mut_bad_placement(d):
    d["objects"][4]["placement"] = "floating"


def _mut_door_unknown_room(d):
    d["doors"][0]["rooms"][1] = "garden_1"


def _mut_disconnected(d):
    victim = d["rooms"][-1]["id"]
    d["doors"] = [dr for dr in d["doors"] if victim not in dr["rooms"]]


def _mut_object_off_furniture(d):
    d["objects"][0]["position"][0] += 50.0


def _mut_unreachable(d):
    # a huge furniture filling the first room's floor
    r = d["rooms"][0]
    xs = [p[0] for p in r["polygon"]]
    ys = [p[1] for p in r["polygon"]]
    i = next(i for i, f in enumerate(d["furniture"]) if f["room"] == r["id"])
    d["furniture"][i]["center"] = [(min(xs) + max(xs)) / 2, (min(ys) + max(ys)) / 2]
    d["furniture"][i]["size"] = [max(xs) - min(xs) - 0.3, max(ys) - min(ys) - 0.3, 0.75]
    for o in d["objects"]:
        if o["furniture"] == d["furniture"][i]["id"]:
            o["position"][:2] = d["furniture"][i]["center"]


CASES = [
    (_mut_unknown_furniture, r"\$\.objects\[3\]\.furniture", "unknown furniture 'desk_99'"),
    (_mut_object_on_room, r"\$\.objects\[2\]\.furniture", "exactly one furniture"),
    (_mut_duplicate_id, r"\$\.objects\[1\]\.id", "duplicate id"),
    (_mut_unknown_room, r"\$\.furniture\[2\]\.room", "unknown room 'attic_1'"),
    (_mut_missing_field, r"\$\.objects\[0\]:", "'position' is a required property"),
    (_mut_wrong_type, r"\$\.furniture\[1\]\.size", "not of type 'array'"),
    (_mut_bad_placement, r"\$\.objects\[4\]\.placement", "is not one of"),
    (_mut_door_unknown_room, r"\$\.doors\[0\]\.rooms\[1\]", "unknown room 'garden_1'"),
    (_mut_disconnected, r"\$\.doors:", "not connected by doors"),
    (_mut_object_off_furniture, r"\$\.objects\[0\]\.position", "not over its furniture"),
    (_mut_unreachable, r"\$\.(furniture|rooms)\[\d+\]", "not reachable"),
]


@pytest.mark.parametrize("mutate,path_re,problem", CASES, ids=[c[0].__name__[5:] for c in CASES])
def test_invalid_file_precise_error(tmp_path, base, mutate, path_re, problem):
    d = copy.deepcopy(base)
    mutate(d)
    f = tmp_path / "bad_scene.json"
    f.write_text(json.dumps(d))
    with pytest.raises(SceneValidationError) as ei:
        load_scene_file(f)
    msg = str(ei.value)
    assert msg.startswith(str(f) + ": $"), msg
    import re

    assert re.search(path_re, msg), msg
    assert problem in msg, msg


def test_valid_file_loads_and_round_trips(tmp_path, base):
    f = tmp_path / "scene.json"
    f.write_text(json.dumps(base))
    s = load_scene_file(f)
    assert json.loads(s.to_json()) == base


def test_not_json_and_missing_file(tmp_path):
    f = tmp_path / "x.json"
    f.write_text("{not json")
    with pytest.raises(SceneValidationError, match=r"x\.json: \$: line 1 column \d+: invalid JSON"):
        load_scene_file(f)
    with pytest.raises(SceneValidationError, match="file not found"):
        load_scene_file(tmp_path / "nope.json")


def test_validate_scene_accepts_graph_object():
    s = generate_scene(scene_config("tiny", seed=4), 0)
    assert validate_scene(s).to_json() == s.to_json()
