"""The planner interface, its result and the planner registry.

A planner turns one command into executed actions: it receives the shared initial candidates
(made once in the ``candidates`` stage), and through a :class:`~interllm.planners.context.PlannerContext`
the world (:class:`~interllm.planners.world_view.WorldView`), the proposer (the LLM, one
implementation per mode), the known-cost memory, the recorder and the shared config (``PlannerConfig``);
its own settings (``planner.<name>``, a dataclass registered with ``config=``) reach its constructor.

Adding a planner: one module with a class decorated ``@PLANNERS.register("<name>", label="<Name>")``
that has ``run_command(command, ctx) -> CommandResult``, its module named in ``PLANNERS``' builtins below,
and one config file ``conf/planner/<name>.yaml`` (see docs/extending.md).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field, fields
from typing import Any, Protocol

from interllm.config import PLANNER_NODES, ConfigError, PlannerConfig, build_section
from interllm.core.records import CommandSummary
from interllm.core.results import ActionResult
from interllm.registry import Registry
from interllm.scene.graph import Command

# filled by @PLANNERS.register in each planner's module; the built-in ones are imported on the first lookup
PLANNERS: Registry = Registry("planner", "planner.names", builtins=(
    "interllm.planners.sayplan", "interllm.planners.moma_llm", "interllm.planners.inter_llm",
    "interllm.planners.nothing", "interllm.planners.optimal", "interllm.planners.inter_llm_ablations"))


def settings_node(name: str) -> str:
    """The node ``planner.<node>`` that configures planner ``name``: its own, or for a variant
    registered with ``ablates=<planner>`` that planner's (a paired comparison holds the rest equal)."""
    return str(PLANNERS.entry(name).meta.get("ablates") or name)


def planner_settings(name: str, cfg: PlannerConfig) -> Any:
    """The settings of planner ``name``: an instance of the dataclass it registers with ``config=``,
    from ``planner.<node>`` (a built-in node, already typed, or an external planner's, checked here);
    None for a planner that registers none."""
    cls = PLANNERS.entry(name).meta.get("config")
    if cls is None:
        return None
    node = settings_node(name)
    if node in PLANNER_NODES:
        settings = getattr(cfg, node)
        if not isinstance(settings, cls):
            raise ConfigError(f"planner {name!r} registers config={cls.__name__}, but planner.{node} is "
                              f"{type(settings).__name__} (interllm/config_planners.py): register the same class")
        return settings
    return build_section(cls, cfg.external.get(node, {}), f"planner.{node}.", "the planner config")


def make_planner(name: str, cfg: PlannerConfig) -> Planner:
    """Planner ``name`` built from its registration: with its settings (``planner_settings``) when it
    registers a config dataclass, without arguments otherwise."""
    factory, settings = PLANNERS.get(name), planner_settings(name, cfg)
    return factory() if settings is None else factory(settings)


def shown_planners(names: Iterable[str]) -> dict[str, dict[str, Any]]:
    """How tables and figures show each of ``names``, from its registration: {name: {"label", "color",
    "order", "anchor"[, "ablates"]}} (anchor: registered with ``anchor=True``, as ``nothing`` and ``optimal`` are:
    shown beside the others, never judged; ablates: the planner a variant removes one part of). The missions stage writes it beside the runs
    (``runs/planners.json``), so the metrics and the report read it without loading planner code."""
    out = {}
    for name in sorted(set(names)):
        e = PLANNERS.entry(name)
        out[name] = {"label": e.label, "color": e.meta.get("color"), "order": e.meta.get("order", 99),
                     "anchor": bool(e.meta.get("anchor", False))}
        if e.meta.get("ablates"):  # a variant of another planner with one part removed: paired against it
            out[name]["ablates"] = str(e.meta["ablates"])
    return out


@dataclass
class CommandResult(CommandSummary):
    """A planner's account of one command (``CommandSummary``: candidates, choice, LLM usage, cost
    inferences) with the actions it executed, in order (recovery and replanned actions included)."""

    actions: list[ActionResult] = field(default_factory=list)

    def summary(self) -> CommandSummary:
        """The part the mission record keeps beside the actions."""
        return CommandSummary(**{f.name: getattr(self, f.name) for f in fields(CommandSummary)})


class Planner(Protocol):
    name: str

    def run_command(self, command: Command, ctx: Any) -> CommandResult: ...
