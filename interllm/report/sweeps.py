"""The report's sections on multirun results beside this run: the M ablation, the cost-estimate
variants, the oracle sweep with this run's model on its error axis, and the cost encodings. Each
pairs the runs over the missions both ran (per_mission.csv) with house-clustered CIs.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Optional

from interllm.core.seeding import bootstrap_seed
from interllm.errors import UserError
from interllm.io import read_json
from interllm.metrics import capability, claims
from interllm.metrics.compute import read_csv
from interllm.metrics.deliveries import paired_runs
from interllm.metrics.stats import houses_of, interval_method, paired_improvement
from interllm.report import plots
from interllm.report.document import Doc, ci, fnum, num_or_nan, ordered, pct

ENCODING_KEYS = ("llm.oracle_costs", "planner.inter_llm.cost_encoding")
ENCODING_DEFAULTS = ("classes", "paper")  # the paper's: three cost classes, the paper's text encoding


def encoding_label(oracle_costs: str, cost_encoding: str) -> str:
    """The label of one encoding variant ("oracle_costs=classes, cost_encoding=paper")."""
    return f"oracle_costs={oracle_costs}, cost_encoding={cost_encoding}"


BASE_ENCODING = encoding_label(*ENCODING_DEFAULTS)


def with_metrics(pairs: Sequence[tuple[str, str | os.PathLike]]) -> list[tuple[str, Path, dict]]:
    """(label, metrics_dir, its metrics.json) of the (label, metrics_dir) pairs whose folder holds one."""
    out = []
    for lab, d in pairs:
        p = Path(d) / "metrics.json"
        if p.is_file():
            out.append((str(lab), Path(d), read_json(p)))
    return out


def benchmark_name(metrics: Mapping) -> str:
    """The frozen benchmark a run's metrics.json names ("" before benchmarks were recorded)."""
    return str(metrics.get("benchmark", {}).get("name", ""))


def check_one_benchmark(metrics: Mapping, source: str | os.PathLike, dirs: Sequence[str | os.PathLike]) -> None:
    """Refuse sweep runs of another benchmark than the report's run (``source``'s metrics): the
    sections pair runs by scene and mission id, which benchmark versions share (paper-v2 and
    paper-v3 name their houses alike), so a mix would pair different missions."""
    want = benchmark_name(metrics)
    odd = [(str(d), benchmark_name(m)) for _, d, m in with_metrics([("", d) for d in dirs])
           if benchmark_name(m) != want]
    if odd:
        listed = "; ".join(f"{d} ({name or 'no benchmark recorded'})" for d, name in odd)
        raise UserError(f"report: {source} is a run of benchmark {want or '(none recorded)'!r}, but sweep run(s) "
                        f"{listed} are not: the report pairs runs by scene and mission id, so every run must be of "
                        f"the same benchmark. Re-make those runs (make sweeps) or leave them out of --sweeps.")


def paired_reduction(base_dir: Path, other_dir: Path, planner: str, label: str) -> tuple[int, float, float, float]:
    """(pairs, % reduction of ``planner``'s m_overall in ``other_dir`` against ``base_dir``, CI lo, hi),
    paired over the (scene, mission) both ran (per_mission.csv)."""
    def per_mission(d: Path) -> dict:
        return {(r["scene"], r["mission"]): float(r["m_overall"])
                for r in read_csv(d / "per_mission.csv") if r["planner"] == planner}

    base, other = per_mission(base_dir), per_mission(other_dir)
    keys = sorted(k for k in base if k in other)
    change, lo, hi = paired_improvement([other[k] for k in keys], [base[k] for k in keys],
                                        seed=bootstrap_seed(0, label), clusters=houses_of(keys))
    return len(keys), change, lo, hi


