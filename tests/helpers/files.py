"""File-system helpers for the tests that check nothing already written is lost."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest


def make_read_only(paths: list[Path]) -> list[Path]:
    """Make folders unwritable: permission bits for a normal user; for root (whom permission bits do
    not stop) the immutable attribute, where the file system has it. Returns what to undo."""
    for p in paths:
        p.chmod(0o555)
    if os.geteuid() != 0:
        return []
    done = []
    for p in paths:
        if subprocess.run(["chattr", "+i", str(p)], capture_output=True).returncode != 0:
            undo_read_only(done)
            pytest.skip("running as root on a file system without chattr +i: cannot make a folder read-only")
        done.append(p)
    return done


def undo_read_only(done: list[Path]) -> None:
    for p in done:
        subprocess.run(["chattr", "-i", str(p)], capture_output=True)
