"""How far two metrics.json results are apart, and whether any conclusion of the report changed.

Used where bit-identity is not to be had (another ISA, an unpinned BLAS kernel; see
:mod:`interllm.numerics`) and by ``make repro`` / ``interllm results diff`` to say what moved
against the committed file. A *conclusion* is what the report states from the numbers: the
ordering of the planners on mean m_overall, for each paired comparison the direction of the
improvement and of the delivered difference and whether its CI excludes 0, and whether each
planner's m_overall lies significantly below doing nothing's.
"""

from __future__ import annotations

import math
import subprocess
from dataclasses import dataclass, field
from typing import Any

from interllm.errors import UserError


@dataclass
class MetricChange:
    key: str  # "planners.inter_llm.m_overall"
    before: Any
    after: Any

    @property
    def abs_change(self) -> float | None:
        if _num(self.before) and _num(self.after):
            return float(self.after) - float(self.before)
        return None

    @property
    def rel_change_pct(self) -> float | None:
        a = self.abs_change
        if a is None:
            return None
        return 0.0 if a == 0 else (math.inf if self.before == 0 else 100.0 * a / abs(float(self.before)))


@dataclass
class Comparison:
    identical: bool
    changes: list[MetricChange] = field(default_factory=list)
    conclusions_before: dict[str, str] = field(default_factory=dict)
    conclusions_after: dict[str, str] = field(default_factory=dict)

    @property
    def changed_conclusions(self) -> list[str]:
        keys = sorted(set(self.conclusions_before) | set(self.conclusions_after))
        return [k for k in keys if self.conclusions_before.get(k) != self.conclusions_after.get(k)]

    def text(self, max_rows: int = 25) -> str:
        """A readable report: the largest relative changes first, then the conclusions."""
        if self.identical:
            return "metrics.json is identical to the reference."
        rows = sorted(self.changes, key=lambda c: -abs(c.rel_change_pct or 0.0) if c.rel_change_pct is not None
                      and math.isfinite(c.rel_change_pct) else -1e300)
        lines = [f"{len(self.changes)} value(s) moved (largest relative change first):",
                 f"  {'metric':58s} {'reference':>14s} {'now':>14s} {'change':>10s}"]
        for c in rows[:max_rows]:
            pct = c.rel_change_pct
            ch = "n/a" if pct is None else ("inf" if not math.isfinite(pct) else f"{pct:+.2f}%")
            lines.append(f"  {c.key:58s} {_fmt(c.before):>14s} {_fmt(c.after):>14s} {ch:>10s}")
        if len(rows) > max_rows:
            lines.append(f"  ... and {len(rows) - max_rows} more")
        changed = self.changed_conclusions
        if not changed:
            lines.append("No conclusion of the report changed:")
            lines += [f"  {k}: {v}" for k, v in sorted(self.conclusions_after.items())]
        else:
            lines.append(f"{len(changed)} conclusion(s) of the report changed:")
            for k in changed:
                lines.append(f"  {k}: {self.conclusions_before.get(k, '(absent)')} -> "
                             f"{self.conclusions_after.get(k, '(absent)')}")
        return "\n".join(lines)


def _num(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


def flatten(d: Any, prefix: str = "") -> dict[str, Any]:
    """A nested mapping as {"a.b.c": leaf}."""
    if isinstance(d, dict):
        out: dict[str, Any] = {}
        for k, v in d.items():
            out.update(flatten(v, f"{prefix}{k}."))
        return out
    return {prefix[:-1]: d}


def conclusions(metrics: dict) -> dict[str, str]:
    """The statements the report makes from ``metrics`` (see the module docstring)."""
    out: dict[str, str] = {}
    planners = metrics.get("planners", {})
    ranked = sorted((p for p in planners if _num(planners[p].get("m_overall"))
                     and not planners[p].get("anchor", planners[p].get("reference"))),  # anchors are shown, never ranked
                    key=lambda p: (planners[p]["m_overall"], p))
    if ranked:
        out["ordering on mean m_overall (best first)"] = " < ".join(ranked)
    for pair, imp in sorted(metrics.get("improvement", {}).items()):
        pct, lo, hi = imp.get("pct"), imp.get("ci_lo"), imp.get("ci_hi")
        if not (_num(pct) and _num(lo) and _num(hi)):
            out[f"improvement {pair}"] = "no interval"
            continue
        direction = "better" if pct > 0 else ("worse" if pct < 0 else "equal")
        sig = "CI excludes 0" if lo > 0 or hi < 0 else "CI includes 0"
        out[f"improvement {pair}"] = f"{direction}, {sig}"
    for pair, c in sorted(metrics.get("comparisons", {}).items()):
        v, lo, hi = c.get("delivered_diff"), c.get("delivered_diff_ci_lo"), c.get("delivered_diff_ci_hi")
        if not (_num(v) and _num(lo) and _num(hi)):
            out[f"delivered {pair}"] = "no interval"
            continue
        direction = "more" if v > 0 else ("fewer" if v < 0 else "equal")
        out[f"delivered {pair}"] = f"{direction}, {'CI excludes 0' if lo > 0 or hi < 0 else 'CI includes 0'}"
    for p in sorted(planners):
        below = planners[p].get("below_nothing") if isinstance(planners[p], dict) else None
        if isinstance(below, bool):
            out[f"{p} below doing nothing"] = "yes, CI below 0" if below else "no"
    return out


class MetricsShapeError(UserError, ValueError):
    """A metrics.json that is valid JSON but not of the shape the aggregate stage writes."""


def check_metrics_shape(d: Any, where: str) -> dict:
    """``d`` if it has the shape of the aggregate stage's metrics.json (an object whose ``planners``,
    ``improvement`` and ``comparisons``, where present, map names to objects), else
    :class:`MetricsShapeError` naming the place and the fix."""
    fix = "regenerate it (`dvc repro aggregate`) or restore it (`git checkout -- data/metrics/metrics.json`)"
    if not isinstance(d, dict):
        raise MetricsShapeError(f"{where} is not a metrics.json of this pipeline: a JSON object was expected, "
                                f"got {type(d).__name__}; {fix}")
    for key in ("planners", "improvement", "comparisons"):
        part = d.get(key, {})
        bad = [k for k, v in part.items() if not isinstance(v, dict)] if isinstance(part, dict) else None
        if bad is None or bad:
            at = f"{key}" if bad is None else f"{key}.{bad[0]}"
            raise MetricsShapeError(f"{where}: $.{at} is not a JSON object as the aggregate stage writes it; {fix}")
    return d


def compare_metrics(reference: dict, current: dict) -> Comparison:
    """Per-value changes from ``reference`` to ``current`` and the conclusions of both."""
    if reference == current:
        c = conclusions(current)
        return Comparison(identical=True, conclusions_before=c, conclusions_after=c)
    a, b = flatten(reference), flatten(current)
    changes = [MetricChange(k, a.get(k), b.get(k)) for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]
    return Comparison(identical=False, changes=changes, conclusions_before=conclusions(reference),
                      conclusions_after=conclusions(current))


def committed_file(repo_root, relpath: str, rev: str = "HEAD") -> bytes | None:
    """``git show REV:relpath`` in ``repo_root``; None when there is no git, no history or no
    such file at that revision."""
    try:
        r = subprocess.run(["git", "-C", str(repo_root), "show", f"{rev}:{relpath}"], capture_output=True,
                           timeout=30)
    except (OSError, subprocess.SubprocessError):
        return None
    return r.stdout if r.returncode == 0 else None
