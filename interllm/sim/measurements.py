"""Manipulation measurements on a scene's initial map, kept to be used again: by later missions of
the same stage and, through ``measurements.json`` in the scene's folder, by the stages after the
scenes stage.

``World.measure_manipulation`` is the N_l-trial measurement of a pickup or place (ground truth of
a cost inference, the ``optimal`` reference's costs, the scenes stage's feasibility). It depends
on the action, on the layout around the furniture (``Manipulator.layout_key``: the furniture
within reach and the objects on them, with positions and sizes), on the robot's map (base poses
are sampled on it), on the simulator's config and on nothing else: its pose sampling is seeded by
the action (``base_poses.pose_sampling_seed``). So a measurement made on the initial map (belief
version 0) can serve any later request of the same (action, layout) on the initial map, in any
mission or stage. Of the 3,669 measurements the default experiment's missions stage makes without
a store, 1,369 are ones the scenes stage made and 757 repeat an earlier mission's
(``benchmarks/bench_measurements.py``).

A store serves only a world of the same scene, simulator config, grid resolution and simulator
code (``made_with``: the sources of ``interllm/sim`` and the MuJoCo and mink releases); a file made
with anything else is skipped with a warning naming what differs, never used.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import logging
from importlib import metadata
from pathlib import Path
from typing import Any, Optional

from interllm.config_sim import SimConfig
from interllm.core.results import ActionResult
from interllm.io import InputFileError, read_json, write_json
from interllm.scene.graph import SceneGraph

log = logging.getLogger(__name__)

MEASUREMENTS_FILE = "measurements.json"  # in a scene's folder of the scenes stage's output
FORMAT = 1  # of the file; a file of another format is skipped
MISSING = object()  # ``MeasurementStore.get``: nothing stored under the key

Key = tuple  # (str(action), layout key): what ``World.measure_manipulation`` memoises under


def made_with(sim: SimConfig, grid_resolution: float, scene: SceneGraph) -> dict:
    """What a measurement depends on besides its key (JSON data): the file format, the simulator's
    config, the grid resolution [m], the scene as built (sha256 of its graph: the walls, doors and
    furniture the key leaves out) and the code that measures (``simulator_code``)."""
    return {"format": FORMAT, "grid_resolution": float(grid_resolution),
            "scene": hashlib.sha256(scene.to_json().encode()).hexdigest(), "code": simulator_code(),
            "sim": json.loads(json.dumps(dataclasses.asdict(sim)))}


@functools.cache
def simulator_code() -> str:
    """sha256 of the simulator's sources (``interllm/sim/*.py``) and the MuJoCo and mink releases:
    a measurement made by other code is not used, even when only a later stage runs."""
    h = hashlib.sha256()
    for f in sorted(Path(__file__).parent.glob("*.py")):
        h.update(f.name.encode() + b"\0" + f.read_bytes() + b"\0")
    for dist in ("mujoco", "mink"):
        h.update(f"{dist}=={_release(dist)}\0".encode())
    return h.hexdigest()


def _release(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "absent"


def differences(ours: dict, theirs: Any, prefix: str = "") -> list[str]:
    """The keys whose values differ between two ``made_with`` documents, as ``key: file X, here Y``."""
    if not isinstance(theirs, dict):
        return [f"{prefix or 'made_with'}: file {theirs!r}, here a document"]
    out = []
    for k in sorted(set(ours) | set(theirs)):
        a, b = ours.get(k), theirs.get(k)
        if isinstance(a, dict) and isinstance(b, dict):
            out += differences(a, b, f"{prefix}{k}.")
        elif a != b:
            out.append(f"{prefix}{k}: file {b!r}, here {a!r}")
    return out


class MeasurementStore:
    """Initial-map measurements by key (``Key``); a value is an :class:`ActionResult` or None (the
    action cannot be tried). Values are shared, not copied: readers only read them."""

    def __init__(self, sim: SimConfig, grid_resolution: float, scene: SceneGraph) -> None:
        self.made_with = made_with(sim, grid_resolution, scene)
        self._entries: dict[Key, Optional[ActionResult]] = {}

    def __len__(self) -> int:
        return len(self._entries)

    def keys(self) -> list[Key]:
        """The stored keys, in the order they were added."""
        return list(self._entries)

    def get(self, key: Key) -> Any:
        """The stored measurement (an ActionResult or None), or ``MISSING``."""
        return self._entries.get(key, MISSING)

    def put(self, key: Key, result: Optional[ActionResult]) -> None:
        self._entries[key] = result

    # -- the file ---------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        entries = [{"action": k[0], "layout": _lists(k[1]), "result": None if r is None else r.to_record()}
                   for k, r in sorted(self._entries.items(), key=lambda kv: json.dumps(_lists(kv[0])))]
        return {"made_with": self.made_with, "entries": entries}

    def write(self, path: str | Path) -> None:
        write_json(path, self.to_dict())

    def read(self, path: str | Path) -> int:
        """Add the measurements of ``path`` (written by :meth:`write`) if it was made with what this
        store's are (``made_with``); return how many were added (0, with a warning naming what
        differs, when it was not). A file that is not such a document is an :class:`InputFileError`
        naming the file and entry."""
        doc = read_json(path)
        if not isinstance(doc, dict) or not isinstance(doc.get("entries"), list):
            raise InputFileError(path, "not a measurements document (an object with 'made_with' and an "
                                       "'entries' list); rerun the scenes stage (dvc repro scenes)")
        if diff := differences(self.made_with, doc.get("made_with")):
            shown = "; ".join(d if len(d) <= 200 else d[:200] + "..." for d in diff[:3])
            log.warning("%s: made with another scene, simulator config or code (%s%s), not used (measuring again); "
                        "rerun the scenes stage (dvc repro scenes) to bring it up to date", path, shown,
                        f"; {len(diff) - 3} more" if len(diff) > 3 else "")
            return 0
        for i, e in enumerate(doc["entries"]):
            try:
                key = (str(e["action"]), _tuples(e["layout"]))
                self._entries[key] = None if e["result"] is None else ActionResult.from_record(e["result"])
            except (KeyError, TypeError, ValueError) as err:
                raise InputFileError(path, f"entries[{i}] is not a measurement ({type(err).__name__}: {err}); "
                                           "rerun the scenes stage (dvc repro scenes)") from None
        return len(doc["entries"])


def _lists(v: Any) -> Any:
    return [_lists(x) for x in v] if isinstance(v, (tuple, list)) else v


def _tuples(v: Any) -> Any:
    return tuple(_tuples(x) for x in v) if isinstance(v, list) else v
