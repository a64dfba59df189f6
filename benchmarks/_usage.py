"""The command line the benchmark scripts without an argparse parser share: ``-h`` / ``--help``
prints the script's docstring (its usage lines and what it measures) and exits before anything
runs; a script that takes no arguments refuses any it is given rather than ignoring them."""

from __future__ import annotations

import sys
from collections.abc import Sequence

HELP = ("-h", "--help")


def overrides(argv: Sequence[str], doc: str | None) -> list[str]:
    """``argv`` as Hydra overrides, after ``--help`` (which prints ``doc`` and exits 0)."""
    if any(a in HELP for a in argv):
        print(doc or "")
        raise SystemExit(0)
    return list(argv)


def no_arguments(argv: Sequence[str], doc: str | None) -> None:
    """Exit 0 after printing ``doc`` on ``--help``; exit 2 naming any other argument."""
    overrides(argv, doc)
    if argv:
        script = sys.argv[0].rsplit("/", 1)[-1]
        print(f"{script} takes no arguments, got {' '.join(argv)!r}; --help says what it measures", file=sys.stderr)
        raise SystemExit(2)
