"""The README's results are the committed metrics: every cell of its headline table and the paired
improvements its claims table quotes are recomputed from ``data/metrics/metrics.json`` and compared
as text, so a re-run that moves a number fails here until the README says so."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
LABELS = {"Inter-LLM": "inter_llm", "SayPlan": "sayplan", "MoMa-LLM": "moma_llm",
          "*nothing* (reference)": "nothing", "*optimal* (reference)": "optimal"}


def _num(v: float, nd: int) -> str:
    """The README's number format: fixed decimals, a typographic minus."""
    s = f"{v:.{nd}f}"
    if float(s) == 0:
        s = s.lstrip("-")  # -0.00 reads 0.00
    return s.replace("-", "−")


def _ci(d: dict, key: str, nd: int) -> str:
    return f"{_num(d[key], nd)} [{_num(d[key + '_ci_lo'], nd)}, {_num(d[key + '_ci_hi'], nd)}]"


def headline_rows() -> dict[str, list[str]]:
    """{planner id: cells} of the table under '## Results of the default experiment'."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("## Results of the default experiment", 1)[1].split("\n## ", 1)[0]
    rows = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if cells and cells[0] in LABELS:
            rows[LABELS[cells[0]]] = cells[1:]
    return rows


@pytest.fixture(scope="module")
def metrics() -> dict:
    return json.loads((ROOT / "data" / "metrics" / "metrics.json").read_text())


@pytest.mark.parametrize("planner", ["inter_llm", "sayplan", "moma_llm"])
def test_the_headline_table_is_metrics_json(metrics, planner):
    d = metrics["planners"][planner]
    expected = [str(d["delivered"]), _ci(d, "delivered_per_mission", 2), _ci(d, "m_overall", 1), _ci(d, "position", 2),
                _num(d["exec_cost_per_delivered"], 1), _num(d["cc"], 2), _num(d["llm_calls_per_mission"], 1)]
    assert headline_rows()[planner] == expected


def test_the_references_rows_are_metrics_json(metrics):
    rows, pl = headline_rows(), metrics["planners"]
    assert rows["nothing"][:3] == [str(pl["nothing"]["delivered"]), "0", _num(pl["nothing"]["m_overall"], 1)]
    o = pl["optimal"]
    assert rows["optimal"][:3] == [str(o["delivered"]), _ci(o, "delivered_per_mission", 2), _ci(o, "m_overall", 1)]
    assert rows["optimal"][4] == _num(o["exec_cost_per_delivered"], 1)


def test_the_claims_quote_the_paired_improvements(metrics):
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    line = next(x for x in text.splitlines() if x.startswith("| Inter-LLM has the lowest m_overall"))
    imp = metrics["improvement"]
    for label, key in (("MoMa-LLM", "inter_llm_vs_moma_llm"), ("SayPlan", "inter_llm_vs_sayplan")):
        quoted = re.search(rf"vs {label} (\S+)% \[(\S+), (\S+)\]", line)
        assert quoted, (label, line)
        assert list(quoted.groups()) == [_num(imp[key]["pct"], 1), _num(imp[key]["ci_lo"], 1), _num(imp[key]["ci_hi"], 1)]
