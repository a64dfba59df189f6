"""Scenes shared by the jobs of a re-make: the scenes stage's output made once per scene setting.

Every job of a sweep (and the mechanism runs of one benchmark) measures the same houses with the
same simulator: the scenes stage's output is a function of the config's ``seed``, ``benchmark``,
``scene``, ``mission`` and ``sim`` sections (the params the DVC stage lists), the code, and the
benchmark's files. With ``scenes_cache`` set (``make sweeps`` and ``make mechanism`` set it), a
job looks up ``<scenes_cache>/<key>/`` under the sha256 of those (:func:`scenes_key`) and copies
it instead of measuring again; the first job of a setting stores its scenes there. A stored entry
is complete or absent: it is copied to a temporary folder and renamed into place, so a job killed
while storing leaves nothing another job could take for an entry.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Optional

from interllm.stages.resume import code_files, files_digest

SCENE_SECTIONS = ("seed", "benchmark", "scene", "mission", "sim")  # the scenes stage's params (dvc.yaml)


def scenes_key(resolved_config: Mapping, root: Path, benchmark: Optional[Path]) -> str:
    """sha256 of what the scenes stage's output depends on (module doc); ``benchmark``: the frozen
    benchmark's folder (None when the run draws its own houses)."""
    sections = json.dumps({k: resolved_config.get(k) for k in SCENE_SECTIONS}, sort_keys=True, default=str)
    parts = [sections, files_digest(root, code_files(root))]
    if benchmark is not None and benchmark.is_dir():
        parts.append(files_digest(benchmark, [p for p in benchmark.rglob("*") if p.is_file()]))
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()


class SharedScenes:
    """The scenes of one key in a store folder (``scenes_cache``)."""

    def __init__(self, store: str | os.PathLike, key: str) -> None:
        self.entry = Path(store) / key

    def fetch(self, out: Path) -> bool:
        """Copy the stored scenes into ``out`` (which must not exist yet); False when none are stored."""
        if not self.entry.is_dir():
            return False
        shutil.copytree(self.entry, out)
        return True

    def store(self, scenes: Path) -> None:
        """Store ``scenes`` (a finished scenes stage's output) under the key, unless another job did."""
        if self.entry.is_dir():
            return
        tmp = self.entry.with_name(f".{self.entry.name}.{os.getpid()}.tmp")
        shutil.rmtree(tmp, ignore_errors=True)
        shutil.copytree(scenes, tmp)
        try:
            os.replace(tmp, self.entry)
        except OSError:  # another job stored it meanwhile: theirs is the same bytes
            shutil.rmtree(tmp, ignore_errors=True)
