"""The report's first part: the headline table and what it rests on.

- ``headline_section``: per planner objects delivered [CI], m_overall [CI], the normalised
  position between the anchors, doing nothing (0) and the optimal reference (1) [CI], whether
  m_overall lies significantly below doing nothing's, and the execution cost per delivered object;
  the paired differences between the planners with their per-house effects; the slots the scenes
  stage measured as deliverable (``feasibility.json``);
- ``summary_section``: the summary per planner with the paired improvement and whether the
  paper's ordering (the judged planner lowest on m_overall) holds (``ordering_sentence``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Optional

from interllm.io import read_json
from interllm.metrics import claims
from interllm.metrics.deliveries import NOTHING, OPTIMAL
from interllm.report import plots
from interllm.report.document import Doc, ci, fnum, num_or_nan, ordered, pct


def split_planners(planners: Mapping[str, Mapping]) -> tuple[list[str], list[str]]:
    """(claimants, anchors) in report order."""
    refs = [p for p in ordered(planners) if planners[p].get("anchor", planners[p].get("reference"))]
    return [p for p in ordered(planners) if p not in refs], refs


def _position_cell(p: str, d: Mapping) -> str:
    if p == NOTHING:
        return "0 (anchor)"
    if p == OPTIMAL:
        return "1 (anchor)"
    return ci(d.get("position"), d.get("position_ci_lo"), d.get("position_ci_hi"), 2)


def _below_cell(p: str, d: Mapping) -> str:
    if p == NOTHING:
        return "(anchor)"
    b = d.get("below_nothing")
    txt = ci(d.get("m_minus_nothing"), d.get("m_minus_nothing_ci_lo"), d.get("m_minus_nothing_ci_hi"), sign=True)
    return txt + (": yes" if b is True else ": no" if b is False else "")


def against_anchor(comparison: Mapping) -> bool:
    """Whether a comparison's baseline is an anchor (listed after the others)."""
    return bool(comparison.get("baseline_anchor", comparison.get("baseline_reference")))


def _missing_anchors(metrics: Mapping) -> list[str]:
    """Which of nothing / optimal have no runs (a metrics.json written before the anchors had their
    name keeps them under "references")."""
    return metrics.get("anchors", metrics.get("references", {})).get("missing", [NOTHING, OPTIMAL])


def missing_anchors_sentence(metrics: Mapping) -> Optional[str]:
    """What the report leaves out when an anchor has no runs (None when both have)."""
    missing = _missing_anchors(metrics)
    if not missing:
        return None
    names = " and ".join(f"`{m}`" for m in missing)
    what = "the position column and the comparison with doing nothing are" if NOTHING in missing \
        else "the position column is"
    return (f"No runs of the {names} anchor{'s' if len(missing) > 1 else ''} in these results, so {what} left "
            f"out: add {names} to planner.names and rerun the missions stage (the position needs one run of "
            f"`{NOTHING}` and one of `{OPTIMAL}` on the same missions).")


