"""The report's verdicts on the paper's claims (``interllm.metrics.claims``): each claim with its
figure [CI], the delivery check beside it and "holds" / "does not hold" / "cannot tell", and the
houses a 10% paired difference would need (``houses_text``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

from interllm.metrics import claims
from interllm.metrics.compute import read_csv
from interllm.metrics.stats import interval_method
from interllm.report import plots
from interllm.report.document import Doc, ci, fnum, num_or_nan


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
