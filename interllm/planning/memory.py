"""Known action costs C^known = {C^naved, C^maned} (paper §IV-B, "Update Known Action Costs").

Every executed action's empirical cost is stored under its (action, state) pair, where the state
is the high-level state *before* the action (``State.describe()``). Fusion follows the paper: a
new cost for a pair already known replaces it with the average of the old and the new value
(c_updated = (c̃ + c_known)/2); a new pair is appended. Navigation records also keep the driven
path (the most recent one for a fused pair) so presumed paths can be compared with them (P°).
Failed actions are recorded too: their cost carries the collisions / failure rate.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Optional

import numpy as np

from interllm.core.actions import Action, State
from interllm.core.results import ActionResult

if TYPE_CHECKING:  # only the type: the aggregate stage loads this module without the scene package
    from interllm.scene.placement import Placement


@dataclass
class NavRecord:
    action: Action
    state: str  # State.describe() before the action
    path: np.ndarray  # [N, 2] navigated path p^naved [m]
    cost: float  # c^naved (fused)
    count: int = 1  # observations fused into ``cost``

    def to_dict(self) -> dict:
        return {"action": self.action.to_dict(), "state": self.state, "cost": float(self.cost),
                "count": self.count, "path": np.round(self.path, 6).tolist()}


@dataclass
class ManRecord:
    action: Action
    state: str
    cost: float  # c^maned (fused)
    count: int = 1
    placement: Optional[Placement] = None  # where the object was when measured (llm.placement_attributes)
    failed: bool = False  # every execution of it failed (planner.inter_llm.cost_encoding=expected reads it)

    def to_dict(self) -> dict:
        d = {"action": self.action.to_dict(), "state": self.state, "cost": float(self.cost), "count": self.count}
        if self.placement is not None:
            d["placement"] = self.placement.to_dict()
        return d


class KnownCosts:
    """C^known: ``naved`` (navigation records) and ``maned`` (manipulation records), in insertion order."""

    def __init__(self) -> None:
        self._nav: dict[tuple[str, str], NavRecord] = {}
        self._man: dict[tuple[str, str], ManRecord] = {}

    @property
    def naved(self) -> list[NavRecord]:
        return list(self._nav.values())

    @property
    def maned(self) -> list[ManRecord]:
        return list(self._man.values())

    def __len__(self) -> int:
        return len(self._nav) + len(self._man)

    def add_navigation(self, action: Action, state: State, path, cost: float) -> NavRecord:
        """Add one navigation cost c̃ [cost units] with its path [N, 2] [m]; fuse if the pair is known."""
        p = np.asarray(path, dtype=float).reshape(-1, 2)
        if p.shape[0] == 0:
            raise ValueError(f"navigation record for {action} needs a non-empty path")
        key = (str(action), state.describe())
        old = self._nav.get(key)
        if old is None:
            rec = NavRecord(action, key[1], p, float(cost))
        else:
            rec = NavRecord(action, key[1], p, (float(cost) + old.cost) / 2.0, old.count + 1)
        self._nav[key] = rec
        return rec

    def add_manipulation(self, action: Action, state: State, cost: float,
                         placement: Optional[Placement] = None, failed: bool = False) -> ManRecord:
        """Add one manipulation cost c̃ [cost units]; fuse if the pair is known. ``failed``: this
        execution failed outright (the record stays ``failed`` while every execution did)."""
        key = (str(action), state.describe())
        old = self._man.get(key)
        if old is None:
            rec = ManRecord(action, key[1], float(cost), placement=placement, failed=bool(failed))
        else:
            rec = ManRecord(action, key[1], (float(cost) + old.cost) / 2.0, old.count + 1, old.placement or placement,
                            old.failed and bool(failed))
        self._man[key] = rec
        return rec

    def add_result(self, result: ActionResult, state_before: State,
                   placement: Optional[Placement] = None) -> Optional[NavRecord | ManRecord]:
        """Store an executed action's empirical cost (with a manipulation, where its object was:
        ``placement``). A navigation without any path is skipped (returns None): there is nothing
        to compare presumed paths with."""
        a = result.action
        if a.kind == "navigate":
            path = result.driven_path if result.driven_path is not None else result.presumed_path
            if path is None or len(path) == 0:
                return None
            return self.add_navigation(a, state_before, path, result.cost)
        return self.add_manipulation(a, state_before, result.cost, placement, failed=not result.success)

    def manipulation_cost(self, action: Action, state: State) -> Optional[float]:
        rec = self.manipulation_record(action, state)
        return None if rec is None else rec.cost

    def manipulation_record(self, action: Action, state: State) -> Optional[ManRecord]:
        """The known record of (action, state), or None."""
        return self._man.get((str(action), state.describe()))

    def only(self, action: Action, state: State) -> KnownCosts:
        """A copy holding only the record of exactly (``action``, ``state``), if there is one: known
        costs used for the identical action and state, never carried to similar ones."""
        out = KnownCosts()
        key = (str(action), state.describe())
        if key in self._nav:
            out._nav[key] = self._nav[key]
        if key in self._man:
            out._man[key] = self._man[key]
        return out

    def to_dict(self) -> dict:
        return {"naved": [r.to_dict() for r in self.naved], "maned": [r.to_dict() for r in self.maned]}
