"""Replay run MCAPs in rerun (``replay``; ``replay_main`` is the ``interllm replay`` CLI).

Each run becomes one rerun recording (its entities: ``record/rerun_log.py``), saved to an
``.rrd``, shown in a spawned viewer or served over gRPC. The blueprint shows a 3D view, the
top-down 2D view, the text log and the cost plots. A truncated MCAP (killed run) replays up to
where it stops and says where, both on stdout and as a warning in the text log.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import uuid
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from interllm.errors import MissingInputError, UserError
from interllm.record.reader import RunLog, read_run
from interllm.record.rerun_log import log_run


def find_runs(path_or_dir: str | os.PathLike) -> list[Path]:
    """The run logs to replay: the file itself, or every .mcap / .mcap.partial under a folder."""
    p = Path(path_or_dir)
    if p.is_dir():
        runs = sorted(q for q in p.rglob("*") if q.is_file() and
                      (q.name.endswith(".mcap") or q.name.endswith(".mcap.partial")))
        if not runs:
            raise MissingInputError(f"no .mcap files under {p}; pass a run .mcap or a folder of runs")
        return runs
    if not p.exists():
        raise MissingInputError(f"{p} does not exist; pass a run .mcap or a folder of runs")
    if not p.is_file():  # reading a FIFO or a device would block or never end
        raise UserError(f"{p} is not a regular file (a FIFO, device or socket); pass a run .mcap or a folder of runs")
    return [p]


def _has_display() -> bool:
    if sys.platform.startswith("linux"):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def blueprint():
    """3D view, top-down 2D view, text log and time-series cost plots."""
    import rerun.blueprint as rrb  # lazy: rerun loads only for a replay

    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                rrb.Spatial3DView(origin="world", name="3D"),
                rrb.TimeSeriesView(origin="costs", name="Action costs"),
                rrb.TimeSeriesView(origin="metrics", name="m_overall (cumulative, per object)"),
                row_shares=[4, 2, 2],
            ),
            rrb.Vertical(
                rrb.Spatial2DView(origin="topdown", name="Top-down (presumed grid)"),
                rrb.TextLogView(origin="/", name="Log and planner events"),
                row_shares=[3, 2],
            ),
            column_shares=[3, 2],
        ),
        collapse_panels=False,
    )


def _recording_id(path: Path) -> uuid.UUID:
    """Stable per run file (name + size), never random: reruns of a replay give the same id."""
    return uuid.uuid5(uuid.NAMESPACE_URL, f"interllm-run:{path.name}:{path.stat().st_size}")


MetricRows = Callable[[RunLog], Sequence[tuple[float, Mapping]]]


def replay(path_or_dir: str | os.PathLike, save: str | None = None, spawn: bool = False,
           serve: bool = False, metric_rows: MetricRows | None = None) -> list[Path]:
    """Replay one run MCAP, or every run under a folder, in rerun.

    save: output ``.rrd`` (one run) or folder (several runs). Default when neither ``spawn`` nor
        ``serve`` is set (or there is no display to spawn a viewer on): ``<run>.rrd`` next to
        each MCAP. spawn: open a native viewer; serve: start a gRPC server (returns immediately).
    metric_rows(run): the per-object metric rows to plot under ``metrics/``
    (``interllm.metrics.compute.run_log_object_rows``; None: no metrics plot).
    Returns the ``.rrd`` files written.
    """
    import rerun as rr  # lazy: rerun loads only for a replay

    if spawn and serve:
        raise ValueError("choose at most one of spawn and serve")
    runs = find_runs(path_or_dir)
    if spawn and not _has_display():
        print("replay: no display (DISPLAY/WAYLAND_DISPLAY unset): saving .rrd files instead of spawning")
        spawn = False
    if save is not None and len(runs) > 1 and str(save).endswith(".rrd"):
        raise ValueError(f"{len(runs)} runs under {path_or_dir}: --save must be a folder, not {save}")
    to_file = save is not None or not (spawn or serve)
    bp = blueprint()
    written: list[Path] = []
    failed: list[tuple[Path, str]] = []
    for i, mcap_path in enumerate(runs):
        try:
            run = read_run(mcap_path)
            rows = metric_rows(run) if metric_rows is not None else ()
        except Exception as e:  # noqa: BLE001 - one bad file must not stop the others
            failed.append((mcap_path, f"{type(e).__name__}: {e}"))
            print(f"replay: {mcap_path}: cannot be read ({type(e).__name__}: {e}); skipped", file=sys.stderr)
            continue
        stem = mcap_path.name.removesuffix(".partial").removesuffix(".mcap")
        rec = rr.RecordingStream("interllm", recording_id=_recording_id(mcap_path), send_properties=False)
        rec.set_log_time_enabled(False)
        rec.set_log_tick_enabled(False)
        out: Path | None = None
        if to_file:
            if save is None:
                out = mcap_path.with_name(stem + ".rrd")
            elif len(runs) == 1 and str(save).endswith(".rrd"):
                out = Path(save)
            else:
                out = Path(save) / mcap_path.relative_to(Path(path_or_dir)).with_name(stem + ".rrd") \
                    if Path(path_or_dir).is_dir() else Path(save) / (stem + ".rrd")
            out.parent.mkdir(parents=True, exist_ok=True)
            rec.save(out, default_blueprint=bp)
        elif spawn:
            rec.spawn(default_blueprint=bp)
        else:
            url = rec.serve_grpc(grpc_port=9876 + i, default_blueprint=bp)
            print(f"replay: serving {mcap_path} at {url}")
        rec.send_recording_name(stem)
        log_run(rec, run, rows)
        rec.flush()
        if out is not None:
            rec.disconnect()
            written.append(out)
            print(f"replay: {mcap_path} -> {out}")
        if not run.complete:
            print(f"replay: {mcap_path} is truncated: {run.stopped_at}")
        if serve:
            _SERVED.append(rec)  # keep the server alive until the process ends
    if failed:
        raise ReplayIncomplete(written, failed)
    return written


class ReplayIncomplete(UserError):
    """Some run logs could not be read; the others were converted (``written``)."""

    def __init__(self, written: list[Path], failed: list[tuple[Path, str]]) -> None:
        lines = "\n".join(f"  {p}: {why}" for p, why in failed)
        super().__init__(f"{len(failed)} of {len(failed) + len(written)} run logs could not be replayed "
                         f"(the other {len(written)} were converted):\n{lines}")
        self.written, self.failed = written, failed


_SERVED: list = []


def replay_main(argv: Sequence[str] | None = None, metric_rows: MetricRows | None = None) -> int:
    """``interllm replay RUN.mcap|DIR [--save OUT.rrd] [--spawn | --serve]``; ``metric_rows`` as for
    ``replay`` (the CLI passes the metrics package's)."""
    ap = argparse.ArgumentParser(prog="interllm replay", description="Replay run MCAP logs in rerun.")
    ap.add_argument("path", help="a run .mcap (or a killed run's .mcap.partial) or a folder of runs")
    ap.add_argument("--save", default=None, help="output .rrd (one run) or folder (several runs); "
                    "default without --spawn/--serve: <run>.rrd next to each MCAP")
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--spawn", action="store_true", help="open a native rerun viewer")
    g.add_argument("--serve", action="store_true", help="serve over gRPC until Ctrl-C")
    args = ap.parse_args(list(argv) if argv is not None else None)
    try:
        replay(args.path, save=args.save, spawn=args.spawn, serve=args.serve, metric_rows=metric_rows)
    except ReplayIncomplete as e:  # 1: some run logs were converted; 2: none could be read
        print(f"interllm replay: error: {e}", file=sys.stderr)
        return 1 if e.written else 2
    except (UserError, FileNotFoundError, ValueError) as e:
        print(f"interllm replay: error: {e}", file=sys.stderr)
        return 2
    if args.serve:
        print("replay: serving; press Ctrl-C to stop")
        try:
            while True:
                time.sleep(3600)
        except KeyboardInterrupt:
            pass
    return 0


if __name__ == "__main__":
    raise SystemExit(replay_main(sys.argv[1:]))
