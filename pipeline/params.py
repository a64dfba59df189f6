"""Compose conf/ (+ overrides) into params.yaml, exactly as DVC's Hydra integration does (both load
the config schema through the Hydra plugin hydra_plugins/interllm_schema).

    python -m pipeline.params                      # the default experiment (paper)
    python -m pipeline.params experiment=quick     # any Hydra overrides

`dvc exp run -S key=value` does the same composition itself; this entry point is for `dvc repro`
after editing conf/ and for the test that proves the committed params.yaml is up to date.
"""

from __future__ import annotations

import sys

import yaml
from omegaconf import OmegaConf

from interllm.config import ConfigError
from interllm.io import atomic_write_text
from pipeline._common import ROOT
from pipeline._hydra import compose, to_config


def compose_params(overrides: list[str]) -> str:
    """The params.yaml text: written exactly as DVC's compose_and_dump writes it."""
    cfg = compose(overrides)
    to_config(cfg)  # validate types, ranges and unknown keys (raises ConfigError naming the key)
    OmegaConf.resolve(cfg)
    return OmegaConf.to_yaml(cfg)


def main(argv: list[str]) -> int:
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    try:
        text = compose_params(argv)
    except (HydraException, OmegaConfBaseException) as e:  # a bad override: Hydra's message names it
        cause = f": {e.__cause__}" if e.__cause__ is not None else ""
        print(f"error: {e}{cause}".replace("\n", " "), file=sys.stderr)
        return 2
    except ConfigError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    atomic_write_text(ROOT / "params.yaml", text)
    print(f"wrote {ROOT / 'params.yaml'} (experiment={yaml.safe_load(text)['experiment']})")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
