"""Score-mode prompts that stay small as houses grow: rooms, then furniture, then objects,
expanding only what scored best (``planning.scoring.expanded_objects``)."""

from __future__ import annotations

import pytest
from helpers.planners import FakeScoreClient

from interllm.config import ExperimentConfig
from interllm.planning import scoring
from interllm.scene.catalog import scene_config
from interllm.scene.generator import generate_scene
from interllm.scene.graph import Furniture, Room, SceneGraph, SceneObject
from interllm.scene.missions import generate_missions


def three_rooms() -> SceneGraph:
    s = SceneGraph(id="three", seed=0)
    for rid, rtype, x in (("k", "kitchen", 0), ("l", "living_room", 4), ("b", "bedroom", 8)):
        s.rooms[rid] = Room(rid, rtype, ((x, 0), (x + 4, 0), (x + 4, 4), (x, 4)))
    for fid, room, x in (("counter", "k", 1), ("table", "k", 3), ("sofa", "l", 5), ("shelf", "l", 7),
                         ("desk", "b", 9)):
        s.furniture[fid] = Furniture(fid, fid, room, (x, 2), (0.6, 0.6, 0.8))
    for oid, cat, fid in (("apple_1", "apple", "counter"), ("bread_1", "bread", "counter"), ("bowl_1", "bowl", "table"),
                          ("book_1", "book", "sofa"), ("remote_1", "remote", "shelf"), ("laptop_1", "laptop", "desk")):
        x = s.furniture[fid].center[0]
        s.objects[oid] = SceneObject(oid, cat, fid, (x, 2, 0.85), (0.1, 0.1, 0.1))
    return s


def test_the_hierarchy_expands_the_best_rooms_then_their_best_furniture():
    s = three_rooms()
    cats = {"apple": 2.0, "bread": 1.0, "bowl": 0.0, "book": -1.0, "remote": -2.0, "laptop": 3.0}
    rooms = {"kitchen": 1.0, "living_room": 0.0, "bedroom": -5.0}
    # room rank = type score + best category in it: kitchen 1 + 2 = 3, living 0 - 1 = -1, bedroom -5 + 3 = -2
    # furniture of kitchen and living by best category: counter 2, table 0, sofa -1, shelf -2
    assert scoring.expanded_objects(s, cats, rooms, 2, 2) == ["apple_1", "bowl_1", "bread_1"]
    assert scoring.expanded_objects(s, cats, rooms, 2, 3) == ["apple_1", "book_1", "bowl_1", "bread_1"]
    assert scoring.expanded_objects(s, cats, rooms, 1, 0) == ["apple_1", "bowl_1", "bread_1"]
    assert scoring.expanded_objects(s, cats, rooms, 0, 0) == sorted(s.objects)  # no beam: everything
    # a strong item in a room the type score rules out still lifts its room: bedroom with laptop 9
    assert "laptop_1" in scoring.expanded_objects(s, {**cats, "laptop": 9.0}, rooms, 1, 1)


def _requests(size: str, cfg=None) -> tuple[list[int], int]:
    """(continuations of each instance-scoring request, characters the model reads per command:
    prompts, calibration prompts, continuations) over the first mission's commands."""
    scene = generate_scene(scene_config(size), 0)
    cfg = cfg or ExperimentConfig()
    client = FakeScoreClient()
    sizes, chars = [], 0
    original = client.score

    def spy(req):
        nonlocal chars
        if req.purpose == "score_instances":
            sizes.append(len(req.continuations))
        chars += len(req.prompt) + len(req.calibration_prompt or "") + 2 * sum(len(c) for c in req.continuations)
        return original(req)

    client.score = spy
    commands = generate_missions(scene, cfg.mission)[0].commands
    for cmd in commands:
        scores = scoring.score_command(client, scene, cmd, cfg.llm)
        assert set(scores.instances) == set(scene.objects)  # every object keeps a score
    return sizes, chars // len(commands)


def _instance_requests(size: str) -> list[int]:
    return _requests(size)[0]


def test_what_the_model_reads_per_command_on_huge_is_at_most_twice_the_paper_house():
    paper, huge = _requests("paper")[1], _requests("huge")[1]
    assert huge <= 2 * paper, (paper, huge)
    flat = ExperimentConfig()
    flat.llm.room_beam = flat.llm.furniture_beam = 0  # every object scored: the flat setting
    assert _requests("huge", flat)[1] > 20 * paper


@pytest.mark.parametrize("size", ["paper", "large", "huge"])
def test_objects_scored_per_command_do_not_grow_with_the_house(size):
    sizes = _instance_requests(size)
    cfg = ExperimentConfig().llm
    assert sizes and max(sizes) <= 40, sizes  # furniture_beam 6 x a handful of objects, in any house
    if size == "huge":
        assert max(sizes) < len(generate_scene(scene_config(size), 0).objects) / 40
    assert cfg.room_beam == 3 and cfg.furniture_beam == 6
