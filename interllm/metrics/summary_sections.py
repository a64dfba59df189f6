"""The report's sections on this run's figures besides the deliveries: the paper's claims with their
verdicts (``claims``), the summary per planner with the ordering sentence, and the measured
manipulation costs."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

from interllm.metrics import claims, plots
from interllm.metrics.compute import read_csv
from interllm.metrics.doc import Doc, ci, fnum, num_or_nan, ordered, pct
from interllm.metrics.stats import interval_method


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
            f"{len(pl)} planners, anchors aside; bootstrap CI)." + (f" Paired improvement: {imps}." if imps else ""))


def claims_section(doc: Doc, metrics: Mapping, metrics_dir: Path,
                   temperature_dirs: Sequence[Path], judge: str) -> None:
    """The paper's claims beside our figures, each with its CI, the paired delivered difference where
    the claim is about m_overall, and a verdict (``metrics.claims``; anchors are not claimants)."""
    ref = plots.label(judge)
    refs = claims.set_aside(metrics)
    doc.h(2, "The paper's claims")
    rows = []
    o = claims.ordering(metrics)

    def delivered(b: str) -> str:
        v = o["deliveries"].get(b)
        return "–" if v is None else f"vs {plots.label(b)} {ci(*v, nd=2, sign=True)}"

    figs = "; ".join(f"vs {plots.label(b)} {fnum(p)}% [{fnum(lo)}, {fnum(hi)}]" for b, (p, lo, hi) in
                     sorted(o["improvements"].items()))
    dl = "; ".join(delivered(b) for b in sorted(o["improvements"]) if b in o["deliveries"])
    rows.append([f"{ref} has the lowest m_overall of the planners compared", figs or "–", dl or "–", o["verdict"]])
    for b, v in sorted(claims.improvement_30(metrics).items()):
        rows.append([f"{ref} improves m_overall by 30% over {plots.label(b)}",
                     f"{fnum(v['pct'])}% [{fnum(v['lo'])}, {fnum(v['hi'])}]", delivered(b), v["verdict"]])
    per_command = read_csv(metrics_dir / "per_command.csv") if (metrics_dir / "per_command.csv").is_file() else []
    # the no-learning variant is the baseline that isolates learning: only the anchors are left out here
    for b, v in sorted(claims.self_improvement(per_command, judge, exclude=claims.anchors(metrics),
                                                           method=interval_method(metrics)).items()):
        rows.append([f"{ref} self-improves along the mission (vs {plots.label(b)}: gap of the last command minus "
                     f"the first, m_overall per object)", f"{fnum(v['did'])} [{fnum(v['lo'])}, {fnum(v['hi'])}] "
                     f"({v['n']} missions)", "–", v["verdict"]])
    for key, v in sorted(metrics.get("semantic_accuracy", {}).items()):
        if key.startswith(f"{judge}@"):
            rows.append([f"Table II: {ref}'s cost classes are right more often than a guess (σ = {key.split('@', 1)[1]}; "
                         "accuracy when answered [%] against chance and the majority class)",
                         f"{pct_ci(v, 'accuracy_known')} ({v.get('n_judged')} inferences judged)",
                         f"chance {fnum(100 * num_or_nan(v.get('chance')))}%, majority "
                         f"{fnum(100 * num_or_nan(v.get('majority')))}%", v.get("verdict", "cannot tell")])
    inf = []  # the sigma sweep's runs when there is one (same missions per sigma), else this run
    for d in [Path(x) for x in temperature_dirs if (Path(x) / "semantic_inferences.csv").is_file()] or [metrics_dir]:
        p = Path(d) / "semantic_inferences.csv"
        inf += read_csv(p) if p.is_file() else []
    s = claims.sigma_rise(inf, judge)
    rows.append(["Table II: semantic-similarity accuracy rises with σ (slope of accuracy when answered per unit σ)",
                 f"{fnum(s['slope'], 3)} [{fnum(s['lo'], 3)}, {fnum(s['hi'], 3)}] ({s['n_sigma']} σ values)", "–",
                 s["verdict"]])
    doc.p("A claim about m_overall is judged together with the objects delivered: when the paired CI of the "
          f"delivered difference ({ref} − baseline, objects per mission) lies below 0, a lower m_overall was bought "
          "by delivering fewer objects and the claim does not hold.")
    doc.table(["claim", "ours [95% CI]", "delivered difference / mission [95% CI]", "verdict"], rows)
    per_mission = read_csv(metrics_dir / "per_mission.csv") if (metrics_dir / "per_mission.csv").is_file() else []
    need = claims.houses_needed(per_mission, judge, exclude=refs)
    if need:
        doc.p("Houses a paired 10% difference in m_overall needs at 80% power (α = 0.05, two-sided), at the "
              "runs' missions per house, from the measured spread of the per-mission differences between "
              "houses and within them (a design effect: missions in one house are not independent): " + "; ".join(
                  f"vs {plots.label(b)} {houses_text(v)}" for b, v in sorted(need.items())) + ".")


def houses_text(v: Mapping) -> str:
    """One baseline's power figures (``claims.houses_needed``) as a phrase."""
    here = f"{v['n_houses']} houses × {fnum(v['missions_per_house'], 1)} missions here"
    if not math.isfinite(num_or_nan(v["houses_needed"])):
        return f"cannot be estimated from one house ({here})"
    return (f"{v['houses_needed']} houses ({v['missions_needed']} missions; sd between houses "
            f"{fnum(v['sd_between'])}, within {fnum(v['sd_within'])}; {here})")


def pct_ci(v: Mapping, key: str) -> str:
    """``v[key]`` with its CI (``key``_ci_lo / _hi) as percentages."""
    return ci(*(100 * num_or_nan(v.get(k)) for k in (key, f"{key}_ci_lo", f"{key}_ci_hi")), nd=1)


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
              "attributes the cost-inference prompts carry): mean c_man with its 95% bootstrap CI.")
        doc.table(["attribute", "bin", "pickups", "c_man [CI]", "mean sr_man", "hard"],
                  [[str(r["attribute"]), str(r["bin"]), str(r["n"]),
                    f"{fnum(r['c_man'])} [{fnum(r['ci_lo'])}, {fnum(r['ci_hi'])}]", fnum(r["sr_man"], 2),
                    pct(r["hard_share"])] for r in attrs])
