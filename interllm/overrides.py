"""``key=value`` overrides of params.yaml for the commands outside Hydra (``interllm llm probe``).

The values are YAML (``llm.timeout_s=30`` is a number). An override that picks the LLM backend,
``llm=<name>`` or an ``llm.backend=<name>`` other than the one params.yaml names, starts the llm
section from that backend's preset (``conf/llm/<name>.yaml``, as Hydra's ``llm=<name>`` does), not
from the workspace's: params.yaml may hold another backend's settings (after ``dvc exp run -S
llm=oracle``: the oracle's modes) that contradict the backend asked for.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from interllm.config import ConfigError, LLMConfig

CONF_DIR = Path(__file__).resolve().parent.parent / "conf"


def parse_override(text: str) -> tuple[str, Any]:
    """(dotted key, YAML value) of ``key=value``."""
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise ConfigError(f"override {text!r} is not key=value (e.g. llm.base_url=http://...)")
    return key, yaml.safe_load(value)


def set_dotted(d: dict, key: str, value: Any) -> None:
    *parents, leaf = key.split(".")
    for k in parents:
        if not isinstance(d.get(k), dict):
            d[k] = {}
        d = d[k]
    d[leaf] = value


def llm_preset(name: str) -> dict:
    """The llm section of ``llm=<name>`` composed from conf/ (its defaults included), or only the
    backend's name where conf/ has no such preset (the config's defaults fill in the rest)."""
    if not (CONF_DIR / "llm" / f"{name}.yaml").is_file():
        return {"backend": name}
    from hydra import compose, initialize_config_dir  # lazy: only when a preset is asked for
    from omegaconf import OmegaConf  # lazy: with hydra, only when a preset is asked for

    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose(config_name="config", overrides=[f"llm={name}"])
    return OmegaConf.to_container(cfg.llm, resolve=True)


def apply_overrides(raw: dict, overrides: list[str]) -> str:
    """Apply ``overrides`` to the params dict ``raw`` in place; returns a note for the user when the
    llm section was started from a backend's preset ("" otherwise)."""
    pairs = [parse_override(o) for o in overrides]
    llm = raw.get("llm") if isinstance(raw.get("llm"), dict) else {}
    current = str(llm.get("backend", LLMConfig.backend))
    picked = [(k, str(v)) for k, v in pairs if k == "llm" or (k == "llm.backend" and str(v) != current)]
    note = ""
    if picked:
        key, name = picked[-1]
        raw["llm"] = llm_preset(name)
        note = (f"note: {key}={name}: the llm section is the {name} preset (conf/llm/{name}.yaml) with the "
                f"other overrides on top, not params.yaml's llm section (llm.backend={current!r})")
    for key, value in pairs:
        if key != "llm":
            set_dotted(raw, key, value)
    return note


def compose_config(overrides: list[str]) -> dict:
    """The experiment config that ``python -m pipeline.run <overrides>`` composes from conf/ (Hydra
    overrides: ``sim/robot=stretch``, ``sim.n_l=10``), as a plain dict."""
    from hydra import compose, initialize_config_dir  # lazy: only the commands that compose load hydra
    from hydra.errors import HydraException  # lazy: with hydra
    from omegaconf import OmegaConf  # lazy: with hydra

    try:
        with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
            cfg = compose(config_name="config", overrides=list(overrides))
    except HydraException as e:
        raise ConfigError(f"overrides {list(overrides)}: {e}") from e
    out = OmegaConf.to_container(cfg, resolve=True)
    out.pop("hydra", None)
    return out
