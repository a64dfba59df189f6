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

A store serves only a world of the same scene, simulator config and grid resolution
(``fingerprint``); a file made for another is skipped with a warning, never used.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
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


def fingerprint(sim: SimConfig, grid_resolution: float, scene: SceneGraph) -> str:
    """sha256 of what a measurement depends on besides its key: the simulator's config, the grid
    resolution [m] and the scene as built (its graph: walls, doors and furniture the key leaves out)."""
    text = json.dumps({"format": FORMAT, "sim": dataclasses.asdict(sim), "grid_resolution": float(grid_resolution),
                       "scene": hashlib.sha256(scene.to_json().encode()).hexdigest()}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


class MeasurementStore:
    """Initial-map measurements by key (``Key``); a value is an :class:`ActionResult` or None (the
    action cannot be tried). Values are shared, not copied: readers only read them."""

    def __init__(self, sim: SimConfig, grid_resolution: float, scene: SceneGraph) -> None:
        self.fingerprint = fingerprint(sim, grid_resolution, scene)
        self._entries: dict[Key, Optional[ActionResult]] = {}

    def __len__(self) -> int:
        return len(self._entries)

    def get(self, key: Key) -> Any:
        """The stored measurement (an ActionResult or None), or ``MISSING``."""
        return self._entries.get(key, MISSING)

    def put(self, key: Key, result: Optional[ActionResult]) -> None:
        self._entries[key] = result

    # -- the file ---------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        entries = [{"action": k[0], "layout": _lists(k[1]), "result": None if r is None else r.to_record()}
                   for k, r in sorted(self._entries.items(), key=lambda kv: json.dumps(_lists(kv[0])))]
        return {"format": FORMAT, "fingerprint": self.fingerprint, "entries": entries}

    def write(self, path: str | Path) -> None:
        write_json(path, self.to_dict())

    def read(self, path: str | Path) -> int:
        """Add the measurements of ``path`` (written by :meth:`write`) if it was made with this store's
        fingerprint; return how many were added (0, with a warning naming why, when it was not). A
        file that is not such a document is an :class:`InputFileError` naming the file and entry."""
        doc = read_json(path)
        if not isinstance(doc, dict) or not isinstance(doc.get("entries"), list):
            raise InputFileError(path, "not a measurements document (an object with 'format', 'fingerprint' "
                                       "and an 'entries' list); rerun the scenes stage (dvc repro scenes)")
        if doc.get("format") != FORMAT or doc.get("fingerprint") != self.fingerprint:
            log.warning("%s: made for another scene, simulator config or file format, not used (measuring "
                        "again); rerun the scenes stage (dvc repro scenes) to bring it up to date", path)
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
