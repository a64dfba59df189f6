"""Replay run MCAPs in rerun (``replay``; ``replay_main`` is the ``interllm replay`` CLI).

Entities (timeline ``sim_time``: simulated mission time, a duration in seconds):

- ``world/scene/{walls,doors,furniture}``          Boxes3D (static, from the scene attachment)
- ``world/scene/objects``                          Boxes3D of the objects that lie in the world,
  re-logged at every grasp and release (a held object is drawn under the gripper's entity, at
  ``.../grip/held``, so it travels with the hand)
- ``world/robot``                                  Transform3D over time (world -> base_link, every
  trajectory sample); the arm's link frames from ``/tf`` nest under it
  (``world/robot/shoulder/upper_arm/...``), each a Transform3D over time, and the robot's shapes
  from the first ``/scene`` update hang off them as static ``visual/<name>`` Boxes3D / Cylinders3D
  (``world/robot/body``, a box, when the log has no robot shapes)
- ``world/paths/{presumed,driven}``                LineStrips3D per navigate action
- ``topdown/grid``                                 the presumed occupancy grid as an Image
  (``topdown/grid_true`` the true one) with ``topdown/{robot,presumed,driven}`` in pixel coordinates
- ``log``                                          TextLog of /log lines; ``events/<topic>`` TextLog of
  planner events (compact JSON)
- ``costs/{navigate,pickup,place}`` and ``costs/cumulative``  Scalars of action costs at the action end
- ``metrics/m_overall_cum``                        Scalars of the cumulative m_overall per object
  (``/metrics/object`` events) and ``metrics/objects_fulfilled``, the running count of fulfilled objects
- ``joints/<name>``                                Scalars of arm joint angles [rad]

The blueprint shows a 3D view, the top-down 2D view, the text log and the cost plots. A
truncated MCAP (killed run) replays up to where it stops and says where, both on stdout and
as a warning in the text log.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import uuid
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from interllm.core.frames import BASE_FRAME, GRIP_FRAME, WORLD_FRAME
from interllm.errors import MissingInputError, UserError
from interllm.record.foxglove import scene_boxes
from interllm.record.reader import RunLog, read_run

TIMELINE = "sim_time"
ROBOT_HALF_SIZE = (0.25, 0.25, 0.2)  # [m] drawn base footprint
_KIND_PATH = {"wall": "walls", "door": "doors", "furniture": "furniture"}  # objects: see _log_objects
_KIND_COLOR = {"wall": (190, 190, 185), "door": (140, 90, 45), "furniture": (115, 140, 190),
               "object": (240, 150, 40)}
_RR_LEVEL = {"debug": "DEBUG", "info": "INFO", "warning": "WARN", "error": "ERROR", "fatal": "CRITICAL"}
_EVENT_TEXT_MAX = 2000  # characters of an event's JSON shown in the text log


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


def _to_pixels(xy: np.ndarray, run: RunLog) -> np.ndarray:
    g = run.grids["presumed"]
    rows = g.shape[0]
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    u = (xy[:, 0] - g.origin[0]) / g.resolution
    v = rows - (xy[:, 1] - g.origin[1]) / g.resolution
    return np.stack([u, v], axis=1)


def log_run(rec, run: RunLog) -> None:
    """Log one RunLog to a rerun RecordingStream."""
    import rerun as rr  # lazy: rerun loads only for a replay

    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    rec.log("run", rr.TextDocument(json.dumps(run.run, indent=1, sort_keys=True, default=str),
                                   media_type="text/plain"), static=True)
    if run.scene is not None:
        boxes = scene_boxes(run.scene)
        for kind, sub in _KIND_PATH.items():
            bs = [b for b in boxes if b["kind"] == kind]
            if not bs:
                continue
            half = np.asarray([b["size"] for b in bs], dtype=float) / 2
            quats = [rr.Quaternion(xyzw=[0.0, 0.0, np.sin(b["yaw"] / 2), np.cos(b["yaw"] / 2)]) for b in bs]
            rec.log(f"world/scene/{sub}", rr.Boxes3D(
                centers=np.asarray([b["center"] for b in bs], dtype=float), half_sizes=half,
                quaternions=quats, colors=[_KIND_COLOR[kind]] * len(bs),
                labels=[b["id"] for b in bs], fill_mode=rr.components.FillMode.Solid,
                show_labels=kind == "furniture"), static=True)
    paths = _frame_paths(run)
    if run.robot_visuals:
        _log_robot_visuals(rec, run, paths)
    else:
        rec.log("world/robot/body", rr.Boxes3D(half_sizes=[ROBOT_HALF_SIZE], centers=[(0, 0, ROBOT_HALF_SIZE[2])],
                                               colors=[(60, 200, 90)], labels=["robot"]), static=True)
    for frame, fs in sorted(run.frames.items()):
        if frame == BASE_FRAME or frame not in paths or not len(fs.t):
            continue
        rec.send_columns(paths[frame], indexes=[rr.TimeColumn(TIMELINE, duration=fs.t)],
                         columns=rr.Transform3D.columns(translation=fs.xyz, quaternion=fs.quat))
    if run.scene is not None:
        _log_objects(rec, run, paths)

    has_grid = "presumed" in run.grids
    for name, grid in sorted(run.grids.items()):
        img = np.where(np.flipud(grid.occupied), 40, 235).astype(np.uint8)
        rec.log("topdown/grid" if name == "presumed" else f"topdown/grid_{name}", rr.Image(img), static=True)

    # Robot base over simulated time (columnar: one call for all samples).
    if len(run.base):
        t, x, y, yaw = run.base.T
        quat = np.stack([np.zeros_like(yaw), np.zeros_like(yaw), np.sin(yaw / 2), np.cos(yaw / 2)], axis=1)
        times = [rr.TimeColumn(TIMELINE, duration=t)]
        rec.send_columns("world/robot", indexes=times, columns=rr.Transform3D.columns(
            translation=np.stack([x, y, np.zeros_like(x)], axis=1), quaternion=quat))
        if has_grid:
            px = _to_pixels(run.base[:, 1:3], run)
            rec.send_columns("topdown/robot", indexes=times, columns=rr.Points2D.columns(positions=px))
    if len(run.joint_t) and run.joints.shape[1]:
        times = [rr.TimeColumn(TIMELINE, duration=run.joint_t)]
        for j, name in enumerate(run.joint_names):
            rec.send_columns(f"joints/{name}", indexes=times, columns=rr.Scalars.columns(scalars=run.joints[:, j]))

    for topic, paths, color in (("presumed", run.presumed_paths, (80, 140, 255)),
                                ("driven", run.driven_paths, (255, 80, 80))):
        for t, path in paths:
            rec.set_time(TIMELINE, duration=t)
            pts = np.c_[path, np.full(len(path), 0.03)]
            rec.log(f"world/paths/{topic}", rr.LineStrips3D([pts], colors=[color], radii=[0.03]))
            if has_grid:
                rec.log(f"topdown/{topic}", rr.LineStrips2D([_to_pixels(path, run)], colors=[color]))

    total = 0.0
    for a, ctx in zip(run.actions, run.contexts, strict=True):
        t1 = a.t_start + a.time
        total += a.cost
        rec.set_time(TIMELINE, duration=t1)
        rec.log(f"costs/{a.action.kind}", rr.Scalars(a.cost))
        rec.log("costs/cumulative", rr.Scalars(total))
        status = "ok" if a.success else f"FAILED: {a.reason}"
        rec.log("events/actions", rr.TextLog(f"{a.action} cost={a.cost:.2f} t={a.time:.2f}s {status} {ctx}",
                                             level="INFO" if a.success else "WARN"))
    fulfilled = 0.0
    for t, payload in run.events.get("/metrics/object", []):
        if "m_overall_cum" in payload:
            fulfilled += float(payload.get("sr_obj", 0.0))
            rec.set_time(TIMELINE, duration=t)
            rec.log("metrics/m_overall_cum", rr.Scalars(float(payload["m_overall_cum"])))
            rec.log("metrics/objects_fulfilled", rr.Scalars(fulfilled))
    for t, level, msg in run.logs:
        rec.set_time(TIMELINE, duration=t)
        rec.log("log", rr.TextLog(msg, level=_RR_LEVEL.get(level, "INFO")))
    for topic, evs in sorted(run.events.items()):
        for t, payload in evs:
            rec.set_time(TIMELINE, duration=t)
            text = json.dumps(payload, sort_keys=True, default=str)
            if len(text) > _EVENT_TEXT_MAX:
                text = text[:_EVENT_TEXT_MAX] + " ..."
            rec.log(f"events/{topic.strip('/')}", rr.TextLog(f"{topic} {text}", level="DEBUG"))
    if not run.complete:
        rec.set_time(TIMELINE, duration=run.sim_time)
        rec.log("log", rr.TextLog(f"TRUNCATED RUN LOG: {run.stopped_at}", level="WARN"))


def _frame_paths(run: RunLog) -> dict[str, str]:
    """Entity path of every /tf frame: world -> world, base_link -> world/robot, a child frame
    under its parent's path (world/robot/shoulder/upper_arm/...)."""
    parents = {k: fs.parent for k, fs in run.frames.items()}
    paths = {WORLD_FRAME: "world", BASE_FRAME: "world/robot"}

    def path(frame: str, depth: int = 0) -> str | None:
        if frame in paths:
            return paths[frame]
        parent = parents.get(frame)
        if parent is None or depth > 64:
            return None
        p = path(parent, depth + 1)
        if p is None:
            return None
        paths[frame] = f"{p}/{frame}"
        return paths[frame]

    for f in sorted(parents):
        path(f)
    return paths


