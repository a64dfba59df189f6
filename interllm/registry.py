"""One registry per extension point (planners, LLM backends, proposal modes), filled by decorators
where each implementation is defined: one place per name.

    PLANNERS = Registry("planner", "planner.names")

    @PLANNERS.register("sayplan", label="SayPlan")
    class SayPlanPlanner: ...

    PLANNERS.get("sayplan")      # the class; an unknown name raises ConfigError naming the
                                 # config key and the registered names
"""

from __future__ import annotations

import importlib
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
    """Names -> factories of one kind.

    kind: what is registered ("planner"); config_key: the config key whose values are these names
    (for the error message).
    """

    def __init__(self, kind: str, config_key: str, builtins: tuple[str, ...] = ()) -> None:
        """builtins: the modules that register the built-in implementations, imported on the first
        lookup (so importing the package that holds the registry loads none of them)."""
        self.kind, self.config_key, self.builtins = kind, config_key, tuple(builtins)
        self._entries: dict[str, Entry] = {}
        self._loaded = not self.builtins

    def _load_builtins(self) -> None:
        if not self._loaded:
            self._loaded = True  # first: a built-in module may look itself up while it registers
            for module in self.builtins:
                importlib.import_module(module)

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
        """The registered names, sorted (registration order depends on which module was imported first)."""
        self._load_builtins()
        return sorted(self._entries)

    def entry(self, name: str) -> Entry:
        self._load_builtins()
        try:
            return self._entries[name]
        except KeyError:
            raise ConfigError(f"config key '{self.config_key}': {name!r} is not a registered {self.kind}; "
                              f"choose one of {self.names()}") from None

    def get(self, name: str) -> Any:
        return self.entry(name).factory

    def label(self, name: str) -> str:
        """The display label of ``name`` (the name itself if it is not registered)."""
        self._load_builtins()
        e = self._entries.get(name)
        return e.label if e is not None else name

    def __contains__(self, name: object) -> bool:
        self._load_builtins()
        return name in self._entries
