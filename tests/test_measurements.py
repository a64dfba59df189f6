"""Manipulation measurements on a scene's initial map are made once: the scenes stage writes them
(``measurements.json``), a world of the missions stage starts from them and keeps its own across
missions (``interllm.sim.measurements``), and a measurement served from the store equals one made
afresh."""

from __future__ import annotations

import dataclasses
import json
import logging
from pathlib import Path

import pytest

from interllm.config import ExperimentConfig
from interllm.core.actions import Action
from interllm.io import InputFileError
from interllm.sim.manipulator import Manipulator
from interllm.sim.measurements import MEASUREMENTS_FILE, MISSING, MeasurementStore
from interllm.sim.world import World
from interllm.stages.inputs import load_grids, load_scene_and_missions
from interllm.stages.missions import load_measurements
from interllm.stages.scenes import run_scenes


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    """A tiny generated scene through the real scenes stage."""
    cfg = ExperimentConfig()
    cfg.benchmark, cfg.scene.size, cfg.scene.n_scenes, cfg.mission.n_missions = "", "tiny", 1, 2
    out = tmp_path_factory.mktemp("scenes")
    (sid,) = run_scenes(cfg, out)
    return cfg, out, sid


def _scene(cfg, out: Path, sid: str):
    return load_scene_and_missions(out, sid, cfg)[0]


def _world(cfg, out: Path, sid: str, store: MeasurementStore | None = None) -> World:
    scene = _scene(cfg, out, sid)
    return World(scene, cfg.sim, cfg.scene.grid_resolution, grids=load_grids(out, sid, cfg), measurements=store)


def _actions(store: MeasurementStore, n: int) -> list[Action]:
    """Up to ``n`` distinct actions stored with a result, pickups and places."""
    seen: dict[str, Action] = {}
    for key in store.keys():
        r = store.get(key)
        if r is not None and key[0] not in seen:
            seen[key[0]] = r.action
    acts = sorted(seen.values(), key=str)
    return [a for a in acts if a.kind == "pickup"][: n // 2] + [a for a in acts if a.kind == "place"][: n // 2]


@pytest.fixture
def measured(monkeypatch):
    """Count ``Manipulator.measure`` calls (the N_l-trial measurements really made)."""
    calls: list[str] = []
    real = Manipulator.measure

    def counting(self, belief, scene, action, robot_xy):
        calls.append(str(action))
        return real(self, belief, scene, action, robot_xy)

    monkeypatch.setattr(Manipulator, "measure", counting)
    return calls


def test_the_scenes_stage_writes_what_it_measured(scenes):
    cfg, out, sid = scenes
    doc = json.loads((out / sid / MEASUREMENTS_FILE).read_text())
    store = load_measurements(out, sid, cfg, _scene(cfg, out, sid))
    assert len(store) == len(doc["entries"]) > 20
    kinds = {e["action"].split("(")[0] for e in doc["entries"]}
    assert kinds == {"pickup", "place"}


def test_a_seeded_world_measures_nothing_again_and_gets_what_measuring_gives(scenes, measured):
    cfg, out, sid = scenes
    store = load_measurements(out, sid, cfg, _scene(cfg, out, sid))
    acts = _actions(store, 12)
    assert len(acts) == 12
    seeded = _world(cfg, out, sid, store)
    served = [seeded.measure_manipulation(a) for a in acts]
    assert measured == []  # every one from the scenes stage's file
    fresh = [_world(cfg, out, sid).measure_manipulation(a) for a in acts]
    assert len(measured) == len(acts)
    assert [r.to_record() for r in served] == [r.to_record() for r in fresh]


def test_a_measurement_is_kept_across_missions_but_not_across_map_changes(scenes, measured):
    cfg, out, sid = scenes
    _, missions = load_scene_and_missions(out, sid, cfg)
    world = _world(cfg, out, sid)  # an empty store
    act = _actions(load_measurements(out, sid, cfg, world.initial_scene), 2)[0]
    world.reset(missions[0])
    first = world.measure_manipulation(act)
    world.reset(missions[1])
    assert world.measure_manipulation(act) is first and measured == [str(act)]  # the next mission: no new trials
    assert world.belief.block_cells(world.anchor(act.furniture), 0.3) > 0  # a collision changed the map
    world.measure_manipulation(act)
    assert measured == [str(act)] * 2  # measured on the changed map: neither the mission's memo nor the store
    assert world.measurements.get((str(act), world.manipulator.layout_key(world.scene, act.furniture))) is first


def test_a_file_made_for_another_simulator_config_or_scene_is_not_used(scenes, caplog):
    cfg, out, sid = scenes
    scene = _scene(cfg, out, sid)
    other = ExperimentConfig()
    other.sim.n_l = cfg.sim.n_l + 1
    moved = scene.copy()
    wall = next(iter(moved.walls))
    moved.walls[wall] = dataclasses.replace(moved.walls[wall], thickness=moved.walls[wall].thickness + 0.01)
    key = next(iter(load_measurements(out, sid, cfg, scene).keys()))
    for store in (MeasurementStore(other.sim, cfg.scene.grid_resolution, scene),
                  MeasurementStore(cfg.sim, cfg.scene.grid_resolution, moved)):
        caplog.clear()
        with caplog.at_level(logging.WARNING):
            assert store.read(out / sid / MEASUREMENTS_FILE) == 0
        assert len(store) == 0 and "another scene, simulator config or code" in caplog.text
        assert MEASUREMENTS_FILE in caplog.text and store.get(key) is MISSING
        assert ("sim.n_l: file 5, here 6" if store.made_with["sim"]["n_l"] == 6 else "scene: file") in caplog.text
    with pytest.raises(ValueError, match="sim.n_l: file 5, here 6"):
        World(scene, other.sim, cfg.scene.grid_resolution, grids=load_grids(out, sid, cfg),
              measurements=load_measurements(out, sid, cfg, scene))


def test_a_broken_file_names_the_file_the_entry_and_the_fix(scenes, tmp_path):
    cfg, out, sid = scenes
    doc = json.loads((out / sid / MEASUREMENTS_FILE).read_text())
    del doc["entries"][3]["layout"]
    bad = tmp_path / MEASUREMENTS_FILE
    bad.write_text(json.dumps(doc))
    with pytest.raises(InputFileError, match=r"entries\[3\].*dvc repro scenes") as e:
        MeasurementStore(cfg.sim, cfg.scene.grid_resolution, _scene(cfg, out, sid)).read(bad)
    assert str(bad) in str(e.value)
    bad.write_text("[1, 2]")
    with pytest.raises(InputFileError, match="not a measurements document"):
        MeasurementStore(cfg.sim, cfg.scene.grid_resolution, _scene(cfg, out, sid)).read(bad)
