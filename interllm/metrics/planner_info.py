"""How tables and figures show each planner (label, colour, order) and which planners are anchors
(``nothing`` and ``optimal``: shown beside the others, never judged), as the runs recorded it.

The missions stage writes ``runs/planners.json`` from the planners' registrations
(``interllm.planners.base.shown_planners``); the aggregate stage reads it and copies each planner's
entry into ``metrics.json``, and the report reads it from there. So the metrics and the report
read results, not planner code: editing a planner re-runs neither unless its results change.

The functions that name planners (``plots.label``, ``plots.color``, ``doc.ordered``,
``deliveries.is_anchor``) read the table in use (``shown(table)``); outside one, a planner is
shown by its name, in name order, and none is an anchor.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

from interllm.core.records import PLANNERS_FILE
from interllm.errors import UserError
from interllm.io import read_json


@dataclass(frozen=True)
class PlannerInfo:
    label: str  # how tables and figures name it
    color: str | None  # its matplotlib colour (None: the next one)
    order: float  # tables and figures list planners by it (then by name)
    anchor: bool  # nothing / optimal: shown, never judged
    ablates: str | None = None  # a variant of this planner with one part removed (paired against it)


class PlannerTable:
    """Planner name -> ``PlannerInfo``; a name it lacks is shown by itself, last, and is no anchor."""

    def __init__(self, entries: Mapping[str, PlannerInfo] | None = None) -> None:
        self.entries = dict(entries or {})

    @classmethod
    def from_json(cls, data: Mapping, where: str) -> PlannerTable:
        """From ``{name: {"label", "color", "order", "anchor"[, "ablates"]}}`` (``runs/planners.json``, or the
        planners of a ``metrics.json``: other keys are ignored, a planner without a label is left out)."""
        out = {}
        for name, d in data.items():
            if not isinstance(d, Mapping) or "label" not in d:
                continue
            try:
                out[str(name)] = PlannerInfo(str(d["label"]), None if d.get("color") is None else str(d["color"]),
                                             math.inf if d.get("order") is None else float(d["order"]),
                                             bool(d.get("anchor", False)),
                                             None if d.get("ablates") is None else str(d["ablates"]))
            except (TypeError, ValueError) as e:
                raise PlannerTableError(f"{where}: planner {name!r}: {e}; rerun the missions stage "
                                        f"(dvc repro missions) to rewrite it") from None
        return cls(out)

    def shown(self, name: str) -> dict:
        """{"label", "color", "order"} of ``name`` (an unknown name: itself, no colour, last)."""
        e = self.entries.get(name)
        order = e.order if e is not None else math.inf
        return {"label": self.label(name), "color": self.color(name),
                "order": (int(order) if order.is_integer() else order) if math.isfinite(order) else None}

    def label(self, name: str) -> str:
        e = self.entries.get(name)
        return e.label if e is not None else name

    def color(self, name: str) -> str | None:
        e = self.entries.get(name)
        return e.color if e is not None else None

    def is_anchor(self, name: str) -> bool:
        e = self.entries.get(name)
        return bool(e is not None and e.anchor)

    def ablates(self, name: str) -> str | None:
        """The planner ``name`` removes one part of (an ablation variant), else None."""
        e = self.entries.get(name)
        return None if e is None else e.ablates

    def ordered(self, names: Iterable[str]) -> list[str]:
        """``names`` in report order: the table's order, then by name."""
        return sorted(set(names), key=lambda n: (self.entries[n].order if n in self.entries else math.inf, n))


class PlannerTableError(UserError, ValueError):
    """runs/planners.json is missing or malformed; the message names the file and the fix."""


def load(runs_dir: str | Path) -> PlannerTable:
    """The table the missions stage wrote into ``runs_dir``."""
    path = Path(runs_dir) / PLANNERS_FILE
    if not path.is_file():
        raise PlannerTableError(f"{path} is missing: the missions stage writes it (how tables name each planner "
                                f"and which are anchors); rerun it (dvc repro missions)")
    data = read_json(path)
    if not isinstance(data, Mapping):
        raise PlannerTableError(f"{path} must map planner names to their labels; rerun the missions stage")
    return PlannerTable.from_json(data, str(path))


_IN_USE: list[PlannerTable] = [PlannerTable()]


def current() -> PlannerTable:
    """The table in use (``shown``)."""
    return _IN_USE[-1]


@contextlib.contextmanager
def shown(table: PlannerTable) -> Iterator[PlannerTable]:
    """Use ``table`` to name planners inside the block."""
    _IN_USE.append(table)
    try:
        yield table
    finally:
        _IN_USE.pop()
