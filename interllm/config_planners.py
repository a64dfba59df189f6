"""Each built-in planner's own settings (``planner.<name>.*``) and how a settings node is built.

A planner declares its settings as a dataclass registered with it
(``@PLANNERS.register("inter_llm", config=InterLLMConfig)``); the runner hands the planner that
node, built from ``planner.<name>``. The built-in planners' dataclasses live here, in the config
layer, so Hydra's schema types their nodes at composition (``planner.inter_llm.epsilon_d=abc``
fails there). A planner defined outside the package (``planner.modules``) brings its dataclass in
its own module; its node ``planner.<name>`` is composed as given and checked against that
dataclass once the module is imported (``interllm.stages.validate.check_registered``), with the
same messages. A variant registered with ``ablates=<name>`` reads the node of the planner it
ablates: a paired comparison holds every other setting equal.

Units are in the field comments: metres [m], seconds [s].
"""

from __future__ import annotations

import dataclasses
import difflib
import inspect
from dataclasses import dataclass
from typing import Any

from interllm.config_types import ConfigError, coerce
from interllm.config_types import check as _check
from interllm.config_types import choice as _choice

NAV_ESTIMATES = ("paper_sum", "weighted_mean", "prior")  # interllm/planning/costs.py
COST_ENCODINGS = ("paper", "expected")  # planner.inter_llm.cost_encoding (interllm/planning/costs.py)


@dataclass
class InterLLMConfig:
    """``planner.inter_llm``: how Inter-LLM estimates a candidate's cost from the known costs."""

    # one of NAV_ESTIMATES (interllm/planning/costs.py): paper_sum: the paper's equation; prior: the
    # path's length times a similarity-weighted mean of the known costs per metre, with the path's
    # own cost per metre as a prior
    nav_estimate: str = "prior"
    epsilon_d: float = 1.0  # [m] path-overlap distance scale of P°
    # paper: a manipulation estimate is the decoded class (or the known cost); expected: plus the
    # expected loss of the object, gamma_obj times the chance the action fails outright
    cost_encoding: str = "paper"
    # expected encoding: the chance that an action labelled "hard" fails outright (a class stands for
    # a cost range; "hard" covers both slow-but-sure and never-succeeding manipulations)
    hard_failure_prob: float = 0.5

    def validate(self, key: str = "planner.inter_llm") -> None:
        _choice(self.nav_estimate, f"{key}.nav_estimate", NAV_ESTIMATES)
        _check(self.epsilon_d > 0, f"{key}.epsilon_d", f"must be > 0, got {self.epsilon_d}")
        _choice(self.cost_encoding, f"{key}.cost_encoding", COST_ENCODINGS)
        _check(0.0 <= self.hard_failure_prob <= 1.0, f"{key}.hard_failure_prob",
               f"must be in [0, 1], got {self.hard_failure_prob}")


@dataclass
class SayPlanConfig:
    """``planner.sayplan``."""

    max_iterations: int = 3  # symbolic-simulator replanning rounds per command

    def validate(self, key: str = "planner.sayplan") -> None:
        _check(1 <= self.max_iterations <= 20, f"{key}.max_iterations", f"must be in [1, 20], got {self.max_iterations}")


@dataclass
class MoMaLLMConfig:
    """``planner.moma_llm``."""

    max_replans: int = 3  # replans after execution failures, per command

    def validate(self, key: str = "planner.moma_llm") -> None:
        _check(0 <= self.max_replans <= 20, f"{key}.max_replans", f"must be in [0, 20], got {self.max_replans}")


# the flat keys these nodes replaced: old key -> (node, key); a config that still uses one gets a
# message naming the new key, and stored job configs of earlier runs are read through it
LEGACY_PLANNER_KEYS = {
    "nav_estimate": ("inter_llm", "nav_estimate"), "epsilon_d": ("inter_llm", "epsilon_d"),
    "cost_encoding": ("inter_llm", "cost_encoding"), "hard_failure_prob": ("inter_llm", "hard_failure_prob"),
    "moma_max_replans": ("moma_llm", "max_replans"), "sayplan_max_iterations": ("sayplan", "max_iterations"),
}


def upgrade_legacy_planner_keys(planner: dict) -> dict:
    """A copy of a stored ``planner`` mapping with the flat keys of earlier runs (LEGACY_PLANNER_KEYS)
    moved into their planner's node: for reading configs that runs wrote before the nodes existed."""
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in planner.items()}
    for old, (node, key) in LEGACY_PLANNER_KEYS.items():
        if old in out:
            out.setdefault(node, {})[key] = out.pop(old)
    return out


def build_section(cls: type, data: Any, prefix: str, source: str = "") -> Any:
    """An instance of the config dataclass ``cls`` from the mapping ``data``, every value's type
    checked against the annotations and ``validate()`` called. ``prefix`` is the node's config key
    with a trailing dot (``planner.inter_llm.``); unknown keys raise ConfigError naming the key,
    ``source``, the closest valid key and the valid keys."""
    where = f" (in {source})" if source else ""
    if not isinstance(data, dict):
        raise ConfigError(f"config key '{prefix[:-1]}'{where} must be a mapping of keys, got {data!r}")
    fields = {f.name: f for f in dataclasses.fields(cls) if not f.metadata.get("internal")}  # no config keys
    unknown = sorted(set(data) - set(fields), key=str)
    if unknown:
        close = difflib.get_close_matches(str(unknown[0]), list(fields), n=1)
        raise ConfigError(f"config key '{prefix}{unknown[0]}'{where} is unknown"
                          f"{f' (did you mean {prefix}{close[0]!s}?)' if close else ''}; valid keys: {sorted(fields)}")
    missing = [k for k, f in fields.items() if k not in data and f.init and f.default is dataclasses.MISSING
               and f.default_factory is dataclasses.MISSING]
    if missing:
        raise ConfigError(f"config key '{prefix}{missing[0]}'{where} is required (it has no default); set it, "
                          f"e.g. in conf/ or as {prefix}{missing[0]}=<value>")
    obj = cls(**{k: v if dataclasses.is_dataclass(v) else coerce(v, _annotation(fields[k]), f"{prefix}{k}", source)
                 for k, v in data.items()})  # a dataclass value is a group or node built already
    validate = getattr(obj, "validate", None)
    if validate is not None:  # with the node's key where it takes one (a planner's own dataclass may not)
        validate(prefix[:-1]) if inspect.signature(validate).parameters else validate()
    return obj


def _annotation(f: dataclasses.Field) -> str:
    """A field's annotation as written ("int", "list[str]", "Optional[float]"), also in a module
    without ``from __future__ import annotations`` (where it is the type itself)."""
    if isinstance(f.type, str):
        return f.type
    if isinstance(f.type, type):
        return f.type.__name__
    return str(f.type).replace("typing.", "")
