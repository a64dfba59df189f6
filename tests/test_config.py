"""Configuration: every experiment composes, bad values fail with the key named, params.yaml is
the composition of conf/ (as DVC's own Hydra integration writes it)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from interllm.config import ConfigError, ExperimentConfig, from_dict
from interllm.planners import PLANNERS
from pipeline._hydra import compose, to_config
from pipeline.params import compose_params

ROOT = Path(__file__).resolve().parent.parent
EXPERIMENTS = sorted(p.stem for p in (ROOT / "conf" / "experiment").glob("*.yaml"))


def test_experiment_files_exist():
    assert {"paper", "quick", "temperature_ablation", "m_ablation"} <= set(EXPERIMENTS)


@pytest.mark.parametrize("name", EXPERIMENTS)
def test_every_experiment_composes_and_validates(name):
    cfg = OmegaConf.to_object(compose([f"experiment={name}"]))
    assert isinstance(cfg, ExperimentConfig)
    assert cfg.experiment == name


def test_paper_experiment_is_the_papers_protocol():
    cfg = OmegaConf.to_object(compose([]))
    assert cfg.experiment == "paper"
    assert (cfg.scene.n_rooms, cfg.scene.n_furniture, cfg.scene.n_objects) == (9, 26, 30)
    assert cfg.scene.n_scenes == 3 and cfg.mission.n_missions == 10
    assert cfg.mission.commands_per_mission == 3 and cfg.mission.include_paper_mission
    planners = ["inter_llm", "sayplan", "moma_llm", "nothing", "optimal"]  # the three, then the references
    assert cfg.planner.names == planners == sorted(PLANNERS.names(), key=planners.index) and cfg.planner.M == 3
    assert cfg.llm.temperature == 0.8 and cfg.llm.backend == "embedded"
    assert (cfg.sim.gamma_nav, cfg.sim.gamma_man, cfg.metrics.gamma_obj) == (10, 100, 100)


def test_quick_is_one_scene_one_mission_all_planners():
    cfg = OmegaConf.to_object(compose(["experiment=quick"]))
    assert cfg.scene.n_scenes == 1 and cfg.mission.n_missions == 1
    assert cfg.planner.names == ["inter_llm", "sayplan", "moma_llm", "nothing", "optimal"]


@pytest.mark.parametrize("override, key, hint", [
    ("llm.temperature=-1", "llm.temperature", "[0, 2]"),
    ("planner.M=0", "planner.M", "[1, 20]"),
    ("planner.names=[foo]", "planner.names", "inter_llm"),
    ("llm.backend=chatgpt", "llm.backend", "openai"),
    ("llm.cache_mode=sometimes", "llm.cache_mode", "replay"),
    ("sim.n_l=0", "sim.n_l", "[1, 50]"),
    ("sim.pose_protocol=random", "sim.pose_protocol", "reach"),
    ("sim.pose_reach=0.1", "sim.pose_reach", "sim.robot_radius"),
    ("sim.pose_margin=-0.1", "sim.pose_margin", "[0, 1]"),
])
def test_out_of_range_values_name_the_key_and_valid_values(override, key, hint):
    with pytest.raises(ConfigError) as e:
        to_config(compose([override]))
    assert f"'{key}'" in str(e.value) and hint in str(e.value)


def test_unknown_key_fails_at_composition_naming_it():
    with pytest.raises(Exception) as e:
        compose(["llm.temprature=0.5"])
    assert "llm.temprature" in str(e.value)


def test_wrong_type_fails_at_composition():
    with pytest.raises(Exception) as e:
        compose(["planner.M=three"])
    assert "M" in str(e.value)


def test_unknown_planner_group_lists_choices():
    with pytest.raises(Exception) as e:
        compose(["planner=foo"])
    msg = str(e.value)
    assert "planner/foo" in msg and "inter_llm" in msg


def test_from_dict_rejects_unknown_keys_in_params_file():
    with pytest.raises(ConfigError, match="'llm.temprature' is unknown"):
        from_dict({"llm": {"temprature": 0.3}})


def test_committed_params_yaml_is_the_composition_of_conf():
    assert (ROOT / "params.yaml").read_text() == compose_params([]), (
        "params.yaml is stale: run `python -m pipeline.params`")


def test_dvc_hydra_composition_writes_the_same_params(tmp_path):
    """DVC's own compose_and_dump (what `dvc exp run -S` uses) gives the committed params.yaml."""
    code = (
        "import sys; from dvc.utils.hydra import compose_and_dump; "
        f"compose_and_dump(sys.argv[1], {str(ROOT / 'conf')!r}, None, 'config', {str(ROOT)!r}, [])"
    )
    out = tmp_path / "params.yaml"
    subprocess.run([sys.executable, "-c", code, str(out)], check=True, cwd=tmp_path)
    assert out.read_text() == (ROOT / "params.yaml").read_text()


def test_dvc_config_enables_hydra_and_disables_analytics():
    text = (ROOT / ".dvc" / "config").read_text()
    assert "analytics = false" in text
    assert "[hydra]" in text and "enabled = true" in text


@pytest.mark.parametrize("size", ["tiny", "paper", "large", "huge"])
def test_scene_conf_files_match_the_catalog_presets(size):
    from interllm.scene.catalog import scene_config

    cfg = OmegaConf.to_object(compose([f"scene={size}"]))
    preset = scene_config(size)
    assert (cfg.scene.n_rooms, cfg.scene.n_furniture, cfg.scene.n_objects) == (
        preset.n_rooms, preset.n_furniture, preset.n_objects)


def _differences(a: dict, b: dict, prefix: str = "") -> list[str]:
    out = []
    for k in sorted(set(a) | set(b)):
        if isinstance(a.get(k), dict) and isinstance(b.get(k), dict):
            out += _differences(a[k], b[k], f"{prefix}{k}.")
        elif a.get(k, "<missing>") != b.get(k, "<missing>"):
            out.append(f"{prefix}{k}: conf/ {a.get(k, '<missing>')!r}, interllm/config.py {b.get(k, '<missing>')!r}")
    return out


def test_the_composed_default_is_the_dataclass_default():
    """conf/ (what runs use) and the dataclasses (what ExperimentConfig() in tests and code gives) hold
    the same defaults: a value changed in one place only is named here."""
    from dataclasses import asdict

    composed = asdict(to_config(compose([], typed=False)))
    assert _differences(composed, asdict(ExperimentConfig())) == []
