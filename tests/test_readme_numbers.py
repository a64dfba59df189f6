"""The result numbers README.md and docs/*.md quote are the committed results.

Every quoted number is declared beside it in an HTML comment, which the rendered Markdown hides:

- A table::

      <!-- table SOURCE rows Inter-LLM=inter_llm, SayPlan=sayplan
      | $ | {planners/$/delivered} | {planners/$/m_overall:.1ci} | * |
      | *nothing* (reference) | {planners/nothing/delivered} | 1800.0 | – |
      -->
      | planner | delivered | m_overall / mission | note |
      |---|---|---|---|
      | Inter-LLM | 68 | 1688.6 [1613.8, 1759.2] | free text |

  Each template row is compared, cell by cell, with the table row of the same first cell; a
  template row labelled ``$`` stands for every ``LABEL=KEY`` of ``rows`` (comma-separated), with
  KEY for ``$`` in its paths; ``*`` skips a cell, any other text must be written as it is. SOURCE is a JSON file
  (``data/metrics/*.json``). A table with a Markdown SOURCE (a committed report, e.g.
  ``data/report_sweeps/report.md``) has no template rows: each row is compared, column by column
  under the same header, with the row of a report table that has all its columns and the same
  value under its first one.
- A number in the text: ``... 34.6<!--= {planners/inter_llm/llm_calls_per_mission:.1f} -->``: the
  text before the marker ends with the rendered template. The source is
  ``data/metrics/metrics.json`` unless the template starts with another one
  (``<!--= data/metrics/llm_usage.json {...} -->``).
- A phrase of a report: ``... error 0.29<!--quote SOURCE: an oracle with error 0.29-->``: SOURCE
  says the phrase, and every number written on the line since its previous comment is in it.
- ``<!--unchecked: why-->`` right before a table whose numbers no committed file holds. A table
  whose every number carries its own ``<!--= SOURCE {...} -->`` needs no table marker (rows from
  several files).

Formats, ``{path:format}`` with the path's keys separated by ``/`` (a string value is written as
it is): ``d`` (the default) a whole number, ``,d`` with thousands separators, ``.Nf`` N decimals,
``.Nci`` the value and its CI ``[lo, hi]`` from the ``<key>_ci_lo`` / ``<key>_ci_hi`` (or
``ci_lo`` / ``ci_hi``) keys beside it, ``.N%`` and ``.N%ci`` the same times 100 with a percent
sign; a leading ``+`` signs positive values. Minus signs are typographic (−), as the docs write
them.

After a re-run, ``python tests/test_readme_numbers.py --write`` rewrites every number quoted from a
JSON file (then read the sentences around them again: their wording is not generated).
"""

from __future__ import annotations

import json
import re
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
RESULT_DOCS = [ROOT / "README.md", ROOT / "docs" / "results.md"]  # each numeric table names its source
DEFAULT_SOURCE = "data/metrics/metrics.json"
PLANNERS = ("inter_llm", "sayplan", "moma_llm", "nothing", "optimal")

MARKER = re.compile(r"<!--\s*(table\b|=|quote\b|unchecked\b)(.*?)-->", re.S)
COMMENT = re.compile(r"<!--.*?-->", re.S)
PLACEHOLDER = re.compile(r"\{([^{}:]+)(?::([^{}]*))?\}")
FORMAT = re.compile(r"(?P<plus>\+)?(?P<comma>,)?(?:\.(?P<nd>\d+))?(?P<kind>d|f|ci|%|%ci)?")
NUMBER = r"[+−-]?\d[\d,]*(?:\.\d+)?%?(?: \[[^\]]*\])?"  # a written value, with its CI if any
SEPARATOR = re.compile(r":?-+:?")


@dataclass(frozen=True)
class Mismatch:
    """A quoted value that is not what its source holds."""

    doc: str
    line: int
    what: str
    written: str
    expected: str
    source: str
    at: int | None = None  # offset of the written value in the document, where --write may replace it

    def __str__(self) -> str:
        return (f"{self.doc}:{self.line}: {self.what}: written {self.written!r}, "
                f"{self.source} has {self.expected!r}")


@dataclass(frozen=True)
class Row:
    line: int  # 1-based line number in the document
    cells: list[str]


# ---- rendering a template from JSON ---------------------------------------------------------------
def num(value: float, nd: int, plus: bool = False) -> str:
    """``value`` with ``nd`` decimals and a typographic minus (−0.00 reads 0.00)."""
    s = f"{value:.{nd}f}"
    if float(s) == 0:
        s = s.lstrip("-")
    elif plus and value > 0:
        s = "+" + s
    return s.replace("-", "−")


