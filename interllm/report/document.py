"""The report's tiny document model (``Doc``: headings, paragraphs, tables, images, links, rendered
to Markdown and to self-contained HTML) and the cell formatters the report's sections share."""

from __future__ import annotations

import base64
import html
import math
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any, Optional

from interllm.metrics import planner_info


class Doc:
    """Blocks (heading, paragraph, code, table, image, links) rendered by ``markdown`` and ``html``."""

    def __init__(self) -> None:
        self.blocks: list[tuple[str, Any]] = []

    def h(self, level: int, text: str) -> None:
        self.blocks.append(("h", (level, text)))

    def p(self, text: str) -> None:
        self.blocks.append(("p", text))

    def code(self, text: str) -> None:
        self.blocks.append(("code", text))

    def table(self, header: list[str], rows: list[list[str]], group: Optional[list[tuple[str, int]]] = None
              ) -> None:
        self.blocks.append(("table", (header, rows, group)))

    def img(self, path: Path, alt: str) -> None:
        self.blocks.append(("img", (path, alt)))

    def links(self, items: list[tuple[str, str]]) -> None:
        self.blocks.append(("links", items))

    def markdown(self, out_dir: Path) -> str:
        out = []
        for kind, v in self.blocks:
            if kind == "h":
                out.append("#" * v[0] + " " + v[1])
            elif kind == "p":
                out.append(v)
            elif kind == "code":
                out.append("```\n" + v + "\n```")
            elif kind == "table":
                header, rows, group = v
                if group:
                    names = []
                    for text, span in group:
                        names += [text] + [""] * (span - 1)
                    header = [f"{g} {h}".strip() if g else h for g, h in zip(names, header, strict=True)]
                lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
                lines += ["| " + " | ".join(r) + " |" for r in rows]
                out.append("\n".join(lines))
            elif kind == "img":
                out.append(f"![{v[1]}]({rel(v[0], out_dir)})")
            elif kind == "links":
                out.append("\n".join(f"- [{t}]({u})" for t, u in v))
        return "\n\n".join(out) + "\n"

    def html(self, title: str) -> str:
        e = html.escape
        out = [f"<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>{e(title)}</title>",
               "<style>body{font-family:sans-serif;max-width:1200px;margin:auto}"
               "table{border-collapse:collapse;font-size:13px}td,th{border:1px solid #999;padding:2px 5px;"
               "text-align:center}img{max-width:100%}</style></head><body>"]
        for kind, v in self.blocks:
            if kind == "h":
                out.append(f"<h{v[0]}>{e(v[1])}</h{v[0]}>")
            elif kind == "p":
                out.append(f"<p>{e(v)}</p>")
            elif kind == "code":
                out.append(f"<pre><code>{e(v)}</code></pre>")
            elif kind == "table":
                header, rows, group = v
                t = ["<table>"]
                if group:
                    t.append("<tr>" + "".join(f"<th colspan='{s}'>{e(g)}</th>" for g, s in group) + "</tr>")
                t.append("<tr>" + "".join(f"<th>{e(h)}</th>" for h in header) + "</tr>")
                t += ["<tr>" + "".join(f"<td>{e(c)}</td>" for c in r) + "</tr>" for r in rows]
                t.append("</table>")
                out.append("".join(t))
            elif kind == "img":
                b64 = base64.b64encode(Path(v[0]).read_bytes()).decode("ascii")
                out.append(f"<figure><img alt='{e(v[1])}' src='data:image/png;base64,{b64}'>"
                           f"<figcaption>{e(v[1])}</figcaption></figure>")
            elif kind == "links":
                out.append("<ul>" + "".join(f"<li><a href='{e(u)}'>{e(t)}</a></li>" for t, u in v) + "</ul>")
        out.append("</body></html>\n")
        return "\n".join(out)


def rel(path: Path | str, start: Path) -> str:
    """``path`` relative to ``start`` (POSIX separators), for links in the Markdown."""
    return Path(os.path.relpath(Path(path).resolve(), Path(start).resolve())).as_posix()


def fnum(v: Any, nd: int = 1) -> str:
    """A number with ``nd`` decimals; "–" for none / NaN; non-numbers as text."""
    if v is None or v == "":
        return "–"
    try:
        x = float(v)
    except (TypeError, ValueError):
        return str(v)
    if math.isnan(x):
        return "–"
    return f"{x:.{nd}f}"


def pct(v: Any) -> str:
    """A share in [0, 1] as a whole percentage; "–" for none / NaN."""
    return "–" if v is None or v == "" or (isinstance(v, float) and math.isnan(v)) else f"{100 * float(v):.0f}%"


def ordered(planners: Iterable[str]) -> list[str]:
    """Planners in their report order (baselines first, then the judged planner, then the anchors;
    ``planner_info``), then any others by name."""
    return planner_info.current().ordered(planners)


def num_or_nan(v: Any) -> float:
    """float(v), NaN when v is no number."""
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


def ci(v: Any, lo: Any, hi: Any, nd: int = 1, sign: bool = False) -> str:
    """"v [lo, hi]" (signed with ``sign``); "v" alone without an interval; "–" without a value."""
    def one(x: Any) -> str:
        s = fnum(x, nd)
        if s == "–" or float(s) == 0:
            return s.lstrip("-")
        return f"+{s}" if sign and not s.startswith("-") else s

    if math.isnan(num_or_nan(v)):
        return "–"
    if math.isnan(num_or_nan(lo)) or math.isnan(num_or_nan(hi)):
        return one(v)
    return f"{one(v)} [{one(lo)}, {one(hi)}]"
