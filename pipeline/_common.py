"""Shared by the stage entry points: read params.yaml (written by DVC from conf/), validate it,
set up logging, run the stage body. A user-fixable error (interllm.errors.UserError: a bad config
key, file, URL or model; a full disk or read-only folder) is printed as one message without a
traceback and exits with status 2; under DVC the message also says how to get back the outputs DVC
removed before the stage ran, when the DVC cache holds them."""

from __future__ import annotations

import argparse
import configparser
import logging
import os
import sys
import traceback
from collections.abc import Callable
from pathlib import Path

import yaml

from interllm.config import ConfigError, ExperimentConfig, from_dict
from interllm.errors import INTERRUPTED_EXIT, UserError, interrupted_message, output_error
from interllm.imports_log import log_loaded_modules
from interllm.io import confine_writes

ROOT = Path(__file__).resolve().parent.parent
QUIET_LOGGERS = ("httpx", "httpx2", "httpcore", "openai")  # a line per HTTP request (INFO) unless verbose


def load_params(path: Path | None = None) -> tuple[ExperimentConfig, dict]:
    """The config a stage runs (params.yaml validated, the top-level seed applied:
    ``ExperimentConfig.seeded``) and the raw mapping."""
    path = path or ROOT / "params.yaml"
    if not path.is_file():
        raise ConfigError(f"{path} is missing: run `dvc exp run` or `python -m pipeline.params` to "
                          f"compose it from conf/")
    try:
        raw = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    except (UnicodeDecodeError, yaml.YAMLError) as e:
        raise ConfigError(f"{path} is not readable YAML ({e}); recompose it with `make params`") from None
    if not isinstance(raw, dict):
        raise ConfigError(f"{path} must hold a mapping of config keys, got {type(raw).__name__}; "
                          f"recompose it with `make params`")
    return from_dict(raw, source=str(path)).seeded(), raw


def write_folders(cfg: ExperimentConfig, data: Path, llm: bool = True) -> tuple[Path, ...]:
    """The folders a stage or run may write into (``interllm.io.confine_writes``): its data folder
    and, when it talks to the LLM (``llm``), the response cache and the folder the packaged model is
    assembled in (a relative cache folder is the client's: relative to the working directory)."""
    if not llm:
        return (data,)
    from interllm.llm.model_files import model_dir  # lazy: a stage without the LLM does not load it

    return data, Path(cfg.llm.cache_dir), model_dir()


def setup_logging(verbose: bool) -> None:
    """Warnings only (everything with ``verbose``); the HTTP clients' per-request lines also under a
    logging set up before (Hydra's job logging: INFO on stdout)."""
    level = logging.DEBUG if verbose else logging.WARNING
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    for name in QUIET_LOGGERS:
        logging.getLogger(name).setLevel(level)


def dvc_cache_dir(root: Path) -> Path:
    """The DVC cache folder: ``cache.dir`` of .dvc/config.local or .dvc/config (relative to .dvc/; an
    experiment's temporary copy points at the main repository's cache there), else .dvc/cache."""
    found = root / ".dvc" / "cache"
    for name in ("config", "config.local"):  # the local file wins
        cp = configparser.ConfigParser(strict=False, interpolation=None)
        try:
            cp.read(root / ".dvc" / name, encoding="utf-8")
        except (configparser.Error, UnicodeDecodeError):
            continue
        if cp.has_option("cache", "dir"):
            found = root / ".dvc" / cp.get("cache", "dir").strip("'\"")
    return found


def cached_outputs(root: Path, stage: str) -> bool:
    """True when dvc.lock names outputs of ``stage`` and the DVC cache holds each (what `dvc checkout
    <stage>` needs; DVC 3 keeps them under files/md5/, DVC 2 at the top of the cache)."""
    try:
        lock = yaml.safe_load((root / "dvc.lock").read_text(encoding="utf-8")) or {}
        outs = lock["stages"][stage]["outs"]
    except (OSError, UnicodeDecodeError, yaml.YAMLError, KeyError, TypeError):
        return False
    cache = dvc_cache_dir(root)
    md5s = [str(o.get("md5") or "") if isinstance(o, dict) else "" for o in outs or []]
    return bool(md5s) and all(
        len(h) > 2 and any((base / h[:2] / h[2:]).is_file() for base in (cache / "files" / "md5", cache))
        for h in md5s)


def _dvc_hint(name: str) -> str:
    """Under DVC (which sets DVC_STAGE), how to restore what DVC deleted before the stage ran: only
    when the DVC cache holds the outputs dvc.lock names (a fresh clone has none to restore)."""
    stage = os.environ.get("DVC_STAGE")
    if not stage or not cached_outputs(ROOT, stage):
        return ""
    return (f"\nnote: DVC removed the previous outputs of stage '{stage}' before running it; "
            f"`dvc checkout {stage}` restores them from the DVC cache (dvc.lock still names them)")


def stage_main(name: str, body: Callable[[ExperimentConfig, dict, Path], None], llm: bool = False) -> None:
    """Run a DVC stage's ``body(cfg, raw params, data folder)``, its writes confined to the data folder
    (and the LLM's cache and model folders with ``llm``); a user-fixable error exits 2 with one line."""
    ap = argparse.ArgumentParser(prog=f"python -m pipeline.{name}", description=f"DVC stage '{name}'")
    ap.add_argument("--params", type=Path, default=None, help="params file (default: params.yaml)")
    ap.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    args = ap.parse_args()
    try:
        cfg, raw = load_params(args.params)
        setup_logging(args.verbose or cfg.verbose)
        data = Path(cfg.data_dir)
        if not data.is_absolute():
            data = ROOT / data
        with confine_writes(*write_folders(cfg, data, llm=llm)):
            body(cfg, raw, data)
    except UserError as e:
        print(f"error: stage '{name}': {e}{_dvc_hint(name)}", file=sys.stderr)
        sys.exit(2)
    except KeyboardInterrupt:
        print(f"error: {interrupted_message(f'stage {name!r}')}", file=sys.stderr)
        sys.exit(INTERRUPTED_EXIT)
    except Exception as e:
        if (unwritable := output_error(e)) is not None:  # a full disk, a read-only folder
            print(f"error: stage '{name}': {unwritable}{_dvc_hint(name)}", file=sys.stderr)
            sys.exit(2)
        traceback.print_exc()
        print(f"error: stage '{name}' failed on an unexpected error (the traceback above; please report "
              f"it){_dvc_hint(name)}", file=sys.stderr)
        sys.exit(1)
    log_loaded_modules(name)