def lookup(data: dict, path: str):
    node = data
    for key in path.split("/"):
        if not isinstance(node, dict) or key not in node:
            raise LookupError(f"{path}: no key {key!r}")
        node = node[key]
    return node


def _ci_bound(data: dict, path: str, side: str) -> float:
    parent, _, key = path.rpartition("/")
    node = lookup(data, parent) if parent else data
    for name in (f"{key}_ci_{side}", f"ci_{side}"):
        if name in node:
            return node[name]
    raise LookupError(f"{path}: no {key}_ci_{side} or ci_{side} beside it")


def render_value(data: dict, path: str, fmt: str | None) -> str:
    m = FORMAT.fullmatch(fmt or "")
    if m is None:
        raise ValueError(f"unknown format {fmt!r} of {path}")
    value, nd, plus = lookup(data, path), int(m["nd"] or 0), bool(m["plus"])
    if isinstance(value, str):
        return value
    if value is None:  # a JSON null: no such value (e.g. no break-even when both deliver the same)
        return "none"
    kind = m["kind"] or ("f" if m["nd"] else "d")
    if kind == "d":
        if value is None or value != int(value):
            raise ValueError(f"{path} = {value!r} is not a whole number; give it a format such as .1f")
        return (f"{int(value):+,}" if plus else f"{int(value):,}") if m["comma"] else num(value, 0, plus)
    scale, unit = (100, "%") if kind.startswith("%") else (1, "")
    text = num(value * scale, nd, plus) + unit
    if kind.endswith("ci"):
        lo, hi = (_ci_bound(data, path, side) * scale for side in ("lo", "hi"))
        text += f" [{num(lo, nd, plus)}, {num(hi, nd, plus)}]"
    return text


def render(template: str, data: dict, key: str | None = None) -> str:
    return PLACEHOLDER.sub(lambda m: render_value(data, m[1].replace("$", key or "$"), m[2]), template)


def raw_values(template: str, data: dict, key: str | None = None) -> str:
    """The JSON values behind a template, e.g. ``planners/inter_llm/m_overall = 1688.637576``."""
    paths = [m[1].replace("$", key or "$") for m in PLACEHOLDER.finditer(template)]
    return ", ".join(f"{p} = {lookup(data, p)!r}" for p in paths)


# ---- reading Markdown ---------------------------------------------------------------------------
def cells(line: str) -> list[str]:
    """The cells of a table line, comments removed, ``\\|`` kept inside a cell."""
    return [c.strip() for c in re.split(r"(?<!\\)\|", COMMENT.sub("", line).strip().strip("|"))]


def tables(lines: list[str], start: int = 0, first_only: bool = False) -> list[tuple[Row, list[Row]]]:
    """(header row, body rows) of the tables from line index ``start`` on (the first one only
    with ``first_only``, after blank lines and nothing else)."""
    found, i = [], start
    while i < len(lines):
        if not lines[i].lstrip().startswith("|"):
            if first_only and lines[i].strip():
                break
            i += 1
            continue
        block = []
        while i < len(lines) and lines[i].lstrip().startswith("|"):
            block.append(Row(i + 1, cells(lines[i])))
            i += 1
        body = [r for r in block[1:] if not all(SEPARATOR.fullmatch(c) for c in r.cells)]
        found.append((block[0], body))
        if first_only:
            break
    return found


def without_comments(text: str) -> list[str]:
    """The lines of ``text`` with every HTML comment blanked (line numbers kept)."""
    return COMMENT.sub(lambda m: "\n" * m[0].count("\n"), text).split("\n")


def _source(name: str) -> tuple[str, dict | str]:
    path = ROOT / name
    if not path.is_file():
        raise FileNotFoundError(f"quoted source {name} does not exist")
    text = path.read_text(encoding="utf-8")
    return name, json.loads(text) if name.endswith(".json") else text


def _ascii_minus(s: str) -> str:
    return s.replace("−", "-")


def row_keys(first_line: str) -> dict[str, str]:
    """``{label: key}`` of a table marker's ``rows LABEL=KEY, LABEL=KEY`` (labels may hold spaces)."""
    _, found, rows = first_line.partition(" rows ")
    return {label.strip(): key.strip() for label, _, key in (p.partition("=") for p in rows.split(","))} if found else {}


# ---- the checks -------------------------------------------------------------------------------------
def _cell_offset(text: str, row: Row, col: int, written: str) -> int:
    """Offset in ``text`` of ``written`` inside cell ``col`` of ``row``."""
    line_start = sum(len(x) + 1 for x in text.split("\n")[: row.line - 1])
    line = text.split("\n")[row.line - 1]
    pipes = [m.start() for m in re.finditer(r"(?<!\\)\|", line)]
    return line_start + line.index(written, pipes[col] + 1)