def m_ablation_section(doc: Doc, m_results: Sequence[tuple[str, str | os.PathLike]], judge: str) -> None:
    """``judge``'s m_overall per M (``m_results``: (label "M=3", metrics_dir) pairs), each paired
    against M=3 (else the first) on the same missions."""
    got = with_metrics(m_results)
    if not got:
        return
    doc.h(2, "Ablation over M (plan candidates)")
    base_lab, base_dir = next(((lab, d) for lab, d, _ in got if lab == "M=3"), (got[0][0], got[0][1]))
    doc.p(f"Paired against {base_lab} on the same missions: reduction of m_overall, 95% house-clustered CI.")
    rows = []
    for lab, d_dir, mj in got:
        d = mj.get("planners", {}).get(judge, {})
        n_pairs, change, lo, hi = paired_reduction(base_dir, d_dir, judge, f"M:{lab}")
        rows.append([lab, f"{fnum(d.get('m_overall'))} [{fnum(d.get('m_overall_ci_lo'))}, "
                          f"{fnum(d.get('m_overall_ci_hi'))}]", f"{d.get('n_fulfilled')}/{d.get('n_objects')}",
                     "–" if lab == base_lab else f"{fnum(change)}% [{fnum(lo)}, {fnum(hi)}] ({n_pairs} pairs)",
                     fnum(d.get("llm_calls_per_mission")),
                     fnum(d.get("llm_tokens_in_per_mission"), 0), fnum(d.get("llm_tokens_out_per_mission"), 0)])
    doc.table(["M", f"{plots.label(judge)} m_overall / mission [CI]", "delivered", f"reduction vs {base_lab} [CI]",
               "LLM calls / mission", "tokens in / mission", "tokens out / mission"], rows)


def estimates_section(doc: Doc, metrics_dir: Path, variants: Sequence[tuple[str, Path]], judge: str,
                      current: str) -> None:
    """Each cost-estimate variant's m_overall beside this run's (``planner.inter_llm.nav_estimate`` = ``current``),
    paired over the missions both ran, and which the default should be."""
    got = [(lab, d) for lab, d in variants if (d / "per_mission.csv").is_file() and lab != current]
    if not got:
        return
    doc.h(2, "Cost-estimate variants (planner.inter_llm.nav_estimate)")
    doc.p(f"{plots.label(judge)} with each variant on the same missions as this run ({current}; paper_sum is "
          f"the paper's equation); change = paired reduction of m_overall against {current} (positive: the "
          f"variant is cheaper), 95% house-clustered CI.")
    this = read_json(metrics_dir / "metrics.json")["planners"].get(judge, {})

    def row(lab: str, m: Mapping, change: str, n_pairs: str) -> list[str]:
        return [lab, n_pairs, f"{fnum(m.get('m_overall'))} [{fnum(m.get('m_overall_ci_lo'))}, {fnum(m.get('m_overall_ci_hi'))}]",
                f"{m.get('n_fulfilled')}/{m.get('n_objects')}", fnum(m.get("cc"), 2), change]

    rows, better, worse = [row(f"{current} (this run)", this, "–", "–")], [], []
    for lab, d in got:
        n_pairs, reduction, lo, hi = paired_reduction(metrics_dir, d, judge, f"estimate:{lab}")
        rows.append(row(lab, read_json(d / "metrics.json")["planners"].get(judge, {}),
                        f"{fnum(reduction)}% [{fnum(lo)}, {fnum(hi)}]", str(n_pairs)))
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


def _source_row(metrics: Mapping, judge: str) -> dict:
    """What the capability table and figure need of one run's metrics.json."""
    sem = [v for k, v in metrics.get("semantic_accuracy", {}).items() if k.startswith(f"{judge}@")]
    ans = metrics.get("answers", {})
    return {"source": metrics.get("settings", {}).get("source", "?"),
            "relevance": num_or_nan(ans.get("relevance")), "target": num_or_nan(ans.get("target")),
            "cost": num_or_nan(sem[0].get("accuracy")) if sem else float("nan"),
            "planners": {p: tuple(num_or_nan(d.get(k)) for k in ("m_overall", "m_overall_ci_lo", "m_overall_ci_hi"))
                         for p, d in metrics.get("planners", {}).items()},
            "delivered": {p: f"{d.get('n_fulfilled')}/{d.get('n_objects')}" for p, d in metrics.get("planners", {}).items()},
            "improvement": {k.split("_vs_", 1)[1]: tuple(num_or_nan(v.get(x)) for x in ("pct", "ci_lo", "ci_hi"))
                            for k, v in metrics.get("improvement", {}).items() if k.startswith(f"{judge}_vs_")}}


