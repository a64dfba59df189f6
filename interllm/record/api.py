"""The recorder interface the planners and stages log through (implemented by ``record.recorder.McapRecorder``).

Every timestamp is simulated mission time [s]. ``NullRecorder`` drops everything (tests,
benchmarks of the planner alone).
"""

from __future__ import annotations

from typing import Any, Protocol

from interllm.core.results import ActionResult


class Recorder(Protocol):
    def event(self, topic: str, t: float, payload: dict[str, Any]) -> None:
        """A planner event on a JSON channel, e.g. topic "/planner/candidates"."""

    def action(self, result: ActionResult, context: dict[str, Any]) -> None:
        """A per-action result (+ its trajectory and paths); context has planner/command ids."""

    def log(self, t: float, level: str, message: str) -> None:
        """A human-readable log line (foxglove.Log)."""


class NullRecorder:
    def event(self, topic: str, t: float, payload: dict[str, Any]) -> None:
        pass

    def action(self, result: ActionResult, context: dict[str, Any]) -> None:
        pass

    def log(self, t: float, level: str, message: str) -> None:
        pass
