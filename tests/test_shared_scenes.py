"""Scenes shared by the jobs of a re-make (interllm/stages/shared_scenes.py): the key covers exactly
what the scenes stage reads, and a stored entry is whole or absent."""

from __future__ import annotations

import os
from pathlib import Path

import yaml

from interllm.stages.shared_scenes import SCENE_SECTIONS, SharedScenes, scenes_key

ROOT = Path(__file__).resolve().parents[1]
CONFIG = {"seed": 0, "benchmark": "paper-v3", "scene": {"n_scenes": 10}, "mission": {"n_missions": 3},
          "sim": {"robot": "manipulathor"}, "llm": {"temperature": 0.8}, "planner": {"M": 3}}


def test_the_key_covers_the_params_the_scenes_stage_declares():
    """dvc.yaml's scenes stage lists the params its output depends on; the key reads the same ones
    (benchmark_dir only says where the benchmark is: the key reads the benchmark's files instead)."""
    stage = yaml.safe_load((ROOT / "dvc.yaml").read_text())["stages"]["scenes"]
    assert set(stage["params"]) - {"benchmark_dir"} == set(SCENE_SECTIONS)


def test_the_key_moves_with_the_scene_setting_and_not_with_the_planners(tmp_path):
    (tmp_path / "interllm").mkdir()
    (tmp_path / "interllm" / "a.py").write_text("x = 1\n")
    key = scenes_key(CONFIG, tmp_path, None)
    assert scenes_key({**CONFIG, "llm": {"temperature": 0.2}, "planner": {"M": 5}}, tmp_path, None) == key
    for section, value in (("scene", {"n_scenes": 3}), ("mission", {"n_missions": 1}), ("sim", {"robot": "stretch"}),
                           ("seed", 1), ("benchmark", "")):
        assert scenes_key({**CONFIG, section: value}, tmp_path, None) != key, section
    (tmp_path / "interllm" / "a.py").write_text("x = 2\n")  # the code
    assert scenes_key(CONFIG, tmp_path, None) != key
    bench = tmp_path / "bench"
    bench.mkdir()
    (bench / "manifest.json").write_text("{}")
    with_bench = scenes_key(CONFIG, tmp_path, bench)
    (bench / "manifest.json").write_text("{ }")  # the benchmark's files
    assert scenes_key(CONFIG, tmp_path, bench) != with_bench


def test_an_entry_is_stored_once_and_fetched_whole(tmp_path):
    scenes = tmp_path / "scenes"
    (scenes / "h0").mkdir(parents=True)
    (scenes / "h0" / "scene.json").write_text("{}")
    shared = SharedScenes(tmp_path / "store", "k")
    assert not shared.fetch(tmp_path / "out0")  # nothing stored yet
    shared.store(scenes)
    (scenes / "h0" / "scene.json").write_text("changed")
    shared.store(scenes)  # a second job of the same key keeps the first entry
    assert shared.fetch(tmp_path / "out1")
    assert (tmp_path / "out1" / "h0" / "scene.json").read_text() == "{}"
    assert sorted(os.listdir(tmp_path / "store")) == ["k"]  # no temporary folder left
