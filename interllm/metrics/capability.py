"""The LLM-capability axis: how good the answers of an input source were, and where a model sits
among oracles of known error (``llm=oracle``, ``llm.oracle_error``).

A source answers three kinds of question, each measured against ground truth:

- relevance: the objects its candidates take (every candidate after repair, every command, every
  planner) are of a category the command asks for;
- target: the furniture its candidates deliver to is one the command names;
- cost class: Inter-LLM's inferred cost classes equal the measured ones (Table II's accuracy over
  judged inferences, 'unknown' counting as wrong).

``equivalent_error`` places a model on the oracle sweep's axis: the oracle error at which the
oracle's measured accuracy equals the model's (linear interpolation between sweep points).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, Optional

from interllm.core.records import MissionRecord


def answer_accuracy(records: Iterable[MissionRecord], scenes: Mapping[str, Mapping]) -> dict[str, Any]:
    """{"relevance", "target", "n_objects", "n_candidates"} over every candidate of every run:
    the share of proposed objects of a category their command asks for, and the share of
    candidates whose place actions all go to one of the command's target furniture. ``scenes``:
    ``compute.load_scene_categories`` ({scene: {"category": {object: category}}})."""
    n_obj = n_rel = n_cand = n_tgt = 0
    for rec in records:
        cats = scenes[rec.scene_id]["category"]
        for c in rec.commands:
            wanted, targets = set(c.goal.categories), set(c.goal.target_furniture)
            for plan in c.summary.candidates:
                objs = sorted({a.obj for a in plan if a.kind == "pickup" and a.obj})
                n_obj += len(objs)
                n_rel += sum(cats.get(o) in wanted for o in objs)
                places = [a.furniture for a in plan if a.kind == "place"]
                n_cand += 1
                n_tgt += bool(places) and all(f in targets for f in places)
    return {"relevance": n_rel / n_obj if n_obj else float("nan"),
            "target": n_tgt / n_cand if n_cand else float("nan"), "n_objects": n_obj, "n_candidates": n_cand}


def equivalent_error(accuracy: float, sweep: Sequence[tuple[float, float]]) -> Optional[float]:
    """The oracle error e at which the sweep's accuracy (pairs (e, accuracy), any order) equals
    ``accuracy``, by linear interpolation; None when the sweep has fewer than two points or the
    accuracy lies outside the sweep's range (then the model is better than the best oracle swept or
    worse than the worst)."""
    pts = sorted((float(e), float(a)) for e, a in sweep if math.isfinite(float(a)))
    if len(pts) < 2 or not math.isfinite(accuracy):
        return None
    for (e0, a0), (e1, a1) in zip(pts, pts[1:], strict=False):
        lo, hi = min(a0, a1), max(a0, a1)
        if lo <= accuracy <= hi:
            return e0 if a0 == a1 else e0 + (accuracy - a0) * (e1 - e0) / (a1 - a0)
    return None


def paying_errors(points: Sequence[tuple[float, float, float]]) -> tuple[list[float], list[float]]:
    """(the swept errors at which the judged planner's paired improvement CI lies above 0, those
    at which it does not); points: (error, ci_lo, ci_hi)."""
    above = [e for e, lo, _ in sorted(points) if math.isfinite(lo) and lo > 0]
    return above, [e for e, _, _ in sorted(points) if e not in above]
