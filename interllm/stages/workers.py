"""Worker processes of the scenes and missions stages: how many, a Ctrl-C left to the parent, one
call log each merged in job order, and failures named by their job."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path

from interllm.errors import INTERRUPTED_EXIT
from interllm.io import atomic_write_text

Job = tuple[str, str, str]  # (planner, scene id, mission id)


def usable_cores() -> int:
    """The cores this process may run on (CPU affinity: taskset, SLURM, containers), not the machine's."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def exit_quietly(signum: int, frame) -> None:
    """A worker's SIGINT handler: stop at once with the shell's status for Ctrl-C, no traceback (the
    parent says what it stopped; a worker's traceback would only repeat it). Files a worker was
    writing stay partial or absent (every output is written atomically); the finished ones are kept."""
    os._exit(INTERRUPTED_EXIT)


def leave_ctrl_c_to_parent() -> None:
    """A worker initializer's SIGINT set-up: ``exit_quietly`` on Ctrl-C, unless the worker's parent
    ignores SIGINT (a stage started with ``nohup ... &``): then the worker ignores it as well, so a
    Ctrl-C to the process group does not stop the workers of a stage that goes on."""
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        signal.signal(signal.SIGINT, exit_quietly)


def failed_message(job: Job, e: BaseException, out_dir: Path) -> str:
    log = Path(out_dir) / job[0] / job[1] / f"{job[2]}.mcap"
    return (f"missions stage: planner {job[0]!r} on scene {job[1]!r} mission {job[2]!r} failed: "
            f"{type(e).__name__}: {e} (its run log, if any: {log} or {log}.partial)")


def merge_call_logs(parts: list[Path], out: Path, jobs: list[Job]) -> None:
    """Join the workers' call logs into one, in job order (then each worker's own order)."""
    order = {(p, s, m): k for k, (p, s, m) in enumerate(jobs)}
    rows = []
    for part in parts:
        if not part.is_file():
            continue
        for n, line in enumerate(part.read_text(encoding="utf-8").splitlines()):
            if line.strip():
                r = json.loads(line)
                key = order.get((r.get("planner"), r.get("scene"), r.get("mission")), len(jobs))
                rows.append((key, n, line))
    atomic_write_text(out, "".join(line + "\n" for _, _, line in sorted(rows)))
    for part in parts:
        part.unlink(missing_ok=True)