def headline_section(doc: Doc, metrics: Mapping, scenes_dir: Path, scene_ids: Sequence[str],
                     judge: str) -> None:
    """The headline table (deliveries beside m_overall, the position between the anchors), the
    paired differences, and the deliverable slots of the scenes."""
    pl = metrics.get("planners", {})
    claimants, refs = split_planners(pl)
    missing = _missing_anchors(metrics)
    with_pos, with_null = not missing, NOTHING not in missing
    doc.h(2, "Headline: objects delivered, m_overall and position")
    doc.p("Delivered = distinct goal objects the robot put on a target furniture (Σ sr_obj; at most n per command "
          "asking for n, a replacement after a failure counts), in all and per mission. m_overall per mission "
          "(lower is better) charges an unfilled slot γ_man + γ_obj, so a planner can lower it by trying less: read "
          "it beside the deliveries. Position = (m_nothing − m) / (m_nothing − m_optimal) on the sums over the "
          "missions all three ran: 0 = as good as doing nothing, 1 = as good as the optimal reference (the "
          "cheapest assignment over the mission on ground-truth costs, executed), below 0 = worse than doing "
          "nothing. m − m_nothing is the paired difference per mission; \"yes\" when its CI lies below 0 (significantly better than doing "
          "nothing). Cost per delivered = Σ(γ_nav·cc + t_exe + d) / delivered [s per object]. 95% CIs, clustered by house "
          "(paired ones over the same missions). The anchors (doing nothing, the optimal reference) are "
          "shown, never judged.")
    header = ["planner", "missions", "delivered", "delivered / mission [CI]", "m_overall / mission [CI]"]
    header += ["position [CI]"] if with_pos else []
    header += ["cost / delivered [s]"]
    header += ["m − m_nothing [CI]: below?"] if with_null else []
    rows = []
    for p in claimants + refs:
        d = pl[p]
        row = [plots.label(p) + (" (anchor)" if p in refs and "anchor" not in plots.label(p) else ""),
               str(d.get("n_missions")), f"{d.get('delivered', d.get('n_fulfilled'))}/{d.get('n_objects')}",
               ci(d.get("delivered_per_mission"), d.get("delivered_per_mission_ci_lo"),
                  d.get("delivered_per_mission_ci_hi"), 2),
               ci(d.get("m_overall"), d.get("m_overall_ci_lo"), d.get("m_overall_ci_hi"))]
        row += [_position_cell(p, d)] if with_pos else []
        row += [fnum(d.get("exec_cost_per_delivered"))]
        row += [_below_cell(p, d)] if with_null else []
        rows.append(row)
    doc.table(header, rows)
    note = missing_anchors_sentence(metrics)
    if note:
        doc.p(note)
    comps = metrics.get("comparisons", {})
    if comps:
        doc.p(f"Paired differences per mission, {plots.label(judge)} − other planner, on the missions both ran "
              "(negative m_overall: cheaper; negative delivered: fewer objects):")
        crow = []
        for k in sorted(comps, key=lambda k: (against_anchor(comps[k]), k)):
            c = comps[k]
            b = str(c.get("baseline", k.split("_vs_", 1)[1]))
            crow.append([f"{plots.label(judge)} − {plots.label(b)}", str(c.get("n_pairs")),
                         ci(c.get("delivered_diff"), c.get("delivered_diff_ci_lo"), c.get("delivered_diff_ci_hi"), 2,
                            sign=True),
                         ci(c.get("m_overall_diff"), c.get("m_overall_diff_ci_lo"), c.get("m_overall_diff_ci_hi"),
                            sign=True), _by_house_cell(c.get("m_overall_diff_by_house", {})), _reading(c)])
        doc.table(["comparison", "pairs", "Δ delivered / mission [CI]", "Δ m_overall / mission [CI]",
                   "Δ m_overall per house (houses below 0)", "reading"], crow)
    doc.p(feasibility_sentence(scenes_dir, scene_ids, pl))


def _by_house_cell(by_house: Mapping[str, Any]) -> str:
    """The per-house mean differences of a comparison, in house order, and how many are below 0
    ("–" for metrics made before they were recorded)."""
    if not by_house:
        return "–"
    vals = [num_or_nan(v) for _, v in sorted(by_house.items())]
    cells = ", ".join(f"{v:+.1f}" if math.isfinite(v) else "–" for v in vals)
    return f"{cells} ({sum(v < 0 for v in vals)}/{len(vals)})"


def _reading(c: Mapping) -> str:
    """One phrase from the two paired CIs of a comparison."""
    def side(lo: Any, hi: Any) -> int:
        lo, hi = num_or_nan(lo), num_or_nan(hi)
        return 0 if math.isnan(lo) or math.isnan(hi) else (1 if lo > 0 else -1 if hi < 0 else 0)

    m = side(c.get("m_overall_diff_ci_lo"), c.get("m_overall_diff_ci_hi"))
    d = side(c.get("delivered_diff_ci_lo"), c.get("delivered_diff_ci_hi"))
    if m < 0 and d < 0:
        return "lower m_overall by delivering fewer objects"
    if m < 0:
        return "lower m_overall, " + ("more objects" if d > 0 else "no delivery difference shown")
    if m > 0:
        return "higher m_overall" + (", more objects" if d > 0 else ", fewer objects" if d < 0 else "")
    return "no m_overall difference shown" + (", more objects" if d > 0 else ", fewer objects" if d < 0 else "")


