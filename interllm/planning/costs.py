"""Cost estimation of plan candidates (paper §IV-C): text encoding/decoding, ĉ_nav, ĉ_total.

- ``encode_cost``: f_en(c) = hard if c > 15, medium if 5 <= c <= 15, easy if c < 5.
- ``decode_cost``: f_de = hard 20, medium 10, easy 5, unknown 0.
- ``estimate_navigation``: ĉ(a_nav) from the presumed path p_pre and the known navigations
  (p_i, c_i) ∈ C^naved, with mode
    * ``paper_sum`` (the paper's eq. 8): ĉ = Σ_i c_i · P°(p_pre, p_i). Unnormalised: it
      grows with the history and is 0 for a path that overlaps no known path.
    * ``weighted_mean``: ĉ = Σ_i c_i·P° / Σ_i P°, a similarity-weighted mean of the known costs
      (same units as c_nav). When Σ P° = 0 (no known path overlaps) it falls back as below.
    * ``prior`` (ours, ``planner.inter_llm.nav_estimate``'s default; no novelty bias): ĉ = L · (r_0 + Σ_i w_i r_i) / (1 + Σ_i w_i), with L the
      presumed path's length [m], r_i = c_i / L_i the known cost per metre, w_i = P°/200 ∈ [0, 1],
      and r_0 = 1/base_speed + 1 the presumed path's own cost per metre (no collision) as a prior of
      weight 1: a new path costs what its length says, a path like one that collided costs more.
      With it, ``unknown_manipulation_estimate`` gives an "unknown" manipulation the mean measured
      cost of the known manipulations of its kind instead of leaving it out.
  With no known navigation at all (the first command) every mode falls back to the presumed
  path's own cost c_nav with cc = 0: t = length/base_speed [s], d = length [m] (turn time ignored).
- ``expected_failure_cost`` (``planner.inter_llm.cost_encoding=expected``, our option; the paper's encoding is
  the default): a manipulation's estimate plus γ_obj times the chance it fails outright, so a pickup
  that can never succeed weighs what losing the object costs. The chance: 1 for a known action whose
  every execution failed, 0 for any other known one; for an inferred class, ``hard_failure_prob`` for
  "hard" (the class spans slow-but-sure and never-succeeding actions) and 0 for the others; for the
  numeric oracle, 1 when the measured success rate is 0.
- ``plan_total``: ĉ_total = Σ ĉ_nav + Σ ĉ_man · N_valid/N_man, N_valid = number of manipulation
  estimates that are not ``unknown``; 0/0 is defined as 0 (a plan without manipulations).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from interllm.planning.memory import KnownCosts
from interllm.planning.similarity import path_overlap

COST_LABELS = ("easy", "medium", "hard", "unknown")
DECODE = {"hard": 20.0, "medium": 10.0, "easy": 5.0, "unknown": 0.0}
NAV_MODES = ("paper_sum", "weighted_mean", "prior")
MIN_RATE_LENGTH = 0.5  # [m] known paths shorter than this count as this long for a cost per metre
# Estimate of a navigation whose presumed path does not exist on the belief map.
UNREACHABLE_COST = 1.0e6


def encode_cost(cost: float) -> str:
    """f_en: numeric manipulation cost -> "easy" (< 5) | "medium" (5..15 inclusive) | "hard" (> 15)."""
    if cost > 15:
        return "hard"
    if cost >= 5:
        return "medium"
    return "easy"


def decode_cost(label: str) -> float:
    """f_de: "hard" 20, "medium" 10, "easy" 5, "unknown" 0 (case and whitespace ignored)."""
    key = str(label).strip().lower()
    if key not in DECODE:
        raise ValueError(f"cost label {label!r} is not one of {list(COST_LABELS)}")
    return DECODE[key]


def path_length(path) -> float:
    """Polyline length [m] of an [N, 2] path."""
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(p) < 2:
        return 0.0
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


@dataclass
class CostEstimate:
    """One action's estimated cost inside a candidate."""

    action: str  # str(Action)
    kind: str  # navigate | pickup | place
    estimate: float
    source: str  # "similarity" | "fallback_presumed" | "unreachable" | "llm" | "known"
    label: Optional[str] = None  # manipulation: easy|medium|hard|unknown
    valid: bool = True  # manipulation: label != unknown

    def to_dict(self) -> dict:
        return {"action": self.action, "kind": self.kind, "estimate": float(self.estimate),
                "source": self.source, "label": self.label, "valid": self.valid}


