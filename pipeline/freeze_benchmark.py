"""Freeze a versioned benchmark: ``python -m pipeline.freeze_benchmark NAME [hydra overrides]``.

Draws the houses and missions of the composed config (the scenes stage, with ``benchmark=''``) and
writes them under ``<benchmark_dir>/NAME/`` (``interllm.stages.freeze``). Use the benchmark with
``benchmark=NAME``; commit the folder. An existing NAME is refused: a version never changes.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from interllm.errors import UserError
from interllm.io import confine_writes
from interllm.stages.freeze import freeze_benchmark
from interllm.stages.provenance import git_commit
from pipeline._common import ROOT, setup_logging
from pipeline._hydra import compose, to_config


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m pipeline.freeze_benchmark", description=__doc__.split("\n")[0])
    ap.add_argument("name", help="the benchmark's name, e.g. paper-v3 (a-z, 0-9, '.', '_', '-')")
    ap.add_argument("overrides", nargs="*", help="Hydra overrides of conf/ (e.g. experiment=mechanism)")
    args = ap.parse_args(argv)
    try:
        cfg = to_config(compose([*args.overrides, "benchmark="]))
        if not Path(cfg.benchmark_dir).is_absolute():
            cfg.benchmark_dir = str(ROOT / cfg.benchmark_dir)
        setup_logging(cfg.verbose)
        with confine_writes(cfg.benchmark_dir):
            dest, t = freeze_benchmark(cfg, args.name, git_commit())
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"froze benchmark {args.name!r} in {dest}: {t['houses']} houses, {t['missions']} missions, "
          f"{t['slots_fulfillable']} of {t['slots_drawn']} slots fulfillable by measurement; use it with "
          f"benchmark={args.name} and commit the folder")
    return 0


if __name__ == "__main__":
    sys.exit(main())