def read_feasibility(scenes_dir: Path, scene_ids: Sequence[str]) -> dict:
    """Slots asked and fulfillable by measurement, summed over ``scene_ids``' feasibility.json
    (the scenes stage's, {"totals": {"slots_asked", "slots_fulfillable"}}), read defensively:
    {"asked", "fulfillable", "found": [ids], "missing": [ids], "unreadable": [(id, why)]}."""
    out: dict[str, Any] = {"asked": 0, "fulfillable": 0, "found": [], "missing": [], "unreadable": []}
    for sid in sorted(set(scene_ids)):
        p = Path(scenes_dir) / sid / "feasibility.json"
        if not p.is_file():
            out["missing"].append(sid)
            continue
        try:
            t = read_json(p)["totals"]
            asked, ful = int(t["slots_asked"]), int(t["slots_fulfillable"])
        except Exception as e:  # any malformed file: say so in the report, never fail it
            out["unreadable"].append((sid, f"{type(e).__name__}: {e}"))
            continue
        out["asked"] += asked
        out["fulfillable"] += ful
        out["found"].append(sid)
    return out


def _optimal_share(planners: Mapping[str, Mapping], fulfillable: int) -> str:
    """" The optimal reference delivered X of the Y fulfillable slots (...)." or ""."""
    if "optimal" not in planners:
        return ""
    d = int(planners["optimal"].get("delivered") or 0)
    why = ("every one" if d == fulfillable else
           "the others failed in execution" if d < fulfillable else
           "more than measured: a target took more than its measured capacity")
    return f" The optimal reference delivered {d} of the {fulfillable} fulfillable slots ({why})."


def feasibility_sentence(scenes_dir: Path, scene_ids: Sequence[str], planners: Mapping[str, Mapping]) -> str:
    """Slots asked vs fulfillable by measurement (or why the report cannot say)."""
    f = read_feasibility(scenes_dir, scene_ids)
    parts = []
    if f["found"]:
        share = f"{100 * f['fulfillable'] / f['asked']:.0f}%" if f["asked"] else "–"
        best = max(((planners[p].get("delivered", planners[p].get("n_fulfilled")) or 0, p) for p in planners),
                   default=None)
        parts.append(f"Deliverable slots (the scenes stage's feasibility.json, measured in the simulator, over "
                     f"{len(f['found'])} scene(s) and all their missions): {f['fulfillable']} of {f['asked']} slots "
                     f"asked ({share}) can be fulfilled at all"
                     + (f"; the most any planner delivered in these runs is {best[0]} ({plots.label(best[1])})."
                        if best else ".") + _optimal_share(planners, f["fulfillable"]))
    if f["missing"]:
        parts.append(f"No feasibility.json under {scenes_dir} for scene(s) {', '.join(f['missing'])}: how many of "
                     f"the slots asked can be fulfilled at all is not measured there (the scenes stage writes it).")
    for sid, why in f["unreadable"]:
        parts.append(f"{Path(scenes_dir) / sid / 'feasibility.json'} could not be read ({why}); it is left out.")
    return " ".join(parts) or f"No scenes to read feasibility.json for under {scenes_dir}."


def ordering_sentence(metrics: Mapping, judge: str) -> str:
    """One sentence: does the paper's ordering (the judged planner best on m_overall among the
    planners) hold? Judged as ``claims.ordering`` does: it holds when every paired improvement of
    the judged planner has its CI above 0 and it does not deliver significantly fewer objects, does not
    hold when one has its CI below 0 (or the lower m_overall came from delivering fewer objects),
    and otherwise the runs cannot tell (the mean rank alone decides nothing)."""
    refs = claims.set_aside(metrics)
    pl = {p: d for p, d in metrics.get("planners", {}).items() if p not in refs}
    if judge not in pl or len(pl) < 2:
        return (f"The paper's ordering ({plots.label(judge)} best on m_overall) cannot be judged: "
                f"runs exist only for {sorted(pl)}.")
    ranked = sorted(pl, key=lambda p: (float("inf") if pl[p].get("m_overall") is None else pl[p]["m_overall"], p))
    figs = "; ".join(f"{plots.label(p)} {fnum(pl[p].get('m_overall'))} [{fnum(pl[p].get('m_overall_ci_lo'))}, "
                     f"{fnum(pl[p].get('m_overall_ci_hi'))}]" for p in ranked)
    o = claims.ordering(metrics)
    imps = "; ".join(f"{plots.label(judge)} vs {plots.label(b)}: {fnum(v[0])}% [{fnum(v[1])}, {fnum(v[2])}]"
                     for b, v in sorted(o["improvements"].items()))
    verdict = {"holds": "holds on our runs", "does not hold": "does not hold on our runs",
               claims.FEWER: "does not hold on our runs: its lower m_overall comes from delivering fewer objects",
               }.get(o["verdict"], "cannot be told on our runs (a paired CI includes 0 or has too few pairs)")
    best = "the lowest" if ranked[0] == judge else "not the lowest"
    return (f"The paper's ordering ({plots.label(judge)} best on m_overall per mission, judged by the paired "
            f"CIs and the delivery check) {verdict}; its mean is {best}: {figs} (mean per mission, "
            f"{len(pl)} planners, anchors aside; 95% CI)." + (f" Paired improvement: {imps}." if imps else ""))


