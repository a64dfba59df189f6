"""A package's public names, imported from their modules on first use (PEP 562), so that importing
one module of a package (``interllm.llm.calllog``) does not load the whole package: a DVC stage
then depends only on the modules it runs (``dvc.yaml`` lists them; tests/test_pipeline_e2e.py
checks). Standard library only.

    __getattr__, __dir__ = lazy_exports(__name__, {"make_client": "interllm.llm.client", ...})
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping


def lazy_exports(package: str, exports: Mapping[str, str]) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """Module ``__getattr__`` and ``__dir__`` for ``package``: name -> the module that defines it."""
    table = dict(exports)

    def __getattr__(name: str) -> object:
        module = table.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(module), name)

    def __dir__() -> list[str]:
        return sorted(table)

    return __getattr__, __dir__


def exports_of(modules: Mapping[str, tuple[str, ...]]) -> dict[str, str]:
    """{module: (names, ...)} -> {name: module}."""
    return {name: module for module, names in modules.items() for name in names}
