"""Several imported houses form one experiment: scene.import_path names a folder of
<house>/scene.json files (what `interllm scene import-procthor house.json --out <folder>/<house>/`
writes), each one a scene of the experiment, as generated houses are."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from interllm.errors import MissingInputError
from interllm.scene.generator import generate_scene
from interllm.scene.validate import SceneValidationError
from interllm.stages.freeze import freeze_benchmark
from interllm.stages.scenes import imported_files, run_scenes, scene_count
from pipeline._hydra import compose, to_config


def _houses(folder: Path, n: int) -> list[str]:
    """n tiny houses written as <folder>/house_<i>/scene.json; their scene ids."""
    cfg = to_config(compose(["scene=tiny", "benchmark="]))
    ids = []
    for i in range(n):
        scene = generate_scene(cfg.scene, i, robot_radius=cfg.sim.robot_radius,
                               objects_per_command=cfg.mission.objects_per_command,
                               footprint_radius=cfg.sim.footprint_radius)
        (folder / f"house_{i}").mkdir(parents=True)
        (folder / f"house_{i}" / "scene.json").write_text(scene.to_json())
        ids.append(scene.id)
    return ids


def _cfg(import_path: Path):
    return to_config(compose(["experiment=quick", "benchmark=", f"scene.import_path={import_path}"]))


def test_a_folder_of_imported_houses_is_one_experiment_of_several_scenes(tmp_path):
    ids = _houses(tmp_path / "houses", 2)
    cfg = _cfg(tmp_path / "houses")
    assert scene_count(cfg) == 2 and [p.parent.name for p in imported_files(cfg.scene.import_path)] == ["house_0",
                                                                                                     "house_1"]
    out = tmp_path / "scenes"
    assert run_scenes(cfg, out) == ids
    for sid in ids:
        missions = json.loads((out / sid / "missions.json").read_text())["missions"]
        assert len(missions) == 1 and missions[0]["scene_id"] == sid
    # one file is still one scene
    assert scene_count(_cfg(tmp_path / "houses" / "house_1" / "scene.json")) == 1


def test_two_houses_with_one_scene_id_are_refused_naming_both_files_before_any_is_written(tmp_path):
    _houses(tmp_path / "houses", 1)
    shutil.copytree(tmp_path / "houses" / "house_0", tmp_path / "houses" / "house_copy")
    with pytest.raises(SceneValidationError, match=r"house_copy/scene.json: \$\.id: .*also the id of .*house_0"):
        run_scenes(_cfg(tmp_path / "houses"), tmp_path / "scenes")
    assert not list((tmp_path / "scenes").glob("*/scene.json"))


def test_a_benchmark_of_imported_houses_runs_from_its_frozen_copy_wherever_the_folder_is(tmp_path):
    """Frozen from a folder of two imported houses, the benchmark runs both from its own copy: with the
    folder moved (another path on another machine) or gone."""
    ids = _houses(tmp_path / "houses", 2)
    bench = tmp_path / "benchmarks"
    freeze_benchmark(to_config(compose(["experiment=quick", f"benchmark_dir={bench}",
                                        f"scene.import_path={tmp_path / 'houses'}"])), "imp", "0" * 40)
    shutil.move(tmp_path / "houses", tmp_path / "moved")
    for where in (tmp_path / "moved", tmp_path / "gone"):
        cfg = to_config(compose(["experiment=quick", f"benchmark_dir={bench}", "benchmark=imp",
                                 f"scene.import_path={where}"]))
        assert run_scenes(cfg, tmp_path / where.name / "scenes") == ids


def test_a_folder_without_houses_names_the_layout_it_expects(tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(MissingInputError, match=r"folder without <house>/scene.json files.*--out"):
        scene_count(_cfg(tmp_path / "empty"))
    _houses(tmp_path / "one", 1)
    shutil.move(tmp_path / "one" / "house_0" / "scene.json", tmp_path / "one" / "scene.json")
    with pytest.raises(MissingInputError, match=r"name it: scene.import_path=.*one/scene.json"):
        scene_count(_cfg(tmp_path / "one"))
