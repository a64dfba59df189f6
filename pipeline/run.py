"""Hydra entry point: the whole pipeline (all five stages) for one config, or a sweep.

    python -m pipeline.run experiment=quick
    python -m pipeline.run -m experiment=m_ablation planner.M=1,3,5
    python -m pipeline.run -m hydra/launcher=joblib hydra.launcher.n_jobs=2 llm.temperature=0.2,0.8

Each run writes into its own Hydra output folder (outputs/... or multirun/.../<job>/data), with
the resolved config and provenance; the LLM response cache is shared (llm.cache_dir), so a sweep
never asks the model the same question twice. For DVC-tracked runs use `dvc repro` /
`dvc exp run` instead; both paths call the same library functions.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from interllm.config import check_api_key_env
from interllm.errors import INTERRUPTED_EXIT, UserError, interrupted_message, output_error
from interllm.io import confine_writes, exclusive_folder, read_json
from interllm.stages.pipeline import run_all
from interllm.stages.resume import (
    COMMITTED_RUNS,
    FINISHED,
    METRICS,
    finished_run,
    forget_finished,
    job_key,
    mark_finished,
    restore_committed,
)
from interllm.stages.shared_scenes import SharedScenes, scenes_key
from interllm.stages.workers import usable_cores
from pipeline._common import ROOT, setup_logging, write_folders
from pipeline._hydra import CONF_DIR, to_config


def run(cfg: DictConfig) -> dict:
    typed = to_config(cfg)  # validates types, ranges and unknown keys (ConfigError names the key)
    setup_logging(typed.verbose)
    cache = Path(typed.llm.cache_dir)
    if not cache.is_absolute():
        typed.llm.cache_dir = str(ROOT / cache)
    if not Path(typed.benchmark_dir).is_absolute():  # the committed benchmarks, wherever the run is started
        typed.benchmark_dir = str(ROOT / typed.benchmark_dir)
    hc = HydraConfig.get()
    launcher = str(OmegaConf.select(hc, "launcher._target_", default="") or "")
    if "joblib" in launcher.lower():  # the launcher already runs jobs in parallel
        n_jobs = int(OmegaConf.select(hc, "launcher.n_jobs", default=1) or 1)
        if n_jobs < 0:  # joblib's convention: -1 all cores, -2 all but one, ...
            n_jobs = max(1, usable_cores() + 1 + n_jobs)
        if typed.jobs == 0:
            typed.jobs = 1  # no second layer of worker processes
        # and each job's model gets its share of the threads (llama.cpp's results do not depend on it)
        typed.llm.n_threads = max(1, typed.llm.n_threads // max(1, n_jobs))
    out = Path(hc.runtime.output_dir) / "data"
    resolved = OmegaConf.to_container(cfg, resolve=True)
    resolved["jobs"], resolved["llm"]["n_threads"] = typed.jobs, typed.llm.n_threads
    run_dir = Path(hc.runtime.output_dir)
    bench = Path(typed.benchmark_dir) / typed.benchmark if typed.benchmark else None
    key = job_key(resolved, ROOT, bench)
    shared = None
    if typed.scenes_cache:  # the scenes of this setting, made once for every job of a re-make
        store = Path(typed.scenes_cache) if Path(typed.scenes_cache).is_absolute() else ROOT / typed.scenes_cache
        shared = SharedScenes(store, scenes_key(resolved, ROOT, bench))
    folders = write_folders(typed, run_dir) + ((shared.entry.parent,) if shared else ())
    with confine_writes(*folders), exclusive_folder(run_dir):
        if typed.resume and finished_run(run_dir, key):
            print(f"{run_dir}: already made with this config, code and benchmark; skipped "
                  f"(resume=false, or delete its {FINISHED}, to make it again)", file=sys.stderr)
            return read_json(run_dir / METRICS)
        if typed.resume and (restored := restore_committed(run_dir, key, [ROOT / r for r in COMMITTED_RUNS])):
            print(f"{run_dir}: restored from its committed copy {restored.relative_to(ROOT)}, made with this "
                  f"config, code and benchmark (resume=false to make it again)", file=sys.stderr)
            return read_json(run_dir / METRICS)
        forget_finished(run_dir)  # a run that fails from here on leaves no record of an earlier one
        metrics = run_all(typed, out, resolved_config=resolved, shared_scenes=shared)
        mark_finished(run_dir, key)
        return metrics


@hydra.main(config_path=CONF_DIR, config_name="config", version_base="1.3")
def main(cfg: DictConfig) -> None:
    try:
        run(cfg)
    except UserError as e:  # a fixable problem: its message, not a traceback
        print(f"error: {e}", file=sys.stderr)
        sys.exit(2)
    except KeyboardInterrupt:
        print(f"error: {interrupted_message('the run')}", file=sys.stderr)
        sys.exit(INTERRUPTED_EXIT)
    except Exception as e:
        if (unwritable := output_error(e)) is None:  # a bug: its traceback
            raise
        print(f"error: {unwritable}", file=sys.stderr)  # a full disk, a read-only folder
        sys.exit(2)


# a command-line llm.api_key_env (also +, ++ and ~ forms; a sweep's values are comma-separated)
_KEY_ENV_OVERRIDE = re.compile(r"[+~]{0,2}llm\.api_key_env=(.*)", re.S)


def check_command_line(argv: list[str]) -> None:
    """Raise ConfigError when a command-line override sets llm.api_key_env to something that is not an
    environment variable name (often the key itself). Runs before ``hydra.main``, which writes the
    overrides to .hydra/overrides.yaml before the config is validated."""
    for arg in argv:
        m = _KEY_ENV_OVERRIDE.fullmatch(arg)
        for value in (m.group(1).split(",") if m else ()):
            check_api_key_env(value.strip().strip("'\""))


if __name__ == "__main__":
    try:
        check_command_line(sys.argv[1:])
    except UserError as e:  # before Hydra writes anything
        print(f"error: {e}", file=sys.stderr)
        sys.exit(2)
    main()
