"""The versioned benchmark (interllm/scene/benchmark.py): houses and missions frozen under a name, re-measured
by the scenes stage, which reports what the current simulator measures differently instead of drawing other
commands. Configs are composed from conf/ with Hydra, as runs compose them."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from interllm.config import ConfigError
from interllm.metrics.benchmark_check import benchmark_summary
from interllm.metrics.compute import MetricsInputError
from interllm.report.benchmark import benchmark_sentence
from interllm.scene.benchmark import BenchmarkError, open_benchmark, recheck
from interllm.scene.graph import Command, Goal, Mission
from interllm.scene.missions import Fulfillable, standable_start
from interllm.scene.validate import load_scene_file
from interllm.stages.freeze import freeze_benchmark
from interllm.stages.scenes import run_scenes
from pipeline._hydra import compose, to_config

ROOT = Path(__file__).resolve().parent.parent
TINY = ["experiment=quick", "scene=tiny"]


def _cfg(bench_dir: Path, *overrides: str):
    return to_config(compose([*TINY, f"benchmark_dir={bench_dir}", *overrides]))


@pytest.fixture(scope="module")
def frozen(tmp_path_factory):
    """Benchmark t1: one tiny house, one mission, frozen with the default robot."""
    d = tmp_path_factory.mktemp("benchmarks")
    dest, totals = freeze_benchmark(_cfg(d), "t1", "0" * 40)
    return d, dest, totals


def _records(scenes: Path) -> dict[str, dict]:
    return {p.parent.name: json.loads(p.read_text()) for p in sorted(scenes.glob("*/feasibility.json"))}


@pytest.fixture(scope="module")
def same_simulator(frozen, tmp_path_factory):
    d, _, _ = frozen
    out = tmp_path_factory.mktemp("same") / "scenes"
    run_scenes(_cfg(d, "benchmark=t1"), out)
    return out


@pytest.fixture(scope="module")
def shorter_reach(frozen, tmp_path_factory):
    """The same benchmark with the base poses drawn at most 0.2 m from the target (sim.pose_reach, 0.8 m
    by default): the arm cannot reach most objects."""
    d, _, _ = frozen
    out = tmp_path_factory.mktemp("short") / "scenes"
    run_scenes(_cfg(d, "benchmark=t1", "sim.pose_reach=0.2"), out)
    return out


def test_freezing_writes_the_houses_missions_and_measurement_with_their_hashes(frozen):
    _, dest, totals = frozen
    manifest = json.loads((dest / "manifest.json").read_text())
    assert manifest["name"] == "t1" and manifest["frozen_robot"] == "manipulathor"
    assert manifest["config"]["scene"]["name"] == "tiny" and "n_scenes" not in manifest["config"]["scene"]
    (scene,) = manifest["scenes"]
    assert sorted(p.name for p in (dest / scene["id"]).iterdir()) == ["feasibility.json", "missions.json",
                                                                       "scene.json"]
    assert totals == {"houses": 1, "missions": 1, "slots_drawn": 9, "slots_fulfillable": 9}


def test_the_same_simulator_measures_every_frozen_slot_as_frozen(frozen, same_simulator):
    _, dest, _ = frozen
    (sid, record), = _records(same_simulator).items()
    assert (same_simulator / sid / "missions.json").read_bytes() == (dest / sid / "missions.json").read_bytes()
    section = record.pop("benchmark")
    assert record == json.loads((dest / sid / "feasibility.json").read_text())
    assert section["slots"] == 9 and section["slots_changed"] == 0 and section["changes"] == []


def test_a_shorter_reach_reports_the_slots_whose_feasibility_changed_and_keeps_the_missions(frozen, shorter_reach):
    """The issue's check: change the robot's reach, and the scenes stage names the slots the simulator
    now measures differently, while the missions stay the frozen ones (not drawn anew)."""
    _, dest, _ = frozen
    (sid, record), = _records(shorter_reach).items()
    assert (shorter_reach / sid / "missions.json").read_bytes() == (dest / sid / "missions.json").read_bytes()
    b = record["benchmark"]
    assert b["slots_changed"] > 0 and b["pickups_changed"]
    assert b["slots_changed"] == sum(c["slots_then"] - c["slots_now"] for c in b["changes"])
    assert record["totals"]["slots_fulfillable"] == 9 - b["slots_changed"]
    assert {c["command"] for c in b["changes"]} <= {"breakfast", "meeting", "reading"}
    assert all(c["lost"] for c in b["changes"])
    assert {f["status"] for m in record["missions"] for f in m["commands"]} >= {"short"}


def test_metrics_json_and_the_report_header_carry_the_version_and_the_changes(frozen, same_simulator,
                                                                              shorter_reach):
    same = benchmark_summary(same_simulator, ["tiny_s0000"])
    short = benchmark_summary(shorter_reach, ["tiny_s0000"])
    assert same["name"] == short["name"] == "t1" and same["slots"] == short["slots"] == 9
    assert same["slots_changed"] == 0 and short["slots_changed"] > 0
    assert "all 9 slots measure as when frozen" in benchmark_sentence(same)
    assert f"{short['slots_changed']} of 9 slots" in benchmark_sentence(short)
    unknown = benchmark_summary(Path("/nonexistent"), ["x"])
    assert unknown == {"name": "", "unknown": ["x"]} and "is not known" in benchmark_sentence(unknown)


def test_scenes_from_different_benchmarks_are_refused_by_the_aggregate(frozen, same_simulator, tmp_path):
    mixed = tmp_path / "scenes"
    for sid, b in (("a", {"name": "t1"}), ("b", None)):
        (mixed / sid).mkdir(parents=True)
        (mixed / sid / "feasibility.json").write_text(json.dumps({"benchmark": b} if b else {}))
    with pytest.raises(MetricsInputError, match="different benchmarks"):
        benchmark_summary(mixed, ["a", "b"])


def test_a_config_the_benchmark_was_not_drawn_with_is_refused_naming_the_key(frozen, tmp_path):
    d, _, _ = frozen
    with pytest.raises(BenchmarkError, match=r"scene\.n_objects: frozen 12, given 20.*benchmark=''"):
        run_scenes(_cfg(d, "benchmark=t1", "scene.n_objects=20"), tmp_path / "scenes")
    with pytest.raises(BenchmarkError, match=r"mission\.n_missions: 1 frozen, 2 asked"):
        run_scenes(_cfg(d, "benchmark=t1", "mission.n_missions=2"), tmp_path / "scenes")
    assert not (tmp_path / "scenes").exists()  # refused before anything was written


def test_a_missing_benchmark_names_the_ones_there_and_how_to_freeze(frozen, tmp_path):
    d, _, _ = frozen
    with pytest.raises(BenchmarkError, match=r"benchmarks under .*\['t1'\].*freeze_benchmark t2"):
        open_benchmark(d, "t2")


@pytest.mark.parametrize("name", ["../t1", "T1", "a/b", ".hidden", "/tmp"])
def test_a_benchmark_name_that_is_not_one_folder_name_is_refused(name):
    with pytest.raises(ConfigError, match="config key 'benchmark'"):
        to_config(compose([*TINY, f"benchmark='{name}'"]))
    with pytest.raises(BenchmarkError, match="not a benchmark name"):
        open_benchmark(ROOT, name)


def test_a_changed_frozen_file_is_refused(frozen, tmp_path):
    import shutil

    d, dest, _ = frozen
    copy = tmp_path / "b"
    shutil.copytree(dest, copy / "t1")
    missions = next(copy.glob("t1/*/missions.json"))
    missions.write_text(missions.read_text().replace('"n_objects": 3', '"n_objects": 2', 1))
    with pytest.raises(BenchmarkError, match="not the file frozen.*never changed"):
        run_scenes(_cfg(copy, "benchmark=t1"), tmp_path / "scenes")


def test_an_existing_version_is_never_rewritten(frozen):
    d, dest, _ = frozen
    before = {p: p.read_bytes() for p in dest.rglob("*") if p.is_file()}
    with pytest.raises(BenchmarkError, match="never rewritten"):
        freeze_benchmark(_cfg(d), "t1", "1" * 40)
    assert {p: p.read_bytes() for p in dest.rglob("*") if p.is_file()} == before
    assert [p.name for p in d.iterdir()] == ["t1"]  # no partial folder left


def _mission(n: int, commands=("c1", "c2")) -> Mission:
    return Mission("m000", "s", (0.0, 0.0, 0.0), "f", tuple(Command(c, c, Goal(("x",), ("t",), n)) for c in commands))


def _frozen_record(fills: list[dict]) -> dict:
    return {"missions": [{"id": "m000", "commands": fills}]}


def _fill(cid, n, fulfillable, status="ok"):
    return {"id": cid, "asked": 2, "n_objects": n, "matched": n, "status": status, "instances": [],
            "fulfillable": list(fulfillable)}


def test_recheck_matches_slots_across_the_mission_and_lists_lost_and_gained_instances():
    record = _frozen_record([_fill("c1", 2, ["a", "b"]), _fill("c2", 2, ["b", "c", "d"]), _fill("c3", 0, [], "dropped")])
    # a is gone; c1 competes with c2 for b, c2 keeps c and d; e appears for c2
    now = Fulfillable(objects={"c1": ("b",), "c2": ("b", "c", "d", "e")}, capacity={"c1": 2, "c2": 2})
    drawn, changes = recheck([_mission(2)], record, now, k=2)
    (_, fills), = drawn
    assert [(f.command, f.n_objects, f.matched, f.status) for f in fills] == [
        ("c1", 2, 1, "short"), ("c2", 2, 2, "ok"), ("c3", 0, 0, "dropped")]
    assert [(c.command, c.slots_then, c.slots_now, c.lost, c.gained) for c in changes] == [
        ("c1", 2, 1, ("a",), ()), ("c2", 2, 2, (), ("e",))]
    assert set(fills[0].instances).isdisjoint(fills[1].instances)  # distinct instances across commands


def test_recheck_of_an_unchanged_measurement_reports_nothing():
    record = _frozen_record([_fill("c1", 2, ["a", "b"]), _fill("c2", 2, ["c", "d"])])
    now = Fulfillable(objects={"c1": ("a", "b"), "c2": ("c", "d")}, capacity={"c1": 2, "c2": 2})
    assert recheck([_mission(2)], record, now, k=2)[1] == []


def test_a_start_where_a_wider_footprint_collides_is_moved_to_one_where_it_does_not(frozen):
    """A frozen start on a free cell whose footprint would touch furniture (as the draw never picks when
    a clear cell exists) moves to the clear cell the draw would pick for this footprint."""
    from interllm.scene.grid import (
        approach_cells,
        clear_of_obstacles,
        free_components,
        largest_component,
        rasterize,
    )
    from interllm.scene.reachability import REACH_MARGIN

    _, dest, _ = frozen
    sid = next(p.name for p in dest.iterdir() if p.is_dir())
    scene = load_scene_file(dest / sid / "scene.json", robot_radius=0.15)
    grid = rasterize(scene, 0.05, 0.15, doors="true")
    labels, _ = free_components(grid)
    m = json.loads((dest / sid / "missions.json").read_text())["missions"][0]
    footprint = 0.3
    clear = clear_of_obstacles(grid.free, footprint - 0.15, 0.05)
    cells = approach_cells(grid, scene.furniture[m["start_furniture"]].footprint, 0.15 + REACH_MARGIN)
    cells = [tuple(c) for c in cells if labels[c[0], c[1]] == largest_component(labels)]
    tight = next(c for c in cells if not clear[c])  # free, but the wider footprint touches something
    assert any(clear[c] for c in cells)
    x, y = (float(v) for v in grid.cell_to_world(np.array(tight)))
    mission = Mission.from_dict({**m, "start": [x, y, 0.0]})
    moved = standable_start(scene, mission, grid, 0.15, footprint)
    assert moved != mission.start and clear[tuple(grid.world_to_cell(moved[:2]))]
    assert standable_start(scene, mission, grid, 0.15, None) == mission.start  # no footprint given: it stays


def test_a_start_the_robot_cannot_stand_on_is_moved_next_to_the_same_furniture(frozen):
    """A frozen start inside furniture (a larger robot's inflated obstacles) moves to a free cell next to
    the mission's start furniture; a free one stays."""
    from interllm.scene.grid import rasterize

    _, dest, _ = frozen
    sid = next(p.name for p in dest.iterdir() if p.is_dir())
    scene = load_scene_file(dest / sid / "scene.json", robot_radius=0.15)
    grid = rasterize(scene, 0.05, 0.15, doors="true")
    m = json.loads((dest / sid / "missions.json").read_text())["missions"][0]
    mission = Mission.from_dict(m)
    assert standable_start(scene, mission, grid, 0.15) == mission.start
    f = scene.furniture[mission.start_furniture]
    inside = Mission.from_dict({**m, "start": [f.center[0], f.center[1], 0.0]})
    moved = standable_start(scene, inside, grid, 0.15)
    assert moved != inside.start and grid.is_free(grid.world_to_cell(moved[:2]))
    assert standable_start(scene, Mission.from_dict({**m, "start": list(moved)}), grid, 0.15) == tuple(moved)


@pytest.mark.parametrize("experiment", sorted(p.stem for p in (ROOT / "conf" / "experiment").glob("*.yaml")))
def test_every_experiment_on_the_committed_benchmark_was_drawn_with_its_config(experiment, monkeypatch):
    """conf/ and data/benchmarks/ agree: an experiment that names a benchmark opens it with its own scene
    and mission config (a changed default in conf/scene or conf/mission fails here, not in a run)."""
    from interllm.stages.scenes import open_configured_benchmark

    monkeypatch.chdir(ROOT)  # benchmark_dir is relative to the repository, as DVC and pipeline.run use it
    cfg = to_config(compose([f"experiment={experiment}"]))
    bench = open_configured_benchmark(cfg)
    assert bench.name == ("mechanism-v2" if experiment == "mechanism" else "paper-v3")
    assert len(bench.scenes_frozen) >= cfg.scene.n_scenes