def summary_section(doc: Doc, metrics: Mapping, judge: str) -> None:
    """Every per-planner figure, objects delivered and the cost per delivered object beside m_overall;
    failed LLM calls; the paired improvements."""
    pl = metrics.get("planners", {})
    doc.h(2, "Summary per planner")
    doc.p(ordering_sentence(metrics, judge))
    rows = []
    for p in ordered(pl):
        d = pl[p]
        rows.append([plots.label(p), str(d.get("n_missions")),
                     f"{fnum(d.get('m_overall'))} [{fnum(d.get('m_overall_ci_lo'))}, {fnum(d.get('m_overall_ci_hi'))}]",
                     f"{d.get('delivered', d.get('n_fulfilled'))}/{d.get('n_objects')}",
                     ci(d.get("delivered_per_mission"), d.get("delivered_per_mission_ci_lo"),
                                 d.get("delivered_per_mission_ci_hi"), 2),
                     fnum(d.get("exec_cost_per_delivered")), fnum(d.get("m_overall_per_object")),
                     pct(d.get("sr_obj")), fnum(d.get("cc"), 2), fnum(d.get("d")), fnum(d.get("t_exe")),
                     pct(d.get("sr_man")), fnum(d.get("llm_calls_per_mission")),
                     fnum(d.get("llm_tokens_in_per_mission"), 0), fnum(d.get("llm_tokens_out_per_mission"), 0)])
    doc.p("Scoring rule: a command asking for n objects has n slots, the k-th distinct object the planner "
          "manipulated in it; a slot it never filled scores sr_man = 0 and sr_obj = 0 with no time or "
          "distance (m_overall = γ_man + γ_obj), as the paper's Table III scores an object it did not "
          "deliver (0%, ×). sr_obj counts an object when the robot delivered it in the command (a successful "
          "place) onto a target furniture, its category is one the command asks for (from the scene graph), and "
          "it did not stand on a target when the command began (no goal; a pick-and-put-back is no progress). "
          "Objects beyond the n-th (a replacement after a failure) add their costs to slot n and, when delivered, "
          "fill an earlier unfulfilled slot: a command counts min(n, distinct objects delivered).")
    doc.table(["planner", "missions", "m_overall / mission [CI]", "delivered", "delivered / mission [CI]",
               "cost / delivered [s]", "m_overall / object", "sr_obj", "cc / mission", "d [m] / mission",
               "t_exe [s] / mission", "sr_man", "LLM calls / mission", "tokens in / mission",
               "tokens out / mission"], rows)
    calls = metrics.get("llm_calls", {})
    if calls:
        doc.p("LLM calls that failed (an answer still unparseable after the repair retries, or a backend "
              "error; a stage stops above llm.max_failure_share): " + "; ".join(
                  f"{stage} stage {c.get('failed', 0)} of {c.get('calls', 0)}" for stage, c in sorted(calls.items()))
              + "; per planner in the missions stage: " + ", ".join(
                  f"{plots.label(p)} {pl[p].get('llm_failed_calls', 0)}" for p in ordered(pl)) + ".")
    imp = metrics.get("improvement", {})
    if imp:
        doc.table(["comparison", "pairs", "improvement % of baseline m_overall [CI]"],
                  [[k, str(v.get("n_pairs")), f"{fnum(v.get('pct'))} [{fnum(v.get('ci_lo'))}, {fnum(v.get('ci_hi'))}]"]
                   for k, v in sorted(imp.items())])
