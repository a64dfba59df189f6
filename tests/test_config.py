"""Configuration: every experiment composes, bad values fail with the key named, params.yaml is
the composition of conf/ (as DVC's own Hydra integration writes it)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from dataclasses import asdict
from pathlib import Path

import pytest
import yaml
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
    assert (cfg.scene.n_scenes, cfg.mission.n_missions) == (10, 3) and cfg.benchmark == "paper-v3"  # 10 houses x 3
    assert (cfg.scene.assets, cfg.mission.commands, cfg.metrics.interval) == ("procthor", "open", "cr2")
    assert cfg.mission.commands_per_mission == 3 and cfg.mission.include_paper_mission
    planners = ["inter_llm", "sayplan", "moma_llm", "nothing", "optimal"]  # the three, then the references
    # every registered planner but the ablation variants (planner=mechanism runs those)
    compared = [n for n in PLANNERS.names() if not PLANNERS.entry(n).meta.get("ablates")]
    assert cfg.planner.names == planners == sorted(compared, key=planners.index) and cfg.planner.M == 3
    assert len(PLANNERS.names()) == len(compared) + 3
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
    ("planner.inter_llm.nav_estimate=mean", "planner.inter_llm.nav_estimate", "paper_sum"),
    ("planner.sayplan.max_iterations=0", "planner.sayplan.max_iterations", "[1, 20]"),
    ("planner.moma_llm.max_replans=-1", "planner.moma_llm.max_replans", "[0, 20]"),
    ("planner.MM=3", "planner.MM", "planner.M"),
    ("planner.sayplam.max_iterations=2", "planner.sayplam", "planner.sayplan"),
    ("sim.pose_protocol=random", "sim.pose_protocol", "reach"),
    ("sim.pose_reach=0.1", "sim.pose_reach", "sim.robot_radius"),
    ("sim.pose_margin=-0.1", "sim.pose_margin", "[0, 1]"),
])
def test_out_of_range_values_name_the_key_and_valid_values(override, key, hint):
    with pytest.raises(ConfigError) as e:
        to_config(compose([override]))
    assert f"'{key}'" in str(e.value) and hint in str(e.value)


@pytest.mark.parametrize("override", ["llm.temprature=0.5", "planner.inter_llm.nav_estimat=prior"])
def test_unknown_key_fails_at_composition_naming_it(override):
    with pytest.raises(Exception) as e:
        compose([override])
    assert override.split("=")[0] in str(e.value)


def test_wrong_type_fails_at_composition():
    with pytest.raises(Exception) as e:
        compose(["planner.M=three"])
    assert "M" in str(e.value)


def test_a_typed_planner_node_rejects_a_wrong_type_at_composition():
    with pytest.raises(Exception) as e:
        compose(["planner.inter_llm.epsilon_d=wide"])
    assert "planner.inter_llm.epsilon_d" in str(e.value)


def test_each_planner_gets_its_own_node_and_a_variant_the_node_of_what_it_ablates():
    from interllm.planners.base import make_planner

    cfg = to_config(compose(["planner=mechanism", "planner.inter_llm.nav_estimate=paper_sum",
                             "planner.inter_llm.epsilon_d=2.5", "planner.sayplan.max_iterations=5",
                             "planner.moma_llm.max_replans=1"]))
    full = make_planner("inter_llm", cfg.planner).settings
    assert (full.nav_estimate, full.epsilon_d) == ("paper_sum", 2.5)
    for variant in ("inter_llm_no_learning", "inter_llm_no_cost_choice", "inter_llm_no_carry_over"):
        assert make_planner(variant, cfg.planner).settings == full  # paired: every other setting equal
    assert make_planner("sayplan", cfg.planner).settings.max_iterations == 5
    assert make_planner("moma_llm", cfg.planner).settings.max_replans == 1
    assert not hasattr(make_planner("nothing", cfg.planner), "settings")  # registers none: built bare


@pytest.mark.parametrize("old, new", [("nav_estimate=paper_sum", "inter_llm.nav_estimate"),
                                      ("moma_max_replans=1", "moma_llm.max_replans"),
                                      ("sayplan_max_iterations=2", "sayplan.max_iterations")])
def test_a_flat_key_of_the_old_layout_is_refused_with_its_new_name(old, new):
    with pytest.raises(ConfigError, match=rf"'planner.{old.split('=')[0]}'.* is now 'planner.{new}'"):
        to_config(compose([f"planner.{old}"]))


def test_an_outside_planners_node_is_kept_as_composed_and_written_back_where_it_was():
    from interllm.config import to_dict

    cfg = from_dict({"planner": {"names": ["inter_llm"], "mine": {"horizon": 5}}})
    assert cfg.planner.external == {"mine": {"horizon": 5}}
    with pytest.raises(ConfigError, match=r"valid keys: \[.M., .fair_baselines., .inter_llm., .max_regenerations., .modules., .moma_llm., .names., .sayplan.\]"):
        from_dict({"planner": {"MM": 3}})  # where external nodes are kept is no key to offer
    assert to_dict(cfg)["planner"]["mine"] == {"horizon": 5} and "external" not in to_dict(cfg)["planner"]
    assert from_dict(to_dict(cfg)) == cfg
    with pytest.raises(ConfigError, match=r"'planner.mine' is neither .*registered planner"):
        to_config(compose(["+planner.mine.horizon=5"]))  # no module registers a planner with that node


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
    the same defaults: a base option file that sets a value other than the dataclass's is named here."""
    composed = asdict(to_config(compose([])))
    # but the benchmark: conf/ runs on the committed benchmark (data/benchmarks/paper-v3) with the
    # settings it was drawn with and the interval valid at its 10 houses, while library use
    # (ExperimentConfig(), tests of other houses) draws from its own measurement and needs no file
    assert composed.pop("benchmark") == "paper-v3"
    default = asdict(ExperimentConfig())
    assert default.pop("benchmark") == ""
    assert sorted(d.split(":")[0] for d in _differences(composed, default)) == BENCHMARK_SETTINGS


