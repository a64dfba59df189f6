"""Shared by the stage entry points: read params.yaml (written by DVC from conf/), validate it,
set up logging. Errors name the config key and exit with status 2 instead of a traceback."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable
from pathlib import Path

import yaml

from interllm.config import ConfigError, ExperimentConfig, from_dict
from interllm.provenance import log_loaded_modules

ROOT = Path(__file__).resolve().parent.parent


def load_params(path: Path | None = None) -> tuple[ExperimentConfig, dict]:
    path = path or ROOT / "params.yaml"
    if not path.is_file():
        raise ConfigError(f"{path} is missing: run `dvc exp run` or `python -m pipeline.params` to "
                          f"compose it from conf/")
    raw = yaml.safe_load(path.read_text()) or {}
    return from_dict(raw), raw


def setup_logging(verbose: bool) -> None:
    logging.basicConfig(level=logging.DEBUG if verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")


def stage_main(name: str, body: Callable[[ExperimentConfig, dict, Path], None]) -> None:
    ap = argparse.ArgumentParser(prog=f"python -m pipeline.{name}", description=f"DVC stage '{name}'")
    ap.add_argument("--params", type=Path, default=None, help="params file (default: params.yaml)")
    ap.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    args = ap.parse_args()
    try:
        cfg, raw = load_params(args.params)
    except ConfigError as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(2)
    setup_logging(args.verbose or cfg.verbose)
    data = Path(cfg.data_dir)
    if not data.is_absolute():
        data = ROOT / data
    body(cfg, raw, data)
    log_loaded_modules(name)
