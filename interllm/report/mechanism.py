"""The report's mechanism section: each ablation variant of the judged planner paired against it
(``metrics.json`` "mechanism", ``interllm.metrics.mechanism``), per mission and along the mission."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from interllm.metrics import claims
from interllm.report import plots
from interllm.report.document import Doc, ci, fnum
from interllm.report.verdicts import houses_text


def mechanism_section(doc: Doc, metrics: Mapping, per_mission: Sequence[Mapping], fig_dir: Path) -> Path | None:
    """The mechanism table, the houses a 10% difference needs (``claims.houses_needed`` on
    ``per_mission`` rows) and the learning curve (figure and table); None without variants."""
    mech = metrics.get("mechanism") or {}
    if not mech:
        return None
    doc.h(2, "Mechanism: one part removed at a time")
    doc.p("Each variant runs the same candidates and missions with one part of the mechanism removed "
          "(no learning: no known cost kept between commands; no cost choice: the first feasible candidate is "
          "executed unestimated; no carry-over: a known cost is used only for the identical action and state). "
          "Differences are full − variant per mission, with 95% house-clustered paired CIs: a positive "
          "Δ delivered and a negative Δ m_overall mean the removed part helps.")
    rows = []
    for variant, d in sorted(mech.items()):
        rows.append([plots.label(variant), plots.label(str(d.get("ablates"))), str(d.get("n_pairs")),
                     _ci(d, "n_fulfilled_diff", 2), _ci(d, "m_overall_diff", 1),
                     f"{fnum(d.get('cost_per_delivered_full'))} / {fnum(d.get('cost_per_delivered_variant'))}",
                     _ci(d, "cost_per_delivered_diff", 1), _verdict(d)])
    doc.table(["variant", "full planner", "missions", "Δ delivered / mission [CI]", "Δ m_overall / mission [CI]",
               "cost / delivered, full / variant [s]", "Δ cost / delivered [CI]", "the removed part"], rows)
    need = claims.houses_needed(per_mission, next(iter(mech.values()))["ablates"],
                                exclude=set(metrics.get("planners", {})) - set(mech))
    if need:
        doc.p("Houses a paired 10% difference in m_overall needs at 80% power (α = 0.05, two-sided), at these "
              "runs' missions per house: " + "; ".join(
                  f"vs {plots.label(v)} {houses_text(d)}" for v, d in sorted(need.items())) + ".")
    f = plots.learning_curve(mech, fig_dir / "learning_curve.png")
    doc.img(f, "Learning curve: full − variant per command index (house-clustered paired CIs)")
    doc.h(3, "Learning curve")
    rows = []
    for variant, d in sorted(mech.items()):
        for r in d.get("by_command", []):
            rows.append([plots.label(variant), str(r["command_index"]), str(r["n_pairs"]),
                         _ci(r, "n_fulfilled_diff", 2), _ci(r, "m_overall_diff", 1),
                         _ci(r, "cost_per_delivered_diff", 1)])
    doc.table(["variant", "command", "missions", "Δ delivered [CI]", "Δ m_overall [CI]", "Δ cost / delivered [CI]"],
              rows)
    return f


def _ci(d: Mapping, key: str, nd: int) -> str:
    return ci(d.get(key), d.get(f"{key}_ci_lo"), d.get(f"{key}_ci_hi"), nd, sign=True)


def _verdict(d: Mapping) -> str:
    """What the intervals say of the removed part: "helps" when full delivers more, or as many with a
    lower m_overall; "hurts" when the reverse; else "cannot tell"."""
    def side(key: str) -> int:
        lo, hi = d.get(f"{key}_ci_lo"), d.get(f"{key}_ci_hi")
        if lo is None or hi is None:
            return 0
        return 1 if float(lo) > 0 else -1 if float(hi) < 0 else 0

    dl, m = side("n_fulfilled_diff"), side("m_overall_diff")
    if dl > 0 or (dl == 0 and m < 0):
        return "helps"
    if dl < 0 or (dl == 0 and m > 0):
        return "hurts"
    return "cannot tell"