# what conf/scene/paper.yaml, conf/mission/paper.yaml and conf/metrics/default.yaml set (benchmark paper-v3)
BENCHMARK_SETTINGS = ["metrics.interval", "mission.commands", "mission.n_missions", "scene.assets", "scene.n_scenes"]


GROUPS = ("scene", "mission", "llm", "planner", "sim", "metrics")


def _leaves(d: dict, prefix: str = ""):
    for k, v in d.items():
        if isinstance(v, dict):
            yield from _leaves(v, f"{prefix}{k}.")
        else:
            yield f"{prefix}{k}", v


def _lookup(d: dict, dotted: str):
    for k in dotted.split("."):
        if not isinstance(d, dict) or k not in d:
            return "<missing>"
        d = d[k]
    return d


def _inherited(conf: Path, group: str, raw: dict) -> dict:
    """The values of the sibling options an option file names in its defaults list."""
    out: dict = {}
    for parent in raw.get("defaults", []):
        if isinstance(parent, str) and parent != "_self_":
            parent_raw = yaml.safe_load((conf / group / f"{parent}.yaml").read_text()) or {}
            out.update({**_inherited(conf, group, parent_raw), **parent_raw})
    out.pop("defaults", None)
    return out


def _composed(conf: Path, overrides: list[str]) -> dict:
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir

    with initialize_config_dir(config_dir=str(conf), version_base="1.3"):
        return OmegaConf.to_container(hydra_compose(config_name="config", overrides=overrides), resolve=True)


def repeated_defaults(conf: Path) -> list[str]:
    """Every value an option file under ``conf`` sets to what it would be without it: a group option
    file against the dataclass defaults (and the sibling options it names in its defaults list), an
    experiment against the composition of the groups it overrides, conf/config.yaml against
    ExperimentConfig(). An experiment's own name (key ``experiment``) is exempt."""
    default = asdict(ExperimentConfig())
    found = []
    root = yaml.safe_load((conf / "config.yaml").read_text()) or {}
    found += [f"config.yaml: {k}: {v!r}" for k, v in _leaves(root) if k != "defaults" and _lookup(default, k) == v]
    for group in GROUPS:
        for path in sorted((conf / group).glob("*.yaml")):
            raw = yaml.safe_load(path.read_text()) or {}
            base = {**default[group], **_inherited(conf, group, raw)}
            found += [f"{group}/{path.name}: {k}: {v!r}" for k, v in _leaves(raw) if k != "defaults"
                      and _lookup(base, k) == v]
    for path in sorted((conf / "experiment").glob("*.yaml")):
        raw = yaml.safe_load(path.read_text()) or {}
        overrides = [f"{k.split('/')[-1]}={v}" for entry in raw.pop("defaults", []) if isinstance(entry, dict)
                     for k, v in entry.items() if k.startswith("override /")]
        base = _composed(conf, overrides)
        found += [f"experiment/{path.name}: {k}: {v!r}" for k, v in _leaves(raw) if k != "experiment"
                  and _lookup(base, k) == v]
    return found