def _paying_sentence(judge: str, baseline: str, sweep: Sequence[tuple[float, Mapping]]) -> str:
    """Where on the oracle axis the judged planner's paired improvement over ``baseline`` holds, and
    whether it grows with the quality of the answers (perfect oracle against random answers)."""
    nan3 = (math.nan,) * 3
    imp = {e: r["improvement"].get(baseline, nan3) for e, r in sweep}
    above, rest = capability.paying_errors([(e, v[1], v[2]) for e, v in imp.items()])
    best, worst = min(imp), max(imp)

    def errors(es) -> str:
        return ", ".join(format(e, "g") for e in es)

    text = (f"{plots.label(judge)} over {plots.label(baseline)}: the paired improvement's CI lies above 0 at "
            f"oracle error {errors(above) or 'none'}"
            + (f" and includes 0 at {errors(rest)}." if rest else " (every swept error)."))
    grows = not (above and worst in above)
    return text + (f" From the perfect oracle (error {best:g}) to the most random answers (error {worst:g}) it goes "
                   f"from {fnum(imp[best][0])}% to {fnum(imp[worst][0])}%: what {plots.label(judge)} gains over "
                   f"{plots.label(baseline)} " + ("depends on the answers." if grows else
                                                  "does not come from good answers."))


def capability_section(doc: Doc, metrics: Mapping, oracles: Sequence[tuple[float, Path]], fig_dir: Path,
                       judge: str) -> Optional[Path]:
    """The oracle sweep beside this run's model: accuracies, m_overall and paired improvements per
    source, the model's place on the oracle-error axis, and how much error the look-ahead survives.
    ``oracles``: (llm.oracle_error, metrics_dir) pairs; returns the figure drawn into ``fig_dir``
    (None without oracle results)."""
    got = [(e, read_json(d / "metrics.json")) for e, d in oracles if (d / "metrics.json").is_file()]
    if not got:
        return None
    model = _source_row(metrics, judge)
    sweep = [(e, _source_row(m, judge)) for e, m in got]
    planners = ordered({p for _, r in sweep for p in r["planners"]} | set(model["planners"]))
    refs = claims.set_aside(metrics) | {p for _, m in got for p in claims.set_aside(m)}
    baselines = [p for p in planners if p != judge and p not in refs]
    doc.h(2, "LLM capability: the oracle sweep and this run's model")
    doc.p("The same missions with llm=oracle: object relevance and target furniture from each command's goal, "
          "cost classes from the simulator's measurement, with a share llm.oracle_error of the answers replaced "
          "by seeded random ones. Oracle runs are never averaged with model runs. Accuracies are measured "
          "against ground truth for every source: relevance = share of the objects the candidates take that the "
          "command asks for; target = share of candidates delivering to a furniture the command names; cost "
          f"class = {plots.label(judge)}'s inferred classes equal to the measured ones ('unknown' wrong). "
          "m_overall per mission and paired improvements with 95% house-clustered CIs.")

    def mean_ci(v: tuple, unit: str = "") -> str:
        return f"{fnum(v[0])}{unit} [{fnum(v[1])}, {fnum(v[2])}]"

    nan3 = (math.nan,) * 3
    rows = [[r["source"], pct(r["relevance"]), pct(r["target"]), pct(r["cost"])]
            + [mean_ci(r["planners"].get(p, nan3)) for p in planners]
            + [mean_ci(r["improvement"].get(b, nan3), "%") for b in baselines] + [r["delivered"].get(judge, "–")]
            for r in [model] + [r for _, r in sweep]]
    doc.table(["input source", "relevance", "target", "cost class"] + [f"{plots.label(p)} m_overall [CI]" for p in planners]
              + [f"{plots.label(judge)} vs {plots.label(b)} [CI]" for b in baselines]
              + [f"{plots.label(judge)} delivered"], rows)
    where = {k: capability.equivalent_error(model[k], [(e, r[k]) for e, r in sweep]) for k in ("relevance", "cost")}
    sent = []
    for k, name in (("relevance", "object relevance"), ("cost", "cost classes")):
        e = where[k]
        worst = max(e for e, _ in sweep)
        sent.append(f"its accuracy on {name} ({pct(model[k])}) is that of an oracle with error {e:.2f}" if e is not None
                    else f"its accuracy on {name} ({pct(model[k])}) lies outside the swept oracles' range "
                    f"({'worse than error ' + format(worst, 'g') if model[k] < min(r[k] for _, r in sweep) else 'better than the best oracle swept'})")
    doc.p(f"On this axis, {model['source']} sits where " + "; ".join(sent) + ".")
    for b in baselines:
        doc.p(_paying_sentence(judge, b, sweep))
    f = plots.capability_figure(sweep, model, where, planners, judge, fig_dir / "capability.png")
    doc.img(f, "m_overall and paired improvements against oracle error; the model at its equivalent error")
    return f


