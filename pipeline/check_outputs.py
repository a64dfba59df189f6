"""Before `dvc repro` (`make repro` runs this first): refuse output folders that are symbolic links.

DVC makes a stage's output folder writable (mode 0777) before the stage runs, following a link to
wherever it points, so a `data/report` linked to a folder outside the project would have that
folder's mode changed even though the stage itself refuses to write through the link
(interllm.io.check_inside). This check stops before DVC touches anything:

    python -m pipeline.check_outputs        # exit 2 and the links to remove, or exit 0
"""

from __future__ import annotations

import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent


def dvc_outputs(root: Path = ROOT) -> list[Path]:
    """Every output path the stages of ``root/dvc.yaml`` declare (outs, metrics, plots)."""
    stages = (yaml.safe_load((root / "dvc.yaml").read_text(encoding="utf-8")) or {}).get("stages", {})
    paths = []
    for stage in stages.values():
        for kind in ("outs", "metrics", "plots"):
            for entry in stage.get(kind) or []:
                paths.append(root / (next(iter(entry)) if isinstance(entry, dict) else entry))
    return paths


def linked_outputs(root: Path = ROOT) -> list[Path]:
    """The declared outputs that are, or lie under, a symbolic link inside ``root`` (a link at or
    above ``root`` itself, e.g. the whole project on another disk, is fine)."""
    found = []
    for out in dvc_outputs(root):
        chain = [out, *out.parents]
        inside = chain[:chain.index(root)] if root in chain else [out]
        found += [p for p in inside if p.is_symlink() and p not in found]
    return sorted(set(found))


def main() -> int:
    links = linked_outputs()
    if not links:
        return 0
    where = "; ".join(f"{p.relative_to(ROOT)} -> {p.resolve()}" for p in links)
    print(f"error: DVC output folders must not be symbolic links ({where}): DVC would change the mode of "
          f"the folder they point to and the stage would write outside the project; remove the links "
          f"(rm {' '.join(str(p.relative_to(ROOT)) for p in links)}) and rerun: the outputs are recreated",
          file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
