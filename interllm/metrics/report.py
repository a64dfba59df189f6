"""The experiment report: ``report.md`` and a self-contained ``report.html`` (images inlined as
base64) built from the files the aggregate stage wrote (``metrics.json``, ``per_object.csv``,
``per_command.csv``, ``cumulative.csv``, ``per_object_summary.csv``, ``semantic_accuracy.csv``).

Contents: the headline table (objects delivered, m_overall, the position between doing nothing
and the ground-truth optimum, cost per delivered object; ``report_sections``), the paper's claims
with the delivery check, summary per planner, paired improvement, one sentence on whether the
paper's ordering (Inter-LLM lowest m_overall) holds, the γ_obj sensitivity, candidate diversity,
the paper's Table III layout with our means beside the paper's numbers, the cumulative
overall-metric figure, per-object bars, the path-similarity illustration, scene pictures, run MCAPs
with the replay command, Table II (semantic accuracy per temperature), the M ablation, the
cost-estimate variants, the oracle sweep and the cost encodings when multirun result folders are
given. The document model and cell formatters are in ``interllm.metrics.doc``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, Optional

from interllm.core.seeding import bootstrap_seed
from interllm.errors import MissingInputError
from interllm.io import atomic_write_text, read_json
from interllm.metrics import capability, claims, plots
from interllm.metrics import report_sections as sections
from interllm.metrics.compute import read_csv
from interllm.metrics.doc import Doc as _Doc
from interllm.metrics.doc import fnum as _f
from interllm.metrics.doc import num_or_nan as _num_or_nan
from interllm.metrics.doc import ordered as _ordered
from interllm.metrics.doc import pct as _pct
from interllm.metrics.doc import rel as _rel
from interllm.metrics.stats import LABELS, confusion_matrix, paired_improvement
from interllm.record.figures import mission_trajectories_figure

# Paper Table III ("Comprehensive metric results of algorithm comparison", Yang et al.,
# "Interleaved LLM and Motion Planning for Generalized Multi-Object Collection in Large Scene
# Graphs", §V-C; shared/paper/inter-llm.tex, table "table result_all_metrics"): one mission of
# three commands in ProcTHOR train_1, obj_1..obj_9. sr_man in [0, 1]; sr_obj: ✓ = 1, × = 0.
PAPER_TABLE_III: dict[str, dict[str, list[float]]] = {
    "cc": {"sayplan": [0, 1, 1, 1, 3, 0, 2, 0, 0],
           "moma_llm": [0, 1, 1, 1, 3, 4, 3, 0, 2],
           "inter_llm": [1, 0, 1, 1, 3, 0, 2, 0, 1]},
    "d": {"sayplan": [10.0, 28.0, 28.2, 31.0, 31.5, 11.0, 31.0, 8.0, 11.2],
          "moma_llm": [10.0, 28.0, 56.5, 31.0, 40.7, 71.5, 66.5, 8.0, 52.5],
          "inter_llm": [20.0, 15.0, 28.2, 31.0, 31.5, 11.0, 27.7, 8.0, 43.5]},
    "sr_man": {"sayplan": [0, 0, 0, 0.40, 0, 0, 0, 0.30, 0],
               "moma_llm": [0, 0, 0.10, 0.60, 0.20, 0.05, 0.06, 0.30, 0.04],
               "inter_llm": [0, 0, 0, 0.40, 0, 0, 0.40, 0.30, 0.30]},
    "t_exe": {"sayplan": [17.5, 35.2, 34.0, 34.0, 48.7, 71.2, 76.6, 17.8, 23.5],
              "moma_llm": [17.8, 34.9, 79.9, 27.6, 56.6, 183.0, 121.7, 18.5, 142.5],
              "inter_llm": [31.0, 20.1, 33.8, 34.5, 49.1, 71.8, 34.1, 18.2, 38.5]},
    "sr_obj": {"sayplan": [0, 0, 0, 1, 0, 0, 0, 1, 0],
               "moma_llm": [0, 0, 1, 1, 1, 1, 1, 1, 1],
               "inter_llm": [0, 0, 0, 1, 0, 0, 1, 1, 1]},
}
# Paper Table II (same paper, §V-B, table "table result_llm_temperature_parameter"): semantic
# similarity accuracy [%] per LLM temperature σ.
PAPER_TABLE_II: dict[float, float] = {0.0: 11.0, 0.2: 20.0, 0.4: 35.0, 0.6: 57.0, 0.8: 73.0, 1.0: 66.0}

TABLE_III_ROWS = (("cc", "Navigation Collision Counts"), ("d", "Navigated Distance (m)"),
                  ("sr_man", "Manipulation Success Rate"), ("t_exe", "Total Execution Time (s)"),
                  ("sr_obj", "Object Fulfillment Rate"))


# ---- sections ----------------------------------------------------------------------------------
def square_missions(per_command: Iterable[Mapping], n_commands: int = 3, n_objects: int = 3) -> set[tuple]:
    """(planner, scene, mission) of missions shaped like the paper's: n_commands commands of
    n_objects objects each."""
    by: dict[tuple, list[int]] = {}
    for r in per_command:
        by.setdefault((str(r["planner"]), str(r["scene"]), str(r["mission"])), []).append(int(r["n_objects"]))
    return {k for k, v in by.items() if len(v) == n_commands and all(n == n_objects for n in v)}


def table_iii(per_object: Iterable[Mapping], per_command: Iterable[Mapping]) -> dict[str, dict[str, list]]:
    """Our Table III: {metric: {planner: [mean over 3x3 missions of obj_1..obj_9]}} and the number
    of missions per planner under key "n"."""
    keep = square_missions(per_command)
    acc: dict[tuple[str, str, int], list[float]] = {}
    n: dict[str, set] = {}
    for r in per_object:
        key = (str(r["planner"]), str(r["scene"]), str(r["mission"]))
        if key not in keep:
            continue
        n.setdefault(key[0], set()).add(key)
        for m, _ in TABLE_III_ROWS:
            acc.setdefault((m, key[0], int(r["object_index"])), []).append(float(r[m]))
    out: dict[str, dict[str, list]] = {m: {} for m, _ in TABLE_III_ROWS}
    for m, _ in TABLE_III_ROWS:
        for p in n:
            out[m][p] = [(sum(acc[(m, p, i)]) / len(acc[(m, p, i)])) if (m, p, i) in acc else float("nan")
                         for i in range(1, 10)]
    out["n"] = {p: len(v) for p, v in n.items()}  # type: ignore[assignment]
    return out


def _cell(metric: str, v: float, paper: Optional[float]) -> str:
    """'ours (paper)': rates in %, collisions with 2 decimals (a mean), others with 1."""
    if metric in ("sr_man", "sr_obj"):
        ours = _pct(v)
    else:
        ours = _f(v, 2 if metric == "cc" else 1)
    if paper is None:
        return ours
    if metric == "sr_obj":
        pap = "✓" if paper >= 0.5 else "×"
    elif metric == "sr_man":
        pap = _pct(paper)
    else:
        pap = _f(paper, 0 if metric == "cc" else 1)
    return f"{ours} ({pap})"


def ordering_sentence(metrics: Mapping, reference: str = "inter_llm") -> str:
    """One sentence: does the paper's ordering (reference best on m_overall among the non-reference
    planners) hold? Judged as ``claims.ordering`` does: it holds when every paired improvement of
    the reference has its CI above 0 and it does not deliver significantly fewer objects, does not
    hold when one has its CI below 0 (or the lower m_overall came from delivering fewer objects),
    and otherwise the runs cannot tell (the mean rank alone decides nothing)."""
    refs = claims.references(metrics)
    pl = {p: d for p, d in metrics.get("planners", {}).items() if p not in refs}
    if reference not in pl or len(pl) < 2:
        return (f"The paper's ordering ({plots.label(reference)} best on m_overall) cannot be judged: "
                f"runs exist only for {sorted(pl)}.")
    ranked = sorted(pl, key=lambda p: (float("inf") if pl[p].get("m_overall") is None else pl[p]["m_overall"], p))
    figs = "; ".join(f"{plots.label(p)} {_f(pl[p].get('m_overall'))} [{_f(pl[p].get('m_overall_ci_lo'))}, "
                     f"{_f(pl[p].get('m_overall_ci_hi'))}]" for p in ranked)
    o = claims.ordering(metrics)
    imps = "; ".join(f"{plots.label(reference)} vs {plots.label(b)}: {_f(v[0])}% [{_f(v[1])}, {_f(v[2])}]"
                     for b, v in sorted(o["improvements"].items()))
    verdict = {"holds": "holds on our runs", "does not hold": "does not hold on our runs",
               claims.FEWER: "does not hold on our runs: its lower m_overall comes from delivering fewer objects",
               }.get(o["verdict"], "cannot be told on our runs (a paired CI includes 0 or has too few pairs)")
    best = "the lowest" if ranked[0] == reference else "not the lowest"
    return (f"The paper's ordering ({plots.label(reference)} best on m_overall per mission, judged by the paired "
            f"CIs and the delivery check) {verdict}; its mean is {best}: {figs} (mean per mission, "
            f"{len(pl)} planners, references aside; bootstrap CI)." + (f" Paired improvement: {imps}." if imps else ""))


def _gather(pairs: Sequence[tuple[str, str | os.PathLike]]) -> list[tuple[str, Path, dict]]:
    out = []
    for lab, d in pairs:
        p = Path(d) / "metrics.json"
        if p.is_file():
            out.append((str(lab), Path(d), read_json(p)))
    return out


def _claims_section(doc: _Doc, metrics: Mapping, metrics_dir: Path,
                    temperature_dirs: Sequence[Path], reference: str) -> None:
    """The paper's claims beside our figures, each with its CI, the paired delivered difference where
    the claim is about m_overall, and a verdict (``metrics.claims``; references are not claimants)."""
    ref = plots.label(reference)
    refs = claims.references(metrics)
    doc.h(2, "The paper's claims")
    rows = []
    o = claims.ordering(metrics)

    def delivered(b: str) -> str:
        v = o["deliveries"].get(b)
        return "–" if v is None else f"vs {plots.label(b)} {sections.ci(*v, nd=2, sign=True)}"

    figs = "; ".join(f"vs {plots.label(b)} {_f(p)}% [{_f(lo)}, {_f(hi)}]" for b, (p, lo, hi) in
                     sorted(o["improvements"].items()))
    dl = "; ".join(delivered(b) for b in sorted(o["improvements"]) if b in o["deliveries"])
    rows.append([f"{ref} has the lowest m_overall of the planners compared", figs or "–", dl or "–", o["verdict"]])
    for b, v in sorted(claims.improvement_30(metrics).items()):
        rows.append([f"{ref} improves m_overall by 30% over {plots.label(b)}",
                     f"{_f(v['pct'])}% [{_f(v['lo'])}, {_f(v['hi'])}]", delivered(b), v["verdict"]])
    per_command = read_csv(metrics_dir / "per_command.csv") if (metrics_dir / "per_command.csv").is_file() else []
    for b, v in sorted(claims.self_improvement(per_command, reference, exclude=refs).items()):
        rows.append([f"{ref} self-improves along the mission (vs {plots.label(b)}: gap of the last command minus "
                     f"the first, m_overall per object)", f"{_f(v['did'])} [{_f(v['lo'])}, {_f(v['hi'])}] "
                     f"({v['n']} missions)", "–", v["verdict"]])
    inf = []  # the sigma sweep's runs when there is one (same missions per sigma), else this run
    for d in [Path(x) for x in temperature_dirs if (Path(x) / "semantic_inferences.csv").is_file()] or [metrics_dir]:
        p = Path(d) / "semantic_inferences.csv"
        inf += read_csv(p) if p.is_file() else []
    s = claims.sigma_rise(inf, reference)
    rows.append(["Table II: semantic-similarity accuracy rises with σ (slope of accuracy when answered per unit σ)",
                 f"{_f(s['slope'], 3)} [{_f(s['lo'], 3)}, {_f(s['hi'], 3)}] ({s['n_sigma']} σ values)", "–",
                 s["verdict"]])
    doc.p("A claim about m_overall is judged together with the objects delivered: when the paired CI of the "
          f"delivered difference ({ref} − baseline, objects per mission) lies below 0, a lower m_overall was bought "
          "by delivering fewer objects and the claim does not hold.")
    doc.table(["claim", "ours [95% CI]", "delivered difference / mission [95% CI]", "verdict"], rows)
    per_mission = read_csv(metrics_dir / "per_mission.csv") if (metrics_dir / "per_mission.csv").is_file() else []
    need = claims.missions_needed(per_mission, reference, exclude=refs)
    if need:
        doc.p("Missions a paired 10% difference in m_overall needs at 80% power (α = 0.05, two-sided), from the "
              "measured spread of the per-mission differences: " + "; ".join(
                  f"vs {plots.label(b)} {v['n_needed']} (sd of the differences {_f(v['sd_diff'])}, "
                  f"{v['n_pairs']} pairs here)" for b, v in sorted(need.items())) + ".")


def _summary_section(doc: _Doc, metrics: Mapping, reference: str) -> None:
    """Every per-planner figure, objects delivered and the cost per delivered object beside m_overall;
    failed LLM calls; the paired improvements."""
    pl = metrics.get("planners", {})
    doc.h(2, "Summary per planner")
    doc.p(ordering_sentence(metrics, reference))
    rows = []
    for p in _ordered(pl):
        d = pl[p]
        rows.append([plots.label(p), str(d.get("n_missions")),
                     f"{_f(d.get('m_overall'))} [{_f(d.get('m_overall_ci_lo'))}, {_f(d.get('m_overall_ci_hi'))}]",
                     f"{d.get('delivered', d.get('n_fulfilled'))}/{d.get('n_objects')}",
                     sections.ci(d.get("delivered_per_mission"), d.get("delivered_per_mission_ci_lo"),
                                 d.get("delivered_per_mission_ci_hi"), 2),
                     _f(d.get("exec_cost_per_delivered")), _f(d.get("m_overall_per_object")),
                     _pct(d.get("sr_obj")), _f(d.get("cc"), 2), _f(d.get("d")), _f(d.get("t_exe")),
                     _pct(d.get("sr_man")), _f(d.get("llm_calls_per_mission")),
                     _f(d.get("llm_tokens_in_per_mission"), 0), _f(d.get("llm_tokens_out_per_mission"), 0)])
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
                  f"{plots.label(p)} {pl[p].get('llm_failed_calls', 0)}" for p in _ordered(pl)) + ".")
    imp = metrics.get("improvement", {})
    if imp:
        doc.table(["comparison", "pairs", "improvement % of baseline m_overall [CI]"],
                  [[k, str(v.get("n_pairs")), f"{_f(v.get('pct'))} [{_f(v.get('ci_lo'))}, {_f(v.get('ci_hi'))}]"]
                   for k, v in sorted(imp.items())])


def _paired(base_dir: Path, other_dir: Path, planner: str, label: str) -> tuple[int, float, float, float]:
    """(pairs, % reduction of ``planner``'s m_overall in ``other_dir`` against ``base_dir``, CI lo, hi),
    paired over the (scene, mission) both ran (per_mission.csv)."""
    def per_mission(d: Path) -> dict:
        return {(r["scene"], r["mission"]): float(r["m_overall"])
                for r in read_csv(d / "per_mission.csv") if r["planner"] == planner}

    base, other = per_mission(base_dir), per_mission(other_dir)
    keys = sorted(k for k in base if k in other)
    pct, lo, hi = paired_improvement([other[k] for k in keys], [base[k] for k in keys],
                                     seed=bootstrap_seed(0, label))
    return len(keys), pct, lo, hi


def _estimates_section(doc: _Doc, metrics_dir: Path, variants: Sequence[tuple[str, Path]], reference: str,
                       current: str) -> None:
    """Each cost-estimate variant's m_overall beside this run's (``planner.nav_estimate`` = ``current``),
    paired over the missions both ran, and which the default should be."""
    got = [(lab, d) for lab, d in variants if (d / "per_mission.csv").is_file() and lab != current]
    if not got:
        return
    doc.h(2, "Cost-estimate variants (planner.nav_estimate)")
    doc.p(f"{plots.label(reference)} with each variant on the same missions as this run ({current}; paper_sum is "
          f"the paper's equation); change = paired reduction of m_overall against {current} (positive: the "
          f"variant is cheaper), 95% bootstrap CI.")
    this = read_json(metrics_dir / "metrics.json")["planners"].get(reference, {})

    def row(lab: str, m: Mapping, change: str, n_pairs: str) -> list[str]:
        return [lab, n_pairs, f"{_f(m.get('m_overall'))} [{_f(m.get('m_overall_ci_lo'))}, {_f(m.get('m_overall_ci_hi'))}]",
                f"{m.get('n_fulfilled')}/{m.get('n_objects')}", _f(m.get("cc"), 2), change]

    rows, better, worse = [row(f"{current} (this run)", this, "–", "–")], [], []
    for lab, d in got:
        n_pairs, pct, lo, hi = _paired(metrics_dir, d, reference, f"estimate:{lab}")
        rows.append(row(lab, read_json(d / "metrics.json")["planners"].get(reference, {}),
                        f"{_f(pct)}% [{_f(lo)}, {_f(hi)}]", str(n_pairs)))
        if math.isfinite(lo) and lo > 0:
            better.append((lo, lab))
        elif math.isfinite(hi) and hi < 0:
            worse.append(lab)
    doc.table(["variant", "pairs", "m_overall / mission [CI]", "delivered", "cc / mission",
               f"reduction vs {current} [CI]"], rows)
    if better:
        doc.p(f"{max(better)[1]} improves on {current} (its paired CI lies above 0): it should be the default, with "
              f"the paper's form (paper_sum) one flag away.")
    elif len(worse) == len(got):
        doc.p(f"Every other variant costs more than {current} (their paired CIs lie below 0): {current} stays the "
              f"default, with the paper's form (paper_sum) one flag away.")
    else:
        doc.p(f"No variant's paired CI lies above 0, so none can be told better than {current}: it stays the default.")


def _manipulation_section(doc: _Doc, summary: Mapping, attributes_csv: Path) -> None:
    """The measured manipulation costs: graded share, classes, sr_man per class, c_man per attribute."""
    if not summary:
        return
    doc.h(2, "Manipulation costs: what the planners can learn from")
    doc.p("Every executed pickup and place (N_l trials each; precondition failures excluded). sr_man = "
          "successes / N_l; c_man = γ_man (1 − sr_man) + t_man; class = f_en(c_man): easy < 5 ≤ medium ≤ 15 < hard. "
          "With γ_man = 100 any failed trial makes the action hard.")
    rows = []
    for name in ["all"] + _ordered(k for k in summary if k != "all"):
        d = summary.get(name)
        if not d:
            continue
        rows.append([plots.label(name) if name != "all" else "all planners", str(d.get("n")),
                     _pct(d.get("graded_share"))] + [_pct(d.get(f"{c}_share")) for c in ("easy", "medium", "hard")])
    doc.table(["planner", "manipulations", "0 < sr_man < 1", "easy", "medium", "hard"], rows)
    d = summary.get("all", {})
    rows = []
    for c in ("easy", "medium", "hard"):
        e = d.get(c, {})
        hist = ", ".join(f"{k}: {v}" for k, v in e.get("sr_man_histogram", {}).items())
        rows.append([c, str(e.get("n")), _f(e.get("sr_man_mean"), 2), _f(e.get("c_man_mean")), hist or "–"])
    doc.table(["class", "n", "mean sr_man", "mean c_man", "sr_man: count"], rows)
    attrs = read_csv(attributes_csv) if attributes_csv.is_file() else []
    if attrs:
        doc.p("Pickups by the placement of their object (where the scene put it; the generator's label and the "
              "attributes the cost-inference prompts carry): mean c_man with its 95% bootstrap CI.")
        doc.table(["attribute", "bin", "pickups", "c_man [CI]", "mean sr_man", "hard"],
                  [[str(r["attribute"]), str(r["bin"]), str(r["n"]),
                    f"{_f(r['c_man'])} [{_f(r['ci_lo'])}, {_f(r['ci_hi'])}]", _f(r["sr_man"], 2),
                    _pct(r["hard_share"])] for r in attrs])


def _source_row(metrics: Mapping, reference: str) -> dict:
    """What the capability table and figure need of one run's metrics.json."""
    sem = [v for k, v in metrics.get("semantic_accuracy", {}).items() if k.startswith(f"{reference}@")]
    ans = metrics.get("answers", {})
    return {"source": metrics.get("settings", {}).get("source", "?"),
            "relevance": _num_or_nan(ans.get("relevance")), "target": _num_or_nan(ans.get("target")),
            "cost": _num_or_nan(sem[0].get("accuracy")) if sem else float("nan"),
            "planners": {p: tuple(_num_or_nan(d.get(k)) for k in ("m_overall", "m_overall_ci_lo", "m_overall_ci_hi"))
                         for p, d in metrics.get("planners", {}).items()},
            "delivered": {p: f"{d.get('n_fulfilled')}/{d.get('n_objects')}" for p, d in metrics.get("planners", {}).items()},
            "improvement": {k.split("_vs_", 1)[1]: tuple(_num_or_nan(v.get(x)) for x in ("pct", "ci_lo", "ci_hi"))
                            for k, v in metrics.get("improvement", {}).items() if k.startswith(f"{reference}_vs_")}}


def _paying_sentence(reference: str, baseline: str, sweep: Sequence[tuple[float, Mapping]]) -> str:
    """Where on the oracle axis the reference planner's paired improvement over ``baseline`` holds, and
    whether it grows with the quality of the answers (perfect oracle against random answers)."""
    nan3 = (math.nan,) * 3
    imp = {e: r["improvement"].get(baseline, nan3) for e, r in sweep}
    above, rest = capability.paying_errors([(e, v[1], v[2]) for e, v in imp.items()])
    best, worst = min(imp), max(imp)

    def errors(es) -> str:
        return ", ".join(format(e, "g") for e in es)

    text = (f"{plots.label(reference)} over {plots.label(baseline)}: the paired improvement's CI lies above 0 at "
            f"oracle error {errors(above) or 'none'}"
            + (f" and includes 0 at {errors(rest)}." if rest else " (every swept error)."))
    grows = not (above and worst in above)
    return text + (f" From the perfect oracle (error {best:g}) to the most random answers (error {worst:g}) it goes "
                   f"from {_f(imp[best][0])}% to {_f(imp[worst][0])}%: what {plots.label(reference)} gains over "
                   f"{plots.label(baseline)} " + ("depends on the answers." if grows else
                                                  "does not come from good answers."))


def _capability_section(doc: _Doc, metrics: Mapping, oracles: Sequence[tuple[float, Path]], fig_dir: Path,
                        reference: str, figures: list) -> None:
    """The oracle sweep beside this run's model: accuracies, m_overall and paired improvements per
    source, the model's place on the oracle-error axis, and how much error the look-ahead survives."""
    got = [(e, read_json(d / "metrics.json")) for e, d in oracles if (d / "metrics.json").is_file()]
    if not got:
        return
    model = _source_row(metrics, reference)
    sweep = [(e, _source_row(m, reference)) for e, m in got]
    planners = _ordered({p for _, r in sweep for p in r["planners"]} | set(model["planners"]))
    refs = claims.references(metrics) | {p for _, m in got for p in claims.references(m)}
    baselines = [p for p in planners if p != reference and p not in refs]
    doc.h(2, "LLM capability: the oracle sweep and this run's model")
    doc.p("The same missions with llm=oracle: object relevance and target furniture from each command's goal, "
          "cost classes from the simulator's measurement, with a share llm.oracle_error of the answers replaced "
          "by seeded random ones. Oracle runs are never averaged with model runs. Accuracies are measured "
          "against ground truth for every source: relevance = share of the objects the candidates take that the "
          "command asks for; target = share of candidates delivering to a furniture the command names; cost "
          f"class = {plots.label(reference)}'s inferred classes equal to the measured ones ('unknown' wrong). "
          "m_overall per mission and paired improvements with 95% bootstrap CIs.")
    def ci(v: tuple, unit: str = "") -> str:
        return f"{_f(v[0])}{unit} [{_f(v[1])}, {_f(v[2])}]"

    nan3 = (math.nan,) * 3
    rows = [[r["source"], _pct(r["relevance"]), _pct(r["target"]), _pct(r["cost"])]
            + [ci(r["planners"].get(p, nan3)) for p in planners]
            + [ci(r["improvement"].get(b, nan3), "%") for b in baselines] + [r["delivered"].get(reference, "–")]
            for r in [model] + [r for _, r in sweep]]
    doc.table(["input source", "relevance", "target", "cost class"] + [f"{plots.label(p)} m_overall [CI]" for p in planners]
              + [f"{plots.label(reference)} vs {plots.label(b)} [CI]" for b in baselines]
              + [f"{plots.label(reference)} delivered"], rows)
    where = {k: capability.equivalent_error(model[k], [(e, r[k]) for e, r in sweep]) for k in ("relevance", "cost")}
    sent = []
    for k, name in (("relevance", "object relevance"), ("cost", "cost classes")):
        e = where[k]
        worst = max(e for e, _ in sweep)
        sent.append(f"its accuracy on {name} ({_pct(model[k])}) is that of an oracle with error {e:.2f}" if e is not None
                    else f"its accuracy on {name} ({_pct(model[k])}) lies outside the swept oracles' range "
                    f"({'worse than error ' + format(worst, 'g') if model[k] < min(r[k] for _, r in sweep) else 'better than the best oracle swept'})")
    doc.p(f"On this axis, {model['source']} sits where " + "; ".join(sent) + ".")
    for b in baselines:
        doc.p(_paying_sentence(reference, b, sweep))
    f = plots.capability_figure(sweep, model, where, planners, reference, fig_dir / "capability.png")
    figures.append(f)
    doc.img(f, "m_overall and paired improvements against oracle error; the model at its equivalent error")


def build_report(metrics_dir: str | os.PathLike, scenes_dir: str | os.PathLike, runs_dir: str | os.PathLike,
                 out_dir: str | os.PathLike, cfg: Any = None,
                 temperature_results: Sequence[tuple[str, str | os.PathLike]] = (),
                 m_results: Sequence[tuple[str, str | os.PathLike]] = (),
                 reference: str = "inter_llm",
                 estimate_results: Sequence[tuple[str, str | os.PathLike]] = (),
                 oracle_results: Sequence[tuple[float, str | os.PathLike]] = (),
                 encoding_results: Sequence[tuple[str, str, str | os.PathLike]] = ()) -> dict[str, Path]:
    """Write ``out_dir/report.md``, ``out_dir/report.html`` and ``out_dir/figures/*.png``.

    metrics_dir: output of ``aggregate``; scenes_dir: ``data/scenes`` (topdown.png pictures);
    runs_dir: ``data/runs`` (MCAP links); cfg: ExperimentConfig or None (ε of the path-similarity
    figure = ``cfg.planner.epsilon_d``); temperature_results / m_results: (label, metrics_dir)
    pairs of other runs (labels like "0.2" / "M=3"); folders without metrics.json are skipped;
    oracle_results: (llm.oracle_error, metrics_dir) pairs of an oracle sweep on the same missions;
    encoding_results: (group, variant, metrics_dir) of runs differing only in llm.oracle_costs and/or
    planner.cost_encoding (``report_sections.encoding_section``).
    Returns {"markdown", "html", "figures"} paths.
    """
    metrics_dir, out_dir = Path(metrics_dir), Path(out_dir)
    mpath = metrics_dir / "metrics.json"
    if not mpath.is_file():
        raise MissingInputError(f"{mpath} is missing; run the 'aggregate' stage (interllm.metrics.aggregate) "
                                f"first or pass the folder holding metrics.json")
    metrics = read_json(mpath)
    per_object = read_csv(metrics_dir / "per_object.csv")
    per_command = read_csv(metrics_dir / "per_command.csv")
    cumulative = read_csv(metrics_dir / "cumulative.csv")
    summary = read_csv(metrics_dir / "per_object_summary.csv")
    fig_dir = out_dir / "figures"
    doc = _Doc()
    s = metrics.get("settings", {})
    doc.h(1, "Inter-LLM experiment report")
    doc.p(f"Input source: **{s.get('source', '?')}**. {s.get('n_runs', '?')} mission runs; γ_nav = {s.get('gamma_nav')}, γ_man = {s.get('gamma_man')}, "
          f"γ_obj = {s.get('gamma_obj')}; LLM temperature {s.get('temperature')}; "
          f"{int(100 * float(s.get('ci', 0.95)))}% percentile bootstrap CIs with B = "
          f"{s.get('bootstrap_samples')} (seed {s.get('seed')}). All times are simulated seconds.")

    sections.headline_section(doc, metrics, Path(scenes_dir), sorted({str(r["scene"]) for r in per_object}),
                              reference)
    _claims_section(doc, metrics, metrics_dir, [Path(d) for _, d in temperature_results], reference)
    _summary_section(doc, metrics, reference)
    sections.gamma_obj_section(doc, metrics, reference)
    sections.diversity_section(doc, metrics)
    if (metrics_dir / "llm_usage.json").is_file():
        sections.llm_usage_section(doc, read_json(metrics_dir / "llm_usage.json"))

    # Table III
    doc.h(2, "Table III: per-object metrics (ours, paper in parentheses)")
    t3 = table_iii(per_object, per_command)
    ns = t3.pop("n")
    if ns:
        doc.p("Mean over our missions shaped like the paper's (3 commands x 3 objects): "
              + ", ".join(f"{plots.label(p)} {n}" for p, n in sorted(ns.items()))
              + " missions. The paper's numbers are one mission in ProcTHOR train_1. sr_obj: ours = share "
                "of missions fulfilling the object; paper ✓/×.")
        rows = []
        for m, name in TABLE_III_ROWS:
            for p in _ordered(set(t3[m]) | set(PAPER_TABLE_III[m])):
                ours = t3[m].get(p, [float("nan")] * 9)
                paper = PAPER_TABLE_III[m].get(p)
                rows.append([name, plots.label(p)] + [_cell(m, ours[i], None if paper is None else paper[i])
                                                      for i in range(9)])
        doc.table(["metric", "algorithm"] + [f"obj_{i}" for i in range(1, 10)], rows,
                  group=[("", 2), ("command_1", 3), ("command_2", 3), ("command_3", 3)])
    else:
        doc.p("No run is shaped like the paper's mission (3 commands x 3 objects): Table III is left out.")

    _manipulation_section(doc, metrics.get("manipulation", {}), metrics_dir / "manipulation_attributes.csv")

    # figures
    figures: list[Path] = []
    doc.h(2, "Overall metric along the mission")
    f = plots.cumulative_figure(cumulative, fig_dir / "cumulative_m_overall.png")
    figures.append(f)
    doc.img(f, "Cumulative m_overall per object index (mean over missions, bootstrap CI band)")
    doc.h(2, "Per-object metrics")
    max_idx = 9 if any(int(r["object_index"]) > 9 for r in summary) else None
    for metric, ylab in (("m_overall", "m_overall"), ("t_exe", "t_exe [s]"), ("cc", "collisions"),
                         ("sr_obj", "sr_obj")):
        f = plots.per_object_bars(summary, metric, fig_dir / f"per_object_{metric}.png", ylab, max_idx)
        figures.append(f)
        doc.img(f, f"{ylab} per object (mean, bootstrap CI)")
    doc.h(2, "Path similarity P°")
    eps = float(cfg.planner.epsilon_d) if cfg is not None else 1.0
    f, note = plots.path_similarity_figure(fig_dir / "path_similarity.png", eps)
    if f is not None:
        figures.append(f)
        doc.img(f, "Three synthetic path pairs and their P°")
    doc.p(note)

    # scenes and runs
    scenes = sorted({str(r["scene"]) for r in per_object})
    pics = [(sid, Path(scenes_dir) / sid / "topdown.png") for sid in scenes]
    pics = [(sid, p) for sid, p in pics if p.is_file()]
    doc.h(2, "Scenes")
    if pics:
        for sid, p in pics:
            doc.img(p, f"scene {sid} (top-down)")
    else:
        doc.p(f"No topdown.png under {scenes_dir} for scenes {scenes}.")
    doc.h(2, "Trajectories")
    shown = 0
    for sid in scenes:
        by_mission: dict[str, dict[str, Path]] = {}
        for m in sorted(Path(runs_dir).glob(f"*/{sid}/*.mcap")) if Path(runs_dir).is_dir() else []:
            by_mission.setdefault(m.stem, {})[m.parent.parent.name] = m
        if not by_mission:
            continue
        mission, runs = sorted(by_mission.items())[0]
        try:
            f = mission_trajectories_figure({p: runs[p] for p in _ordered(runs)},
                                            fig_dir / f"trajectories_{sid}_{mission}.png",
                                            colors={p: plots.color(p) for p in runs if plots.color(p)})
        except (ValueError, OSError) as e:  # an unreadable log must not sink the report
            doc.p(f"Could not draw the trajectories of {sid} {mission}: {e}")
            continue
        figures.append(f)
        doc.img(f, f"{sid} {mission}: where each planner drove (from the run logs)")
        shown += 1
    if not shown:
        doc.p(f"No .mcap run logs under {runs_dir} to draw trajectories from.")
    doc.h(2, "Run logs (MCAP)")
    mcaps = sorted(Path(runs_dir).glob("**/*.mcap")) if Path(runs_dir).is_dir() else []
    if mcaps:
        doc.p("Replay any run in rerun with `interllm replay <file>`, or open it in Foxglove Studio:")
        doc.links([(Path(m).relative_to(runs_dir).as_posix(), _rel(m, out_dir)) for m in mcaps])
        doc.code(f"interllm replay {Path(mcaps[0]).as_posix()}")
    else:
        doc.p(f"No .mcap run logs found under {runs_dir}.")

    # Table II
    doc.h(2, "Table II: semantic-similarity accuracy per temperature")
    sem_rows = []
    others = [(lab, d) for lab, d in temperature_results if Path(d).resolve() != metrics_dir.resolve()]
    for lab, d, _ in _gather([("this run", metrics_dir)] + others):
        p = d / "semantic_accuracy.csv"
        for r in (read_csv(p) if p.is_file() else []):
            t = r["temperature"]
            paper = PAPER_TABLE_II.get(round(float(t), 1)) if t != "" else None
            sem_rows.append((float(t) if t != "" else -1.0, lab, [
                _f(t, 1), lab, plots.label(str(r["planner"])), str(r["n_judged"]),
                f"{_pct(r['accuracy'])} [{_pct(r.get('accuracy_ci_lo'))}, {_pct(r.get('accuracy_ci_hi'))}]",
                _pct(r.get("coverage")),
                f"{_pct(r['accuracy_known'])} [{_pct(r.get('accuracy_known_ci_lo'))}, "
                f"{_pct(r.get('accuracy_known_ci_hi'))}]",
                f"{_pct(r.get('chance'))} / {_pct(r.get('majority'))}", str(r.get("verdict", "–")),
                "–" if paper is None else f"{paper:.0f}%",
                f"{_pct(r.get('truth_agreement'))} of {r.get('n_executed', '–')}"]))
    if sem_rows:
        rows = [row for _, _, row in sorted(sem_rows, key=lambda x: (x[0], x[1]))]
        doc.p("Prediction = class the LLM inferred for a manipulation action; truth = f_en of the cost the "
              "simulator measured for the same action, by the same N_l-trial protocol, in a scratch copy of the "
              "scene as it was when the inference was made (the mission is untouched), so every inference is "
              "judged, whether or not its action ran. Accuracy counts 'unknown' as wrong; coverage = share "
              "answered; accuracy when answered is compared with chance (1/3 over easy / medium / hard) and "
              "the majority class (always the commonest true class); the verdict says whether its 95% "
              "bootstrap CI lies above both. The last column checks the measurement: of the judged "
              "inferences whose action also ran later, the share whose executed class equals the measured one.")
        doc.table(["temperature σ", "results", "planner", "inferences judged", "accuracy [CI]", "coverage",
                   "accuracy when answered [CI]", "chance / majority", "verdict", "paper accuracy",
                   "measured = executed class"], rows)
        conf = confusion_matrix(read_csv(metrics_dir / "semantic_inferences.csv")
                                if (metrics_dir / "semantic_inferences.csv").is_file() else [])
        if any(sum(v.values()) for v in conf.values()):
            doc.p("Confusion matrix of this run's judged inferences (rows: measured class; columns: inferred):")
            doc.table(["measured \\ inferred"] + list(LABELS),
                      [[t] + [str(conf[t][p]) for p in LABELS] for t in conf])
    else:
        doc.p("No cost inferences were recorded (only Inter-LLM infers manipulation costs).")

    # M ablation
    got = _gather(m_results)
    if got:
        doc.h(2, "Ablation over M (plan candidates)")
        base_lab, base_dir = next(((lab, d) for lab, d, _ in got if lab == "M=3"), (got[0][0], got[0][1]))
        doc.p(f"Paired against {base_lab} on the same missions: reduction of m_overall, 95% bootstrap CI.")
        rows = []
        for lab, d_dir, mj in got:
            d = mj.get("planners", {}).get(reference, {})
            n_pairs, pct, lo, hi = _paired(base_dir, d_dir, reference, f"M:{lab}")
            rows.append([lab, f"{_f(d.get('m_overall'))} [{_f(d.get('m_overall_ci_lo'))}, "
                              f"{_f(d.get('m_overall_ci_hi'))}]", f"{d.get('n_fulfilled')}/{d.get('n_objects')}",
                         "–" if lab == base_lab else f"{_f(pct)}% [{_f(lo)}, {_f(hi)}] ({n_pairs} pairs)",
                         _f(d.get("llm_calls_per_mission")),
                         _f(d.get("llm_tokens_in_per_mission"), 0), _f(d.get("llm_tokens_out_per_mission"), 0)])
        doc.table(["M", f"{plots.label(reference)} m_overall / mission [CI]", "delivered", f"reduction vs {base_lab} [CI]",
                   "LLM calls / mission", "tokens in / mission", "tokens out / mission"], rows)

    _estimates_section(doc, metrics_dir, [(lab, Path(d)) for lab, d in estimate_results], reference,
                       cfg.planner.nav_estimate if cfg is not None else "this run's estimate")
    _capability_section(doc, metrics, [(float(e), Path(d)) for e, d in oracle_results], fig_dir, reference, figures)
    sections.encoding_section(doc, [(g, v, Path(d)) for g, v, d in encoding_results], metrics, reference)

    out_dir.mkdir(parents=True, exist_ok=True)
    md, ht = out_dir / "report.md", out_dir / "report.html"
    atomic_write_text(md, doc.markdown(out_dir))
    atomic_write_text(ht, doc.html("Inter-LLM experiment report"))
    return {"markdown": md, "html": ht, "figures": figures}  # type: ignore[dict-item]