@dataclass
class PlanEstimate:
    total: float
    nav: list[CostEstimate] = field(default_factory=list)
    man: list[CostEstimate] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"total": float(self.total), "nav": [e.to_dict() for e in self.nav],
                "man": [e.to_dict() for e in self.man]}


def estimate_navigation(presumed_path, known: KnownCosts, eps: float, mode: str = "paper_sum",
                        base_speed: float = 0.5) -> tuple[float, str]:
    """ĉ_nav for a presumed path [N, 2] [m] -> (estimate, source). ``eps``: ε [m];
    ``base_speed`` [m/s] for the fallback. See the module docstring for the two modes."""
    if mode not in NAV_MODES:
        raise ValueError(f"planner.inter_llm.nav_estimate {mode!r} is not one of {list(NAV_MODES)}")
    if presumed_path is None:
        return UNREACHABLE_COST, "unreachable"
    p = np.asarray(presumed_path, dtype=float).reshape(-1, 2)
    recs = known.naved
    length = path_length(p)
    fallback = length / base_speed + length
    if not recs or len(p) == 0:
        return fallback, "fallback_presumed"
    overlaps = np.array([path_overlap(p, r.path, eps) for r in recs])
    costs = np.array([r.cost for r in recs])
    if mode == "paper_sum":
        return float(np.sum(costs * overlaps)), "similarity"
    if mode == "prior":
        w = overlaps / 200.0
        rates = np.array([r.cost / max(path_length(r.path), MIN_RATE_LENGTH) for r in recs])
        r0 = 1.0 / base_speed + 1.0
        return float(length * (r0 + np.sum(w * rates)) / (1.0 + np.sum(w))), "similarity"
    s = float(overlaps.sum())
    if s <= 0:
        return fallback, "fallback_presumed"
    return float(np.sum(costs * overlaps) / s), "similarity"


def unknown_manipulation_estimate(kind: str, known: KnownCosts) -> float:
    """``prior`` mode: the estimate of a manipulation the LLM answered "unknown" for: the mean measured
    c_man of the known manipulations of the same kind (pickup / place), else of all known ones, else
    the middle class's decoded value (medium, 10)."""
    same = [r.cost for r in known.maned if r.action.kind == kind]
    pool = same or [r.cost for r in known.maned]
    return float(np.mean(pool)) if pool else DECODE["medium"]


def failure_chance(label: str, hard_failure_prob: float, known_failed: Optional[bool] = None,
                   measured_sr: Optional[float] = None) -> float:
    """The chance [0, 1] that a manipulation fails outright, as ``expected_failure_cost`` reads it
    (module docstring): from a known record (``known_failed``), else a measured success rate, else
    the class ``label``."""
    if known_failed is not None:
        return 1.0 if known_failed else 0.0
    if measured_sr is not None:
        return 1.0 if measured_sr <= 0.0 else 0.0
    return float(hard_failure_prob) if str(label).strip().lower() == "hard" else 0.0


def expected_failure_cost(estimate: float, p_fail: float, gamma_obj: float) -> float:
    """ĉ + p_fail · γ_obj [cost units]: the estimate with the expected loss of the object."""
    return float(estimate) + float(p_fail) * float(gamma_obj)


def plan_total(nav_estimates: Sequence[float], man_estimates: Sequence[float],
               man_valid: Sequence[bool]) -> float:
    """ĉ_total = Σ ĉ_nav + Σ ĉ_man · N_valid / N_man (0/0 := 0)."""
    if len(man_estimates) != len(man_valid):
        raise ValueError("man_estimates and man_valid must have the same length")
    n_man = len(man_estimates)
    n_valid = sum(bool(v) for v in man_valid)
    factor = (n_valid / n_man) if n_man else 0.0
    return float(sum(nav_estimates)) + float(sum(man_estimates)) * factor
