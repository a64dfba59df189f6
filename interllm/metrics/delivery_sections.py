"""The report's delivery sections, from metrics.json (``interllm.metrics.deliveries``):

- ``headline_section``: the first table of the report: per planner objects delivered [CI],
  m_overall [CI], the normalised position between the anchors, doing nothing (0) and the optimal
  reference (1) [CI], whether m_overall lies significantly below doing nothing's, and the execution cost
  per delivered object; the paired differences between the planners; the slots the scenes
  stage measured as deliverable (``feasibility.json``);
- ``gamma_obj_section``: mean m_overall per mission at each γ_obj of
  ``metrics.gamma_obj_sensitivity``, the paired differences and the break-even γ_obj;
- ``diversity_section``: the share of commands whose plan candidates take different objects;
- ``llm_usage_section``: the LLM requests and prompt tokens per command of each planner, by phase.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Optional

from interllm.io import read_json
from interllm.metrics import plots
from interllm.metrics.deliveries import NOTHING, OPTIMAL, gamma_key
from interllm.metrics.doc import Doc, ci, fnum, num_or_nan, ordered, pct


def _split(planners: Mapping[str, Mapping]) -> tuple[list[str], list[str]]:
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


def _against_anchor(comparison: Mapping) -> bool:
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
    claimants, refs = _split(pl)
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
          "nothing). Cost per delivered = Σ(γ_nav·cc + t_exe + d) / delivered [s per object]. 95% bootstrap CIs "
          "(paired ones resample the missions jointly). The anchors (doing nothing, the optimal reference) are "
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
        for k in sorted(comps, key=lambda k: (_against_anchor(comps[k]), k)):
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


# ---- γ_obj -----------------------------------------------------------------------------------
def break_even_text(c: Mapping, judge: str) -> str:
    """"γ_obj = 154: Inter-LLM cheaper above it" or "never: ... at every γ_obj ≥ 0"."""
    ref, b = plots.label(judge), plots.label(str(c.get("baseline")))
    be = c.get("break_even")
    if be is None:
        de = num_or_nan(c.get("exec_diff"))
        if math.isnan(de):
            return "–"
        who = ref if de < 0 else b if de > 0 else None
        return "never" + (f" ({who} cheaper at every γ_obj ≥ 0)" if who else " (equal at every γ_obj)")
    above = c.get("judged_lower_above", c.get("reference_lower_above"))
    return (f"{fnum(be)}: {ref} cheaper " + ("above" if above else "below") + f" it, {b} "
            + ("below" if above else "above"))


def gamma_obj_section(doc: Doc, metrics: Mapping, judge: str) -> None:
    """Each planner's mean m_overall per mission at each γ_obj, the paired differences and break-evens."""
    s = metrics.get("gamma_obj_sensitivity", {})
    gs = s.get("gammas") or []
    if not gs or not s.get("planners"):
        return
    pl = metrics.get("planners", {})
    cur = metrics.get("settings", {}).get("gamma_obj")
    doc.h(2, "Sensitivity to γ_obj")
    doc.p("m_overall is linear in γ_obj: per mission m(γ) = E + γ·U with E = Σ_slots γ_nav·cc + t_exe + d + "
          "γ_man·(1 − sr_man) [s] and U the undelivered slots, recomputed here from the per-slot rows (this run "
          f"uses γ_obj = {fnum(cur, 0)}). Mean m_overall per mission [s]:")
    header = ["planner", "E [s]", "U [slots]"] + [f"γ_obj = {gamma_key(g)}" for g in gs]
    rows = []
    claimants, refs = _split({p: pl.get(p, {}) for p in s["planners"]})
    for p in claimants + refs:
        d = s["planners"][p]
        rows.append([plots.label(p), fnum(d.get("exec")), fnum(d.get("undelivered"), 2)]
                    + [fnum(d.get("m_overall", {}).get(gamma_key(g))) for g in gs])
    doc.table(header, rows)
    comps = s.get("comparisons", {})
    if comps:
        doc.p(f"Paired difference {plots.label(judge)} − other per mission at each γ_obj [CI] (negative: "
              f"{plots.label(judge)} cheaper) and the break-even γ_obj where the mean difference "
              "Δ(γ) = Δ_E + γ·Δ_U crosses 0 (\"never\" when it does not for γ_obj ≥ 0):")
        crow = []
        for k in sorted(comps, key=lambda k: (_against_anchor(comps[k]), k)):
            c = comps[k]
            by = c.get("by_gamma", {})
            crow.append([f"{plots.label(judge)} − {plots.label(str(c.get('baseline')))}", str(c.get("n_pairs")),
                         f"{fnum(c.get('exec_diff'))} + γ·({fnum(c.get('undelivered_diff'), 2)})"]
                        + [ci(by.get(gamma_key(g), {}).get("diff"), by.get(gamma_key(g), {}).get("ci_lo"),
                              by.get(gamma_key(g), {}).get("ci_hi"), sign=True) for g in gs]
                        + [break_even_text(c, judge)])
        doc.table(["comparison", "pairs", "Δ(γ) = Δ_E + γ·Δ_U"] + [f"γ_obj = {gamma_key(g)}" for g in gs]
                  + ["break-even γ_obj"], crow)


# ---- candidate diversity ---------------------------------------------------------------------
def diversity_section(doc: Doc, metrics: Mapping) -> None:
    """The share of commands whose candidates take different objects, per planner with candidates."""
    div = metrics.get("candidate_diversity", {})
    if not div:
        return
    doc.h(2, "Candidate diversity")
    doc.p("Commands with plan candidates, and the share whose candidates take different objects (at least two "
          "distinct sets of picked-up objects among them): choosing between candidates can only change what is "
          "delivered when they differ.")
    doc.table(["planner", "commands with candidates", "candidates / command", "with different objects", "share"],
              [[plots.label(p), str(d.get("n_commands")), fnum(d.get("candidates_per_command"), 2),
                str(d.get("n_diverse")), pct(d.get("share"))] for p, d in ((p, div[p]) for p in ordered(div))])


def llm_usage_section(doc: Doc, usage: Mapping) -> None:
    """The LLM requests and prompt tokens per command of each planner, by phase (``metrics.llm_usage``),
    and in generate mode the room selections and the share of commands whose selection was widened."""
    runs = usage.get("missions", {})
    if not runs:
        return
    doc.h(2, "LLM requests per command, by phase")
    doc.p("Every request the missions stage made (answered from the cache or not), per command the planner ran: "
          "requests / prompt tokens. A room selection (generate mode) counts in the phase of the plan request it "
          "serves; the selection columns say how many there were and the share of commands whose selection had "
          "to be widened (data/metrics/llm_usage.json).")
    phases = ("proposal", "repair", "replan", "cost_inference")
    rows = []
    for p in ordered(runs):
        u, sel = runs[p], runs[p].get("room_selection", {})
        cells = []
        for ph in phases:
            d = u.get("phases", {}).get(ph, {}).get("per_command")
            cells.append("–" if d is None else f"{fnum(d['requests'], 2)} / {fnum(d['tokens_in'], 0)}")
        rows.append([plots.label(p), str(u.get("commands")), *cells,
                     f"{fnum(u['per_command']['requests'], 2)} / {fnum(u['per_command']['tokens_in'], 0)}",
                     fnum(u["per_command"].get("selection_requests"), 2), pct(sel.get("widened_share"))])
    doc.table(["planner", "commands", *phases, "all", "room selections / command", "widened"], rows)
