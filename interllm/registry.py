"""One registry per extension point (planners, LLM backends, proposal modes), filled by decorators
where each implementation is defined: one place per name.

    PLANNERS = Registry("planner", "planner.names")

    @PLANNERS.register("sayplan", label="SayPlan")
    class SayPlanPlanner: ...

    PLANNERS.get("sayplan")      # the class; an unknown name raises ConfigError naming the
                                 # config key and the registered names
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from interllm.config import ConfigError


@dataclass(frozen=True)
class Entry:
    name: str
    factory: Any
    label: str  # how tables and figures name it
    meta: dict = field(default_factory=dict)


class Registry:
    """Names -> factories of one kind, in registration order.

    kind: what is registered ("planner"); config_key: the config key whose values are these names
    (for the error message).
    """

    def __init__(self, kind: str, config_key: str) -> None:
        self.kind, self.config_key = kind, config_key
        self._entries: dict[str, Entry] = {}

    def register(self, name: str, label: str | None = None, **meta: Any) -> Callable[[Any], Any]:
        """Decorator registering a class or factory under ``name`` (once per name)."""
        def add(factory: Any) -> Any:
            if name in self._entries:
                raise ValueError(f"{self.kind} {name!r} is registered twice "
                                 f"({self._entries[name].factory!r} and {factory!r})")
            self._entries[name] = Entry(name, factory, label or name, dict(meta))
            return factory
        return add

    def unregister(self, name: str) -> None:
        """Remove ``name`` (tests that register a temporary implementation)."""
        self._entries.pop(name, None)

    def names(self) -> list[str]:
        return list(self._entries)

    def entry(self, name: str) -> Entry:
        try:
            return self._entries[name]
        except KeyError:
            raise ConfigError(f"config key '{self.config_key}': {name!r} is not a registered {self.kind}; "
                              f"choose one of {self.names()}") from None

    def get(self, name: str) -> Any:
        return self.entry(name).factory

    def label(self, name: str) -> str:
        """The display label of ``name`` (the name itself if it is not registered)."""
        e = self._entries.get(name)
        return e.label if e is not None else name

    def __contains__(self, name: object) -> bool:
        return name in self._entries
