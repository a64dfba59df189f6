"""Copy what a multirun's jobs measured into a committed folder: for every job folder under SRC that
holds ``data/metrics/metrics.json``, its metrics (metrics.json and the per-mission and per-command
tables the mechanism comparison pairs), its Markdown report with its figures, and its
``finished.json`` (what lets a re-make elsewhere restore it: ``interllm/stages/resume.py``) go to
DST/<job folder name>/. Earlier copies of the same jobs are replaced whole (written beside, then
renamed).

    python -m pipeline.collect_runs multirun/mechanism data/mechanism
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

from interllm.stages.resume import FINISHED

METRICS = ("metrics.json", "per_mission.csv", "per_command.csv")  # what the mechanism tables pair
REPORT_SKIPS = ("report.html",)  # the Markdown report and its figures suffice; the HTML inlines them again


def collect(src: Path, dst: Path) -> list[Path]:
    """The DST folders written, one per job of SRC with metrics (none: SystemExit naming SRC)."""
    jobs = sorted(p.parent.parent.parent for p in src.glob("*/data/metrics/metrics.json"))
    if not jobs:
        raise SystemExit(f"collect_runs: no job under {src} holds data/metrics/metrics.json; run the multirun first")
    out = []
    for job in jobs:
        tmp = dst / f".{job.name}.tmp"
        shutil.rmtree(tmp, ignore_errors=True)
        (tmp / "metrics").mkdir(parents=True)
        for name in METRICS:
            shutil.copy2(job / "data" / "metrics" / name, tmp / "metrics" / name)
        shutil.copytree(job / "data" / "report", tmp / "report", ignore=shutil.ignore_patterns(*REPORT_SKIPS))
        if (job / FINISHED).is_file():  # what lets a re-make elsewhere restore this job (stages/resume.py)
            shutil.copy2(job / FINISHED, tmp / FINISHED)
        final = dst / job.name
        shutil.rmtree(final, ignore_errors=True)
        tmp.rename(final)
        out.append(final)
    return out


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit(__doc__)
    for d in collect(Path(sys.argv[1]), Path(sys.argv[2])):
        print(d)