def _check_json_table(text, doc, header, body, spec_lines, source, data) -> list[Mismatch]:
    rows = row_keys(spec_lines[0])
    by_label = {r.cells[0]: r for r in body}
    out = []
    for spec in (cells(s) for s in spec_lines[1:] if s.strip().startswith("|")):
        for label, key in (rows.items() if spec[0] == "$" else [(spec[0], None)]):
            row = by_label.get(label)
            if row is None:
                out.append(Mismatch(doc, header.line, f"row {label!r}", "(missing)", label, source))
                continue
            if len(spec) != len(row.cells):
                out.append(Mismatch(doc, row.line, f"{label}: cells", f"({len(row.cells)})", f"({len(spec)})",
                                    "the template"))
            for col, (tmpl, written) in enumerate(zip(spec[1:], row.cells[1:], strict=False), start=1):
                expected = written if tmpl == "*" else render(tmpl, data, key)
                if written != expected:
                    raw = raw_values(tmpl, data, key)
                    out.append(Mismatch(doc, row.line, f"{label} / {header.cells[col]}", written, expected,
                                        f"{source} ({raw})" if raw else source,
                                        _cell_offset(text, row, col, written) if written else None))
    return out


def _check_report_table(doc, header, body, source, report) -> list[Mismatch]:
    """Each row against the report's row with the same value in the column of the first header."""
    candidates = [(h.cells, r.cells) for h, rs in tables(without_comments(report)) if set(header.cells) <= set(h.cells)
                  for r in rs]
    out = []
    for row in body:
        label = _ascii_minus(row.cells[0])
        match = next(((h, r) for h, r in candidates if _ascii_minus(r[h.index(header.cells[0])]) == label), None)
        if match is None:
            out.append(Mismatch(doc, row.line, f"row {row.cells[0]!r}", "(written)",
                                "(no such row under these columns)", source))
            continue
        report_header, report_row = match
        for col, written in zip(header.cells[1:], row.cells[1:], strict=False):
            expected = report_row[report_header.index(col)]
            if _ascii_minus(written) != _ascii_minus(expected):
                out.append(Mismatch(doc, row.line, f"{row.cells[0]} / {col}", written, expected, source))
    return out


def _check_inline(doc, line_no, line_start, before, body) -> list[Mismatch]:
    parts = body.split(None, 1)
    name, template = (parts[0], parts[1].strip()) if parts[0].endswith(".json") else (DEFAULT_SOURCE, body.strip())
    source, data = _source(name)
    expected = render(template, data)
    pattern = "".join(NUMBER if m[1] else re.escape(m[0]) for m in re.finditer(r"(\{[^{}]*\})|[^{}]+", template))
    found = re.search(f"({pattern})\\s*$", before)
    if found is not None and found[1] == expected:
        return []
    written = found[1] if found else "(" + before.rstrip()[-len(expected) - 10:] + ")"
    return [Mismatch(doc, line_no, template, written, expected, f"{source} ({raw_values(template, data)})",
                     line_start + found.start(1) if found else None)]


def _check_quote(doc, line_no, before, body) -> list[Mismatch]:
    """The source says the phrase, and every number written since the line's previous comment is in it."""
    name, _, phrase = body.partition(":")
    source, text = _source(name.strip())
    phrase = _ascii_minus(phrase.strip())
    if phrase not in _ascii_minus(text):
        return [Mismatch(doc, line_no, "quote", phrase, "(no such phrase)", source)]
    written = re.findall(r"(?<![\w.])-?\d[\d,]*(?:\.\d+)?", _ascii_minus(before.rsplit("-->", 1)[-1]))
    return [Mismatch(doc, line_no, "quote", n, phrase, source) for n in (w.rstrip(",") for w in written)
            if n not in phrase]


def check(text: str, doc: str) -> list[Mismatch]:
    """Every declared quote of a Markdown document against its source."""
    out = []
    for m in MARKER.finditer(text):
        kind, body = m[1], m[2]
        line_no = text.count("\n", 0, m.start()) + 1
        line_start = text.rfind("\n", 0, m.start()) + 1
        if kind == "table":
            spec_lines = body.strip().splitlines()
            found = tables(without_comments(text), text.count("\n", 0, m.end()) + 1, first_only=True)
            if not found:
                out.append(Mismatch(doc, line_no, "table", "(none)", "(a table after the marker)", "the marker"))
                continue
            source, data = _source(spec_lines[0].split()[0])
            header, rows = found[0]
            out += (_check_json_table(text, doc, header, rows, spec_lines, source, data) if isinstance(data, dict)
                    else _check_report_table(doc, header, rows, source, data))
        elif kind == "=":
            out += _check_inline(doc, line_no, line_start, text[line_start:m.start()], body)
        elif kind == "quote":
            out += _check_quote(doc, line_no, text[line_start:m.start()], body)
    return out


