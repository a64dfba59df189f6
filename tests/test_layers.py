"""The library's layers: every package imports only from the layers below it, no module import
closes a cycle, and an import inside a function says why (a comment starting with "lazy:").

    base (errors, numerics, llama_build, core, config, overrides, registry, io, progress, lifetime, lazy)
      -> scene, llm -> planning -> sim -> record -> planners -> metrics -> report -> stages -> cli

Imports are read from the source (ast), so the test needs nothing installed beyond the stdlib.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "interllm"
LAYERS = [
    {"errors", "numerics", "llama_build", "core", "config_types", "config_sim", "config_planners", "config", "overrides", "registry", "io", "progress", "lifetime",
     "imports_log", "lazy", "__init__"},
    {"scene", "llm"},
    {"planning"},
    {"sim"},
    {"record"},
    {"planners"},
    {"metrics"},
    {"report"},
    {"stages"},
    {"cli"},
]
# inside the base layer the order matters too (what may import what)
BASE_ORDER = ["errors", "numerics", "llama_build", "core", "config_types", "config_sim", "config_planners", "config", "overrides", "registry", "io", "progress",
              "lifetime", "imports_log", "lazy", "__init__"]


def layer_of(part: str) -> int:
    return next(i for i, names in enumerate(LAYERS) if part in names)


def modules() -> dict[str, Path]:
    out = {}
    for p in sorted(PKG.rglob("*.py")):
        rel = p.relative_to(ROOT).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = p
    return out


def imports(path: Path) -> list[tuple[str, int, bool, str]]:
    """(imported interllm module, line, inside a function, source line) of a file."""
    src = path.read_text(encoding="utf-8")
    lines = src.splitlines()
    tree = ast.parse(src)
    nested: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            nested.update(id(n) for n in ast.walk(node) if isinstance(n, (ast.Import, ast.ImportFrom)))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        else:
            continue
        for name in names:
            out.append((name, node.lineno, id(node) in nested, lines[node.lineno - 1]))
    return out


def top_part(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def test_every_package_has_a_layer():
    parts = {top_part(m) for m in modules()}
    assert parts <= set().union(*LAYERS), f"packages without a layer: {sorted(parts - set().union(*LAYERS))}"


def test_imports_only_run_down_the_layers():
    mods = modules()
    bad = []
    for mod, path in mods.items():
        src = top_part(mod)
        for name, line, _, _ in imports(path):
            if not name.startswith("interllm") or name not in mods:
                continue
            dst = top_part(name)
            if dst == src:
                continue
            ls, ld = layer_of(src), layer_of(dst)
            if ld > ls or (ld == ls and ls != 0) or (ls == ld == 0 and BASE_ORDER.index(dst) > BASE_ORDER.index(src)):
                bad.append(f"{path.relative_to(ROOT)}:{line}: {src} (layer {ls}) imports {name} (layer {ld})")
    assert not bad, "imports up or across the layer order:\n" + "\n".join(bad)


def test_no_module_import_cycle():
    mods = modules()
    graph = {m: sorted({n for n, _, nested, _ in imports(p) if n in mods and n != m and not nested})
             for m, p in mods.items()}
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> None:
        state[m] = 1
        stack.append(m)
        for n in graph[m]:
            if n.startswith(m + "."):  # a package's own __init__ importing its modules is not a cycle
                continue
            if state.get(n) == 1:
                cyc = stack[stack.index(n):] + [n]
                if not all(c.startswith(n + ".") or c == n for c in cyc[1:-1]):
                    pytest.fail("import cycle: " + " -> ".join(cyc))
            elif n not in state:
                visit(n)
        stack.pop()
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m)


def test_imports_inside_functions_say_why():
    bad = []
    for path in modules().values():
        for _, line, nested, text in imports(path):
            if nested and "# lazy" not in text and "lazy:" not in text:
                bad.append(f"{path.relative_to(ROOT)}:{line}: {text.strip()}")
    assert not bad, "imports inside functions without a '# lazy: <why>' comment:\n" + "\n".join(sorted(set(bad)))


def test_the_layer_check_fails_on_an_upward_import(tmp_path, monkeypatch):
    """The check itself: a scene module importing the planners is reported."""
    fake = tmp_path / "interllm" / "scene"
    fake.mkdir(parents=True)
    (fake / "bad.py").write_text("from interllm.planners.base import PLANNERS\n")
    (tmp_path / "interllm" / "planners").mkdir()
    (tmp_path / "interllm" / "planners" / "base.py").write_text("")
    monkeypatch.setattr(__import__(__name__), "ROOT", tmp_path)
    monkeypatch.setattr(__import__(__name__), "PKG", tmp_path / "interllm")
    with pytest.raises(AssertionError, match=r"scene/bad.py:1: scene \(layer 1\) imports interllm.planners.base"):
        test_imports_only_run_down_the_layers()


def test_the_metrics_compute_and_the_report_writes():
    """``interllm.metrics`` holds the numbers only: none of its modules imports matplotlib or the
    report, or writes Markdown, HTML or pictures (the report package does)."""
    writes = ("savefig", ".md\"", ".html\"", ".png\"", "imsave")
    for name, path in modules().items():
        if not name.startswith("interllm.metrics"):
            continue
        src = path.read_text(encoding="utf-8")
        bad = [m for m, *_ in imports(path) if m.startswith(("matplotlib", "interllm.report"))]
        bad += [w for w in writes if w in src]
        assert not bad, f"{path.relative_to(ROOT)} draws or writes the report: {bad}"
