"""Freezing a versioned benchmark (``interllm.scene.benchmark``): the scenes stage's houses, missions
and measurement, drawn anew with this config, copied under ``<benchmark_dir>/<name>/`` with a
manifest of their hashes. Run on purpose (``python -m pipeline.freeze_benchmark NAME``), never by the
pipeline; an existing version is never rewritten."""

from __future__ import annotations

import dataclasses
import os
import tempfile
from pathlib import Path

from interllm.config import ExperimentConfig
from interllm.io import atomic_write_bytes, ensure_dir, read_bytes, read_json, write_json
from interllm.scene.benchmark import (
    FROZEN_FILES,
    MANIFEST,
    BenchmarkError,
    Manifest,
    check_benchmark_name,
    drawn_with,
    sha256_of,
)
from interllm.stages.scenes import run_scenes


def freeze_benchmark(cfg: ExperimentConfig, name: str, commit: str) -> tuple[Path, dict]:
    """Draw the houses and missions of ``cfg`` (as with ``benchmark=''``) and freeze them as benchmark
    ``name`` under ``cfg.benchmark_dir``; ``commit``: the code's git commit, recorded in the manifest.
    Returns the benchmark's folder and its slot totals {houses, missions, slots_drawn,
    slots_fulfillable}. The folder appears whole or not at all (built beside it, then renamed)."""
    root = ensure_dir(cfg.benchmark_dir)
    dest = root / check_benchmark_name(name, "the benchmark name")
    if dest.exists():
        raise BenchmarkError(f"{dest} exists: a benchmark version is never rewritten (results made on it would "
                             f"silently change); freeze under a new name, e.g. {name}-next")
    drawn = dataclasses.replace(cfg, benchmark="")
    with tempfile.TemporaryDirectory(dir=root, prefix=f".{name}.partial-") as tmp:
        ids = run_scenes(drawn, Path(tmp) / "scenes")
        staging = Path(tmp) / name
        hashes: dict[str, dict[str, str]] = {}
        totals = {"houses": len(ids), "missions": 0, "slots_drawn": 0, "slots_fulfillable": 0}
        for sid in ids:
            for f in FROZEN_FILES:
                atomic_write_bytes(ensure_dir(staging / sid) / f, read_bytes(Path(tmp) / "scenes" / sid / f))
            hashes[sid] = {f: sha256_of(staging / sid / f) for f in FROZEN_FILES}
            record = read_json(staging / sid / "feasibility.json")
            totals["missions"] += len(record["missions"])
            totals["slots_drawn"] += int(record["totals"]["slots_drawn"])
            totals["slots_fulfillable"] += int(record["totals"]["slots_fulfillable"])
        manifest = Manifest(name, commit, cfg.sim.robot, drawn_with(cfg.seed, cfg.scene, cfg.mission),
                            cfg.mission.n_missions, hashes)
        write_json(staging / MANIFEST, manifest.to_dict())
        try:
            os.rename(staging, dest)
        except OSError as e:  # another freeze of the same name finished first
            raise BenchmarkError(f"{dest} could not be created ({e.strerror}): another freeze of {name!r} may have "
                                 f"finished first; a version is never rewritten, freeze under a new name") from None
    return dest, totals
