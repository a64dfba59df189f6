"""Copy what the sweeps' jobs measured into a committed folder the report is built from.

    python -m pipeline.collect_sweeps multirun/sweeps data/sweeps [EXPERIMENT ...]

For every job folder under SRC (``<experiment>/<job>/``, a Hydra multirun) that holds
``data/metrics/metrics.json``, its config (``.hydra/config.yaml`` and ``overrides.yaml``: what
``interllm report --sweeps`` reads to place the job on its axis) and the small metrics files the
sweep sections read (``METRICS``) go to ``DST/<experiment>/<what the job overrides>/`` in the same
layout, so ``interllm report --sweeps data/sweeps`` and ``interllm results diff --file
data/sweeps/<experiment>/<job>/data/metrics/metrics.json`` work on the committed copy; with them the
job's ``finished.json``, so that a re-make on another machine restores the job instead of making it
again (``interllm/stages/resume.py``). Only the EXPERIMENTs named are collected (all under SRC
when none is), so old local runs of another sweep never replace its committed copy. An experiment's
earlier copy is replaced whole (written beside, then renamed).
"""

from __future__ import annotations

import re
import shutil
import sys
from pathlib import Path

import yaml

from interllm.stages.provenance import EXECUTION_SETTINGS
from interllm.stages.resume import FINISHED

# what the sweep sections read: metrics.json (planners, comparisons, answers), per_mission.csv
# (paired differences), per_command.csv (learning curves), semantic_*.csv (Table II per σ)
METRICS = ("metrics.json", "per_mission.csv", "per_command.csv", "semantic_accuracy.csv", "semantic_inferences.csv")
HYDRA = ("config.yaml", "overrides.yaml")


UNSAFE = re.compile(r"[^A-Za-z0-9._,+=-]")  # anything else in an override value becomes '_'


# overrides that choose how a job runs, not what it computes: not part of its name
UNNAMED = ("experiment", "resume", *EXECUTION_SETTINGS)


def job_name(overrides: list[str]) -> str:
    """A job's folder name: its overrides other than the experiment, the hydra settings and those
    that choose how it runs (``UNNAMED``: ``make sweeps`` passes resume and scenes_cache),
    ``key_value`` joined by ','; one folder name whatever the values hold ('/' and other separators
    become '_')."""
    kept = [o.replace("=", "_", 1) for o in overrides
            if not o.startswith("hydra.") and o.split("=", 1)[0].lstrip("+~") not in UNNAMED]
    name = UNSAFE.sub("_", ",".join(kept)) or "default"
    return "_" + name if name.startswith(".") else name


def _job_folders(jobs: list[Path]) -> dict[str, Path]:
    """{folder name: job} of one experiment's jobs; SystemExit when two jobs get one name or a job
    lacks a file the sweep sections read."""
    named: dict[str, Path] = {}
    for job in jobs:
        name = job_name(yaml.safe_load((job / ".hydra" / "overrides.yaml").read_text()) or [])
        if name in named:
            raise SystemExit(f"collect_sweeps: jobs {named[name]} and {job} override the same keys ({name}); "
                             f"remove the older run folder")
        missing = [f for f in HYDRA if not (job / ".hydra" / f).is_file()] + \
                  [f for f in METRICS if not (job / "data" / "metrics" / f).is_file()]
        if missing:
            raise SystemExit(f"collect_sweeps: job {job} lacks {missing}; re-run it (make sweeps)")
        named[name] = job
    return named


def collect_experiment(jobs: list[Path], dst: Path) -> list[Path]:
    """Copy ``jobs`` (folders of one experiment's multirun) into ``dst``, replacing it whole."""
    named = _job_folders(jobs)
    tmp = dst.with_name(f".{dst.name}.tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    for name, job in named.items():
        (tmp / name / ".hydra").mkdir(parents=True)
        (tmp / name / "data" / "metrics").mkdir(parents=True)
        for f in HYDRA:
            shutil.copy2(job / ".hydra" / f, tmp / name / ".hydra" / f)
        for f in METRICS:
            shutil.copy2(job / "data" / "metrics" / f, tmp / name / "data" / "metrics" / f)
        if (job / FINISHED).is_file():  # what lets a re-make elsewhere restore this job (stages/resume.py)
            shutil.copy2(job / FINISHED, tmp / name / FINISHED)
    shutil.rmtree(dst, ignore_errors=True)
    tmp.rename(dst)
    return [dst / name for name in named]


def collect(src: Path, dst: Path, experiments: list[str] | None = None) -> list[Path]:
    """The job folders written under ``dst``, of ``experiments`` (None: every experiment under ``src``);
    none found: SystemExit naming ``src``."""
    by_experiment: dict[str, list[Path]] = {}
    for m in sorted(src.glob("*/*/data/metrics/metrics.json")):
        job = m.parent.parent.parent
        if experiments is None or job.parent.name in experiments:
            by_experiment.setdefault(job.parent.name, []).append(job)
    if not by_experiment:
        raise SystemExit(f"collect_sweeps: no job {'of ' + ', '.join(experiments) + ' ' if experiments else ''}under "
                         f"{src} holds data/metrics/metrics.json; run `make sweeps`")
    dst.mkdir(parents=True, exist_ok=True)
    return [p for exp, jobs in sorted(by_experiment.items()) for p in collect_experiment(jobs, dst / exp)]


if __name__ == "__main__":
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    for d in collect(Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3:] or None):
        print(d)