def _rgb(c) -> tuple[int, ...]:
    return tuple(int(round(255 * max(0.0, min(1.0, v)))) for v in c)


def _log_robot_visuals(rec, run: RunLog, paths: dict[str, str]) -> None:
    import rerun as rr  # lazy: rerun loads only for a replay

    solid = rr.components.FillMode.Solid
    for v in run.robot_visuals:
        base = paths.get(v.frame)
        if base is None:
            continue
        ent = f"{base}/visual/{v.name.replace('/', '_')}"
        q = rr.Quaternion(xyzw=list(v.quaternion))
        if v.shape == "cylinder":
            arch = rr.Cylinders3D(lengths=[v.size[2]], radii=[v.size[0] / 2], centers=[v.position],
                                  quaternions=[q], colors=[_rgb(v.color)], fill_mode=solid)
        elif v.shape == "sphere":
            arch = rr.Ellipsoids3D(half_sizes=[np.asarray(v.size) / 2], centers=[v.position],
                                   colors=[_rgb(v.color)], fill_mode=solid)
        else:
            arch = rr.Boxes3D(half_sizes=[np.asarray(v.size) / 2], centers=[v.position], quaternions=[q],
                              colors=[_rgb(v.color)], fill_mode=solid)
        rec.log(ent, arch, static=True)


