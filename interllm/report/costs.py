"""The report's sections on what m_overall is made of and what the planners spend:

- ``gamma_obj_section``: mean m_overall per mission at each γ_obj of
  ``metrics.gamma_obj_sensitivity``, the paired differences and the break-even γ_obj;
- ``diversity_section``: the share of commands whose plan candidates take different objects;
- ``llm_usage_section``: the LLM requests and prompt tokens per command of each planner, by phase;
- ``manipulation_section``: the measured manipulation costs by placement attribute.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

from interllm.metrics.compute import read_csv
from interllm.metrics.deliveries import gamma_key
from interllm.report import plots
from interllm.report.document import Doc, ci, fnum, num_or_nan, ordered, pct
from interllm.report.headline import against_anchor, split_planners


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
    claimants, refs = split_planners({p: pl.get(p, {}) for p in s["planners"]})
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
        for k in sorted(comps, key=lambda k: (against_anchor(comps[k]), k)):
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


def manipulation_section(doc: Doc, summary: Mapping, attributes_csv: Path) -> None:
    """The measured manipulation costs: graded share, classes, sr_man per class, c_man per attribute."""
    if not summary:
        return
    doc.h(2, "Manipulation costs: what the planners can learn from")
    doc.p("Every executed pickup and place (N_l trials each; precondition failures excluded). sr_man = "
          "successes / N_l; c_man = γ_man (1 − sr_man) + t_man; class = f_en(c_man): easy < 5 ≤ medium ≤ 15 < hard. "
          "With γ_man = 100 any failed trial makes the action hard.")
    rows = []
    for name in ["all"] + ordered(k for k in summary if k != "all"):
        d = summary.get(name)
        if not d:
            continue
        rows.append([plots.label(name) if name != "all" else "all planners", str(d.get("n")),
                     pct(d.get("graded_share"))] + [pct(d.get(f"{c}_share")) for c in ("easy", "medium", "hard")])
    doc.table(["planner", "manipulations", "0 < sr_man < 1", "easy", "medium", "hard"], rows)
    d = summary.get("all", {})
    rows = []
    for c in ("easy", "medium", "hard"):
        e = d.get(c, {})
        hist = ", ".join(f"{k}: {v}" for k, v in e.get("sr_man_histogram", {}).items())
        rows.append([c, str(e.get("n")), fnum(e.get("sr_man_mean"), 2), fnum(e.get("c_man_mean")), hist or "–"])
    doc.table(["class", "n", "mean sr_man", "mean c_man", "sr_man: count"], rows)
    attrs = read_csv(attributes_csv) if attributes_csv.is_file() else []
    if attrs:
        doc.p("Pickups by the placement of their object (where the scene put it; the generator's label and the "
              "attributes the cost-inference prompts carry): mean c_man with its 95% CI.")
        doc.table(["attribute", "bin", "pickups", "c_man [CI]", "mean sr_man", "hard"],
                  [[str(r["attribute"]), str(r["bin"]), str(r["n"]),
                    f"{fnum(r['c_man'])} [{fnum(r['ci_lo'])}, {fnum(r['ci_hi'])}]", fnum(r["sr_man"], 2),
                    pct(r["hard_share"])] for r in attrs])