def _cells_marked(raw: str, row: Row) -> bool:
    """True when every number of ``row`` (its cells without comments) carries its own ``<!--= -->``
    marker in the same cell of the raw line ``raw``."""
    raw_cells = raw.strip().strip("|").split("|")  # markers hold no '|'
    return len(raw_cells) == len(row.cells) and all(
        "<!--=" in r for r, c in zip(raw_cells, row.cells, strict=True) if re.fullmatch(NUMBER, c))


def undeclared_tables(text: str) -> list[int]:
    """Line numbers of the tables with a number for a cell and no table or unchecked marker before them
    (a table whose every number carries its own ``<!--= ... -->`` marker is declared cell by cell)."""
    lines = text.split("\n")
    marked = {text.count("\n", 0, m.end()) for m in MARKER.finditer(text) if m[1] in ("table", "unchecked")}
    missing = []
    for header, body in tables(without_comments(text)):
        if not any(re.fullmatch(NUMBER, c) for r in body for c in r.cells) or all(_cells_marked(lines[r.line - 1], r)
                                                                                 for r in body):
            continue
        prev = header.line - 2  # 0-based index of the line above the header
        while prev >= 0 and not lines[prev].strip():
            prev -= 1
        if prev not in marked:
            missing.append(header.line)
    return missing


def _rel(p: Path) -> str:
    return str(p.relative_to(ROOT))


# ---- tests --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("doc", [d for d in DOCS if d.is_file()], ids=_rel)
def test_quoted_numbers_are_the_committed_results(doc):
    mismatches = check(doc.read_text(encoding="utf-8"), _rel(doc))
    assert not mismatches, "\n".join(map(str, mismatches))


@pytest.mark.parametrize("doc", RESULT_DOCS, ids=_rel)
def test_every_result_table_names_its_source(doc):
    missing = undeclared_tables(doc.read_text(encoding="utf-8"))
    assert not missing, (f"{_rel(doc)}: the tables at lines {missing} hold numbers but no "
                         "<!-- table SOURCE ... --> or <!--unchecked: why--> marker before them")


@pytest.mark.parametrize("doc", RESULT_DOCS, ids=_rel)
def test_the_headline_table_checks_every_planner(doc):
    text = doc.read_text(encoding="utf-8")
    specs = [m[2] for m in MARKER.finditer(text) if m[1] == "table" and DEFAULT_SOURCE in m[2].split("\n", 1)[0]]
    checked = set()
    for spec in specs:
        keys = list(row_keys(spec.strip().splitlines()[0]).values())
        for path in PLACEHOLDER.findall(spec):
            checked |= {path[0].replace("$", k) for k in keys} if "$" in path[0] else {path[0]}
    for planner in PLANNERS:
        assert {f"planners/{planner}/m_overall", f"planners/{planner}/delivered"} <= checked, (
            f"{_rel(doc)}: no checked table quotes {planner}'s m_overall and delivered from {DEFAULT_SOURCE}")


def test_a_moved_number_is_named_with_its_line_and_both_values():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    data = json.loads((ROOT / DEFAULT_SOURCE).read_text())
    right = render("{planners/inter_llm/m_overall:.1ci}", data)
    line_no = next(i for i, line in enumerate(text.splitlines(), 1)
                   if line.startswith("| Inter-LLM |") and right in line)
    wrong = text.replace(f"| {right} |", f"| {right.replace('.', ',', 1)} |", 1)
    found = [m for m in check(wrong, "README.md") if m.line == line_no]
    assert [(m.written, m.expected) for m in found] == [(right.replace(".", ",", 1), right)]
    assert str(found[0]).startswith(f"README.md:{line_no}: Inter-LLM / ")


# ---- regenerating the quotes ---------------------------------------------------------------------------
def rewrite(text: str) -> str:
    """``text`` with every number quoted from a JSON file rendered again from it."""
    for m in sorted((m for m in check(text, "doc") if ".json" in m.source.split(" ")[0]),
                    key=lambda m: -1 if m.at is None else m.at, reverse=True):
        if m.at is None:
            raise SystemExit(f"cannot rewrite {m}")
        text = text[:m.at] + m.expected + text[m.at + len(m.written):]
    return text


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        raise SystemExit("usage: python tests/test_readme_numbers.py --write")
    for d in DOCS:
        if d.is_file() and (new := rewrite(old := d.read_text(encoding="utf-8"))) != old:
            d.write_text(new, encoding="utf-8")
            print(f"rewrote {_rel(d)}")