def _log_objects(rec, run: RunLog, paths: dict[str, str]) -> None:
    """Objects in the world at t=0 and after every grasp / release; the held one under the grip."""
    import rerun as rr  # lazy: rerun loads only for a replay

    objs = {o.id: {"center": tuple(o.position), "quat": (0.0, 0.0, 0.0, 1.0), "size": tuple(o.size)}
            for o in run.scene.objects.values()}  # type: ignore[union-attr]
    grip = paths.get(GRIP_FRAME)  # None: no arm frames in the log, a held object is not drawn
    held_path = f"{grip}/held" if grip else None
    color = _KIND_COLOR["object"]
    solid = rr.components.FillMode.Solid

    def log_world(t: float) -> None:
        ids = sorted(objs)
        rec.set_time(TIMELINE, duration=t)
        rec.log("world/scene/objects", rr.Boxes3D(
            centers=[objs[i]["center"] for i in ids], half_sizes=[np.asarray(objs[i]["size"]) / 2 for i in ids],
            quaternions=[rr.Quaternion(xyzw=list(objs[i]["quat"])) for i in ids], colors=[color] * len(ids),
            labels=ids, fill_mode=solid, show_labels=True))

    log_world(0.0)
    for mv in run.object_moves:
        if mv.frame == WORLD_FRAME:
            objs[mv.object] = {"center": mv.position, "quat": mv.quaternion, "size": mv.size}
            log_world(mv.t)
            if held_path:
                rec.log(held_path, rr.Clear(recursive=False))
        else:
            objs.pop(mv.object, None)
            log_world(mv.t)
            if held_path:
                rec.log(held_path, rr.Boxes3D(
                    centers=[mv.position], half_sizes=[np.asarray(mv.size) / 2],
                    quaternions=[rr.Quaternion(xyzw=list(mv.quaternion))], colors=[color], labels=[mv.object],
                    fill_mode=solid))


def replay(path_or_dir: str | os.PathLike, save: str | None = None, spawn: bool = False,
           serve: bool = False) -> list[Path]:
    """Replay one run MCAP, or every run under a folder, in rerun.

    save: output ``.rrd`` (one run) or folder (several runs). Default when neither ``spawn`` nor
        ``serve`` is set (or there is no display to spawn a viewer on): ``<run>.rrd`` next to
        each MCAP. spawn: open a native viewer; serve: start a gRPC server (returns immediately).
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
        log_run(rec, run)
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


def replay_main(argv: Sequence[str] | None = None) -> int:
    """``interllm replay RUN.mcap|DIR [--save OUT.rrd] [--spawn | --serve]``."""
    ap = argparse.ArgumentParser(prog="interllm replay", description="Replay run MCAP logs in rerun.")
    ap.add_argument("path", help="a run .mcap (or a killed run's .mcap.partial) or a folder of runs")
    ap.add_argument("--save", default=None, help="output .rrd (one run) or folder (several runs); "
                    "default without --spawn/--serve: <run>.rrd next to each MCAP")
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--spawn", action="store_true", help="open a native rerun viewer")
    g.add_argument("--serve", action="store_true", help="serve over gRPC until Ctrl-C")
    args = ap.parse_args(list(argv) if argv is not None else None)
    try:
        replay(args.path, save=args.save, spawn=args.spawn, serve=args.serve)
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
