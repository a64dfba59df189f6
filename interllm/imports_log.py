"""Which of the repository's source files a process loaded, for the check that every stage's
``dvc.yaml`` deps list the code it runs (tests/test_pipeline_e2e.py). Standard library only."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

ENV = "INTERLLM_IMPORTS_LOG"  # a file to append {"stage", "modules"} lines to (unset: do nothing)


def log_loaded_modules(stage: str) -> None:
    """With ``INTERLLM_IMPORTS_LOG=<file>``, append {"stage", "modules"}: the repository's source files
    this process has loaded (stage entry points and missions workers call it)."""
    out = os.environ.get(ENV)
    if not out:
        return
    root = Path(__file__).resolve().parent.parent
    files = set()
    for mod in list(sys.modules.values()):
        f = getattr(mod, "__file__", None)
        if not f or not f.endswith(".py"):
            continue
        path = Path(f).resolve()
        if path.is_relative_to(root) and path.relative_to(root).parts[0] in ("interllm", "pipeline"):
            files.add(path.relative_to(root).as_posix())
    with open(out, "a", encoding="utf-8") as fh:
        fh.write(json.dumps({"stage": stage, "modules": sorted(files)}) + "\n")
