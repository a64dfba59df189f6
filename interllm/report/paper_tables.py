"""The paper's Tables II and III beside ours: the paper's numbers, our Table III (means over the
missions shaped like the paper's) and the two report sections.

Paper: Yang et al., "Interleaved LLM and Motion Planning for Generalized Multi-Object Collection in
Large Scene Graphs" (``shared/paper/inter-llm.tex``).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Optional

from interllm.metrics.compute import read_csv
from interllm.metrics.stats import LABELS, confusion_matrix
from interllm.report import plots
from interllm.report.document import Doc, fnum, ordered, pct
from interllm.report.sweeps import with_metrics

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
        ours = pct(v)
    else:
        ours = fnum(v, 2 if metric == "cc" else 1)
    if paper is None:
        return ours
    if metric == "sr_obj":
        pap = "✓" if paper >= 0.5 else "×"
    elif metric == "sr_man":
        pap = pct(paper)
    else:
        pap = fnum(paper, 0 if metric == "cc" else 1)
    return f"{ours} ({pap})"


def table_iii_section(doc: Doc, per_object: Iterable[Mapping], per_command: Iterable[Mapping]) -> None:
    """Table III in the paper's layout (obj_1..obj_9 under command_1..command_3): our means with the
    paper's numbers in parentheses, or why it is left out."""
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
            for p in ordered(set(t3[m]) | set(PAPER_TABLE_III[m])):
                ours = t3[m].get(p, [float("nan")] * 9)
                paper = PAPER_TABLE_III[m].get(p)
                rows.append([name, plots.label(p)] + [_cell(m, ours[i], None if paper is None else paper[i])
                                                      for i in range(9)])
        doc.table(["metric", "algorithm"] + [f"obj_{i}" for i in range(1, 10)], rows,
                  group=[("", 2), ("command_1", 3), ("command_2", 3), ("command_3", 3)])
    else:
        doc.p("No run is shaped like the paper's mission (3 commands x 3 objects): Table III is left out.")


def table_ii_section(doc: Doc, metrics_dir: Path, temperature_results: Sequence[tuple[str, str | os.PathLike]]
                     ) -> None:
    """Table II: semantic-similarity accuracy per temperature σ of this run and of the
    ``temperature_results`` (label, metrics_dir) runs, beside the paper's accuracy; this run's
    confusion matrix."""
    doc.h(2, "Table II: semantic-similarity accuracy per temperature")
    sem_rows = []
    others = [(lab, d) for lab, d in temperature_results if Path(d).resolve() != metrics_dir.resolve()]
    for lab, d, _ in with_metrics([("this run", metrics_dir)] + others):
        p = d / "semantic_accuracy.csv"
        for r in (read_csv(p) if p.is_file() else []):
            t = r["temperature"]
            paper = PAPER_TABLE_II.get(round(float(t), 1)) if t != "" else None
            sem_rows.append((float(t) if t != "" else -1.0, lab, [
                fnum(t, 1), lab, plots.label(str(r["planner"])), str(r["n_judged"]),
                f"{pct(r['accuracy'])} [{pct(r.get('accuracy_ci_lo'))}, {pct(r.get('accuracy_ci_hi'))}]",
                pct(r.get("coverage")),
                f"{pct(r['accuracy_known'])} [{pct(r.get('accuracy_known_ci_lo'))}, "
                f"{pct(r.get('accuracy_known_ci_hi'))}]",
                f"{pct(r.get('chance'))} / {pct(r.get('majority'))}", str(r.get("verdict", "–")),
                "–" if paper is None else f"{paper:.0f}%",
                f"{pct(r.get('truth_agreement'))} of {r.get('n_executed', '–')}"]))
    if sem_rows:
        rows = [row for _, _, row in sorted(sem_rows, key=lambda x: (x[0], x[1]))]
        doc.p("Prediction = class the LLM inferred for a manipulation action; truth = f_en of the cost the "
              "simulator measured for the same action, by the same N_l-trial protocol, in a scratch copy of the "
              "scene as it was when the inference was made (the mission is untouched), so every inference is "
              "judged, whether or not its action ran. Accuracy counts 'unknown' as wrong; coverage = share "
              "answered; accuracy when answered is compared with chance (1/3 over easy / medium / hard) and "
              "the majority class (always the commonest true class); the claim holds when its 95% "
              "house-clustered CI lies above both, does not hold when it lies below either, and "
              "cannot be told only when it straddles the higher. The last column checks the measurement: of the judged "
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