def test_option_files_hold_only_what_differs_from_the_defaults():
    """Defaults live once, in interllm/config.py: an option file that repeats one is named here (delete
    the line; a value that differs belongs in the option file)."""
    assert repeated_defaults(ROOT / "conf") == []


def test_a_repeated_default_is_found(tmp_path):
    conf = tmp_path / "conf"
    shutil.copytree(ROOT / "conf", conf)
    with (conf / "scene" / "paper.yaml").open("a") as f:
        f.write("n_rooms: 9\n")
    with (conf / "llm" / "oracle.yaml").open("a") as f:
        f.write("oracle_error: 0.0\n")
    with (conf / "experiment" / "quick.yaml").open("a") as f:
        f.write("planner:\n  M: 3\n")
    assert repeated_defaults(conf) == ["scene/paper.yaml: n_rooms: 9", "llm/oracle.yaml: oracle_error: 0.0",
                                       "experiment/quick.yaml: planner.M: 3"]


def test_hydra_plugin_discovery_registers_the_schema(tmp_path):
    """Hydra's plugin discovery alone (no project module imported, the checkout not on sys.path: as in
    DVC's composition) registers the schema from this checkout's hydra_plugins/interllm_schema, which the
    editable install (`make install`) puts on the interpreter's path."""
    code = (
        "import sys; from hydra.core.plugins import Plugins; from hydra.core.config_store import ConfigStore; "
        "Plugins.instance(); node = ConfigStore.instance().load('_schema/root.yaml').node; "
        "print(sys.modules['hydra_plugins.interllm_schema'].__file__); "
        "print(sorted(k for k in sys.modules if k.split('.')[0] == 'pipeline')); print(node.scene.n_rooms)"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, cwd=tmp_path, capture_output=True,
                         text=True).stdout.splitlines()
    assert Path(out[0]) == ROOT / "hydra_plugins" / "interllm_schema" / "__init__.py"
    assert out[1:] == ["[]", str(ExperimentConfig().scene.n_rooms)]


def test_a_missing_schema_plugin_is_named(monkeypatch):
    from hydra.core.config_store import ConfigStore
    from hydra.core.plugins import Plugins

    Plugins.instance()  # discovery done: it does not run again to restore the entry
    monkeypatch.delitem(ConfigStore.instance().repo, "_schema")
    with pytest.raises(ConfigError, match=r"hydra_plugins/interllm_schema .*`make install`"):
        compose([])


def test_an_outside_planners_settings_are_checked_against_its_dataclass_before_anything_runs():
    from dataclasses import dataclass

    from interllm.stages.validate import check_registered

    @dataclass
    class HorizonConfig:
        horizon: int  # no default: must be set
        label: str = "h"

    PLANNERS.register("horizon_probe", config=HorizonConfig)(lambda settings: settings)
    try:
        for node, message in (({}, r"'planner.horizon_probe.horizon'.* is required"),
                              ({"horizon": "far"}, r"'planner.horizon_probe.horizon'.* must be an integer"),
                              ({"horizon": 3, "lable": "x"}, r"'planner.horizon_probe.lable'.*did you mean "
                                                              r"planner.horizon_probe.label\?")):
            cfg = from_dict({"planner": {"names": ["horizon_probe"], "horizon_probe": node}})
            with pytest.raises(ConfigError, match=message):
                check_registered(cfg)
        check_registered(from_dict({"planner": {"names": ["horizon_probe"], "horizon_probe": {"horizon": 3}}}))
    finally:
        PLANNERS.unregister("horizon_probe")
