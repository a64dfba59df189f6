"""Missions, catalog consistency and rendering."""

from __future__ import annotations

import json

import numpy as np
import pytest

from interllm.config import MissionConfig
from interllm.scene import (
    CatalogError,
    MissionError,
    generate_missions,
    generate_scene,
    load_catalog,
    load_missions,
    rasterize,
    render_topdown,
    save_missions,
    scene_config,
)
from interllm.scene.catalog import CATALOG_DIR, build_catalog


@pytest.fixture(scope="module")
def scene():
    return generate_scene(scene_config("paper", seed=1), 0)


def test_paper_commands_verbatim_and_catalog_rich():
    cat = load_catalog()
    texts = [c.text for c in cat.paper_commands()]
    assert texts == ["My son needs to have the breakfast. Set it up on the dining table.",
                     "I have an online meeting in 10 minutes. Set it up in my bedroom.",
                     "I need to read a book for a break. Also, let me check what is going on in USA today."]
    assert len(cat.commands) >= 11
    assert cat.furniture["dining_table"].size == (1.8, 1.0, 0.75)
    assert cat.furniture["bookshelf"].size[2] >= cat.placement.high_min
    for c in cat.commands:  # every acceptable category can rest somewhere
        assert all(cat.furniture_for(o) for o in c.categories), c.id


def test_catalog_cross_check_names_bad_reference():
    docs = {n: json.loads((CATALOG_DIR / f"{n}.json").read_text()) for n in
            ("furniture", "objects", "rooms", "commands", "presets")}
    docs["commands"]["commands"][0]["categories"].append("unicorn")
    with pytest.raises(CatalogError, match=r"commands\[0\]\.categories: unknown name 'unicorn'"):
        build_catalog(**docs)


def test_missions_deterministic_and_goals_resolved(scene, tmp_path):
    cfg = MissionConfig(n_missions=6, seed=2)
    ms = generate_missions(scene, cfg)
    assert ms == generate_missions(scene, cfg)
    assert [c.id for c in ms[0].commands] == ["breakfast", "meeting", "reading"]
    assert ms != generate_missions(scene, MissionConfig(n_missions=6, seed=3))
    true = rasterize(scene, 0.05, 0.25, doors="true")
    pres = rasterize(scene, 0.05, 0.25, doors="presumed")
    for m in ms:
        assert len(m.commands) == 3 and len({c.id for c in m.commands}) == 3
        cell = true.world_to_cell(np.array(m.start[:2]))
        assert true.is_free(cell) and pres.is_free(cell)
        f = scene.furniture[m.start_furniture]
        fx0, fy0, fx1, fy1 = f.footprint
        dx = max(fx0 - m.start[0], m.start[0] - fx1, 0)
        dy = max(fy0 - m.start[1], m.start[1] - fy1, 0)
        assert np.hypot(dx, dy) <= 0.6 + 1e-6
        for c in m.commands:
            assert c.goal.n_objects == 3 and c.goal.target_furniture
            spec = load_catalog().command(c.id)
            for fid in c.goal.target_furniture:
                assert scene.furniture[fid].category in spec.target_furniture
                if spec.target_room_type:
                    assert scene.rooms[scene.furniture[fid].room].type == spec.target_room_type
    meeting = ms[0].commands[1]
    assert all(scene.rooms[scene.furniture[f].room].type == "bedroom" for f in meeting.goal.target_furniture)
    p = tmp_path / "missions.json"
    save_missions(p, ms)
    assert load_missions(p) == ms
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"missions": [{"id": "m0"}]}))
    with pytest.raises(MissionError, match=r"bad\.json: \$\.missions\[0\]"):
        load_missions(bad)


def test_paper_mission_unavailable_error():
    s = generate_scene(scene_config("tiny", seed=0), 0)
    with pytest.raises(MissionError, match="objects_per_command"):
        generate_missions(s, MissionConfig(objects_per_command=6, n_missions=1))


def test_render_png(scene, tmp_path):
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    grid = rasterize(scene, 0.05, 0.25, doors="true")
    render_topdown(scene, a, grid=grid, paths=[[(1, 1), (2, 2)]])
    render_topdown(scene, b, grid=grid, paths=[[(1, 1), (2, 2)]])
    data = a.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000
    assert data == b.read_bytes()
    assert b"Software" not in data and b"Creation" not in data


def test_start_poses_keep_the_true_footprint_clear(scene):
    """With sim.footprint_radius = 0.30 m the robot never starts touching a wall or furniture."""
    from interllm.config import SimConfig
    from interllm.sim.world import World

    missions = generate_missions(scene, MissionConfig(n_missions=10), 0.25, footprint_radius=0.30)
    world = World(scene, SimConfig(footprint_radius=0.30))
    for m in missions:
        world.reset(m)
        assert world.physics.base_contacts() == [], m.start_pose


@pytest.mark.parametrize("feasibility", ["measured", "off"])
def test_the_papers_mission_grows_to_the_commands_asked_for(feasibility):
    """Mission 0 starts with the paper's three commands; asking for more appends further ones, so a
    long-mission experiment (mission.commands_per_mission = 6) has no 3-command mission among its own."""
    s = generate_scene(scene_config("large", seed=0), 0)
    ms = generate_missions(s, MissionConfig(n_missions=2, commands_per_mission=6, feasibility=feasibility))
    ids = [c.id for c in ms[0].commands]
    assert ids[:3] == ["breakfast", "meeting", "reading"] and len(ids) == 6 == len(set(ids))
    assert len(ms[1].commands) == 6
    short = generate_missions(s, MissionConfig(n_missions=1, feasibility=feasibility))
    assert [c.id for c in short[0].commands] == ids[:3]