def encoding_section(doc: Doc, results: Sequence[tuple[str, str, Path]], metrics: Mapping,
                     judge: str) -> None:
    """Runs that differ only in ``llm.oracle_costs`` and/or ``planner.inter_llm.cost_encoding``: results are
    (group, variant label, metrics_dir) with one group per setting of every other key
    (``interllm.stages.report.find_encoding_results``); each variant of a group is paired against
    the group's paper encoding (``BASE_ENCODING``, else its first variant) on the missions both ran."""
    groups: dict[str, dict[str, Path]] = {}
    for g, v, d in results:
        if (Path(d) / "per_mission.csv").is_file() and (Path(d) / "metrics.json").is_file():
            groups.setdefault(str(g), {})[str(v)] = Path(d)
    groups = {g: vs for g, vs in groups.items() if len(vs) >= 2}
    if not groups:
        return
    st = metrics.get("settings", {})
    n_boot, cov, seed = int(st.get("bootstrap_samples", 2000)), float(st.get("ci", 0.95)), int(st.get("seed", 0))
    ref = plots.label(judge)
    doc.h(2, "Cost encoding: class or numeric oracle costs, paper or expected encoding")
    doc.p(f"{ref} in runs that differ only in llm.oracle_costs (classes: the paper's three cost classes; numeric: "
          "the measured cost) and/or planner.inter_llm.cost_encoding (paper; expected: plus γ_obj × the chance the action "
          f"fails outright). Each variant is paired against {BASE_ENCODING} of its group on the missions both ran "
          "(variant − base; 95% paired house-clustered CIs; the position difference takes the missions jointly for "
          f"{ref} and both anchors of both runs).")
    rows = []
    for g in sorted(groups):
        vs = groups[g]
        base = BASE_ENCODING if BASE_ENCODING in vs else sorted(vs)[0]
        base_rows = read_csv(vs[base] / "per_mission.csv")
        for v in [base] + sorted(set(vs) - {base}):
            d = read_json(vs[v] / "metrics.json").get("planners", {}).get(judge, {})
            row = [g or "–", v + (" (base)" if v == base else ""),
                   ci(d.get("delivered_per_mission"), d.get("delivered_per_mission_ci_lo"),
                      d.get("delivered_per_mission_ci_hi"), 2),
                   ci(d.get("m_overall"), d.get("m_overall_ci_lo"), d.get("m_overall_ci_hi")),
                   ci(d.get("position"), d.get("position_ci_lo"), d.get("position_ci_hi"), 2)]
            if v == base:
                row += ["–"] * 4
            else:
                c = paired_runs(read_csv(vs[v] / "per_mission.csv"), base_rows, judge, n_boot, cov,
                                bootstrap_seed(seed, f"encoding:{g}:{v}"), interval_method(metrics))
                row += [str(c["n_pairs"]),
                        ci(c["delivered_diff"], c["delivered_diff_ci_lo"], c["delivered_diff_ci_hi"], 2, sign=True),
                        ci(c["m_overall_diff"], c["m_overall_diff_ci_lo"], c["m_overall_diff_ci_hi"], sign=True),
                        ci(c["position_diff"], c["position_diff_ci_lo"], c["position_diff_ci_hi"], 2, sign=True)]
            rows.append(row)
    doc.table(["runs", "variant", "delivered / mission [CI]", "m_overall / mission [CI]", "position [CI]", "pairs",
               "Δ delivered [CI]", "Δ m_overall [CI]", "Δ position [CI]"], rows)
