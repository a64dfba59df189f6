"""The package stays readable: no module over 450 lines, no function over 80 lines and no
function with more than 7 positional parameters in ``interllm/``.

Values that travel together become a frozen dataclass; per-call options become keyword-only
parameters. A module that must stay larger is listed in ``EXCEPTIONS`` with the reason.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "interllm"
MAX_MODULE_LINES = 450
MAX_FUNCTION_LINES = 80
MAX_POSITIONAL = 7

# "path relative to interllm/" or "path:function" -> why it stays over a limit.
EXCEPTIONS: dict[str, str] = {}


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        yield path.relative_to(PACKAGE).as_posix(), path.read_text(encoding="utf-8")


def _functions(source: str):
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield node


def _positional_count(fn: ast.FunctionDef) -> int:
    names = [a.arg for a in fn.args.posonlyargs + fn.args.args]
    if names and names[0] in ("self", "cls"):
        names = names[1:]
    return len(names)


def _over(limit_name: str, found: list[str]) -> str:
    return (f"{len(found)} over the {limit_name} limit (split along a seam, or list the place in "
            f"EXCEPTIONS of {Path(__file__).name} with the reason):\n  " + "\n  ".join(found))


def test_no_module_is_over_450_lines():
    found = [f"{rel}: {len(src.splitlines())} lines" for rel, src in _modules()
             if len(src.splitlines()) > MAX_MODULE_LINES and rel not in EXCEPTIONS]
    assert not found, _over("module-length", found)


def test_no_function_is_over_80_lines():
    found = []
    for rel, src in _modules():
        for fn in _functions(src):
            length = fn.end_lineno - fn.lineno + 1
            if length > MAX_FUNCTION_LINES and f"{rel}:{fn.name}" not in EXCEPTIONS:
                found.append(f"{rel}:{fn.lineno} {fn.name}: {length} lines")
    assert not found, _over("function-length", found)


def test_no_function_takes_more_than_7_positional_parameters():
    found = []
    for rel, src in _modules():
        for fn in _functions(src):
            count = _positional_count(fn)
            if count > MAX_POSITIONAL and f"{rel}:{fn.name}" not in EXCEPTIONS:
                found.append(f"{rel}:{fn.lineno} {fn.name}: {count} positional parameters")
    assert not found, _over("positional-parameter", found)


def test_the_checker_sees_an_oversized_function(tmp_path):
    """The walk finds a nested long function and counts positional parameters without self."""
    body = "\n".join(f"        x{i} = {i}" for i in range(MAX_FUNCTION_LINES))
    source = (f"class A:\n    def f(self, a, b, c, d, e, f, g, h):\n{body}\n")
    (fn,) = list(_functions(source))
    assert fn.end_lineno - fn.lineno + 1 > MAX_FUNCTION_LINES
    assert _positional_count(fn) == 8
