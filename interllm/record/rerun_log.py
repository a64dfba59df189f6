"""Log a run log (``record.reader.RunLog``) to a rerun recording stream (``log_run``).

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
  and ``metrics/objects_fulfilled``, the running count of fulfilled objects, from the per-object rows
  given to ``log_run`` (the metrics are computed above this package:
  ``interllm.metrics.compute.run_log_object_rows``)
- ``joints/<name>``                                Scalars of arm joint angles [rad]

A truncated run ends with a warning in the text log saying where it stops.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence

import numpy as np

from interllm.core.frames import BASE_FRAME, GRIP_FRAME, WORLD_FRAME
from interllm.record.foxglove import scene_boxes
from interllm.record.reader import RunLog

TIMELINE = "sim_time"
ROBOT_HALF_SIZE = (0.25, 0.25, 0.2)  # [m] drawn base footprint
_KIND_PATH = {"wall": "walls", "door": "doors", "furniture": "furniture"}  # objects: see _log_objects
_KIND_COLOR = {"wall": (190, 190, 185), "door": (140, 90, 45), "furniture": (115, 140, 190),
               "object": (240, 150, 40)}
_RR_LEVEL = {"debug": "DEBUG", "info": "INFO", "warning": "WARN", "error": "ERROR", "fatal": "CRITICAL"}
_EVENT_TEXT_MAX = 2000  # characters of an event's JSON shown in the text log


def _to_pixels(xy: np.ndarray, run: RunLog) -> np.ndarray:
    g = run.grids["presumed"]
    rows = g.shape[0]
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    u = (xy[:, 0] - g.origin[0]) / g.resolution
    v = rows - (xy[:, 1] - g.origin[1]) / g.resolution
    return np.stack([u, v], axis=1)


def log_run(rec, run: RunLog, metric_rows: Sequence[tuple[float, Mapping]] = ()) -> None:
    """Log one RunLog to a rerun RecordingStream (the entities of the module doc); ``metric_rows``:
    (t [s], per-object row with "m_overall_cum" and "sr_obj") to plot under ``metrics/``."""
    _log_header(rec, run)
    if run.scene is not None:
        _log_scene(rec, run)
    paths = _frame_paths(run)
    _log_robot(rec, run, paths)
    if run.scene is not None:
        _log_objects(rec, run, paths)
    _log_grids(rec, run)
    _log_motion(rec, run)
    _log_paths(rec, run)
    _log_costs(rec, run)
    _log_metrics(rec, metric_rows)
    _log_text(rec, run)


def _log_header(rec, run: RunLog) -> None:
    """The world's axes (z up) and the run's metadata as a text document."""
    import rerun as rr  # lazy: rerun loads only for a replay

    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    rec.log("run", rr.TextDocument(json.dumps(run.run, indent=1, sort_keys=True, default=str),
                                   media_type="text/plain"), static=True)


def _log_scene(rec, run: RunLog) -> None:
    """Walls, door leaves and furniture as static Boxes3D, one entity per kind."""
    import rerun as rr  # lazy: rerun loads only for a replay

    boxes = scene_boxes(run.scene)  # type: ignore[arg-type]
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


def _log_robot(rec, run: RunLog, paths: dict[str, str]) -> None:
    """The robot's shapes (or a box for its body) and its link frames over time (``paths``: the
    entity path of each /tf frame)."""
    import rerun as rr  # lazy: rerun loads only for a replay

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


def _log_grids(rec, run: RunLog) -> None:
    """Every occupancy grid as a static top-down image (occupied dark)."""
    import rerun as rr  # lazy: rerun loads only for a replay

    for name, grid in sorted(run.grids.items()):
        img = np.where(np.flipud(grid.occupied), 40, 235).astype(np.uint8)
        rec.log("topdown/grid" if name == "presumed" else f"topdown/grid_{name}", rr.Image(img), static=True)


def _log_motion(rec, run: RunLog) -> None:
    """The robot base over simulated time (and on the top-down view) and the arm joint angles,
    columnar: one call for all samples."""
    import rerun as rr  # lazy: rerun loads only for a replay

    if len(run.base):
        t, x, y, yaw = run.base.T
        quat = np.stack([np.zeros_like(yaw), np.zeros_like(yaw), np.sin(yaw / 2), np.cos(yaw / 2)], axis=1)
        times = [rr.TimeColumn(TIMELINE, duration=t)]
        rec.send_columns("world/robot", indexes=times, columns=rr.Transform3D.columns(
            translation=np.stack([x, y, np.zeros_like(x)], axis=1), quaternion=quat))
        if "presumed" in run.grids:
            px = _to_pixels(run.base[:, 1:3], run)
            rec.send_columns("topdown/robot", indexes=times, columns=rr.Points2D.columns(positions=px))
    if len(run.joint_t) and run.joints.shape[1]:
        times = [rr.TimeColumn(TIMELINE, duration=run.joint_t)]
        for j, name in enumerate(run.joint_names):
            rec.send_columns(f"joints/{name}", indexes=times, columns=rr.Scalars.columns(scalars=run.joints[:, j]))


def _log_paths(rec, run: RunLog) -> None:
    """The presumed and driven path of every navigate action, in 3D and on the top-down view."""
    import rerun as rr  # lazy: rerun loads only for a replay

    has_grid = "presumed" in run.grids
    for topic, paths, color in (("presumed", run.presumed_paths, (80, 140, 255)),
                                ("driven", run.driven_paths, (255, 80, 80))):
        for t, path in paths:
            rec.set_time(TIMELINE, duration=t)
            pts = np.c_[path, np.full(len(path), 0.03)]
            rec.log(f"world/paths/{topic}", rr.LineStrips3D([pts], colors=[color], radii=[0.03]))
            if has_grid:
                rec.log(f"topdown/{topic}", rr.LineStrips2D([_to_pixels(path, run)], colors=[color]))


def _log_costs(rec, run: RunLog) -> None:
    """Each action's cost and the cumulative cost at its end, and a text line per action."""
    import rerun as rr  # lazy: rerun loads only for a replay

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


def _log_metrics(rec, metric_rows: Sequence[tuple[float, Mapping]]) -> None:
    """The cumulative m_overall and the running count of fulfilled objects, one point per object."""
    import rerun as rr  # lazy: rerun loads only for a replay

    fulfilled = 0.0
    for t, row in metric_rows:
        fulfilled += float(row.get("sr_obj", 0.0))
        rec.set_time(TIMELINE, duration=t)
        rec.log("metrics/m_overall_cum", rr.Scalars(float(row["m_overall_cum"])))
        rec.log("metrics/objects_fulfilled", rr.Scalars(fulfilled))


def _log_text(rec, run: RunLog) -> None:
    """The /log lines, every planner event as compact JSON, and a warning where a truncated run stops."""
    import rerun as rr  # lazy: rerun loads only for a replay

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
