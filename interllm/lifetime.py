"""Child processes that do not outlive their parent.

:func:`die_with_parent` makes the calling process receive ``sig`` when its parent exits (Linux:
``prctl(PR_SET_PDEATHSIG)``, delivered by the kernel even when the parent is killed with
SIGKILL; elsewhere a daemon thread polls the parent pid once a second). The missions stage's
workers call it first thing, so a killed stage leaves no worker writing into ``data/runs``.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import signal
import sys
import threading
import time

PR_SET_PDEATHSIG = 1
STAGE_PARENT_ENV = "INTERLLM_STAGE_PARENT"  # pid of the process that ran pipeline/stage (DVC), set by that script


def _prctl_pdeathsig(sig: int) -> bool:
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        return libc.prctl(PR_SET_PDEATHSIG, int(sig), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _watch_parent(parent: int, sig: int, period_s: float) -> None:
    while os.getppid() == parent:
        time.sleep(period_s)
    os.kill(os.getpid(), sig)


def die_with_parent(expected_parent: int | None = None, sig: int = signal.SIGKILL,
                    period_s: float = 1.0) -> None:
    """Receive ``sig`` when the parent process exits.

    expected_parent: the parent's pid as the parent saw it; if the parent is already gone (the
    child was re-parented before this call), the signal is sent at once. period_s: poll period of
    the fallback watcher [s].
    """
    parent = os.getppid() if expected_parent is None else expected_parent
    if not _prctl_pdeathsig(sig):
        threading.Thread(target=_watch_parent, args=(parent, sig, period_s), daemon=True,
                         name="parent-watch").start()
    if os.getppid() != parent:  # the parent died before the prctl took effect
        os.kill(os.getpid(), sig)


def die_with_stage_runner(sig: int = signal.SIGTERM) -> None:
    """Under DVC (``DVC_STAGE`` set): receive ``sig`` when the ``dvc`` process that started this
    stage exits. ``pipeline/stage`` records dvc's pid in ``INTERLLM_STAGE_PARENT`` before it starts
    Python, so a dvc killed while the interpreter was still starting or importing is noticed
    here, not missed (the stage would otherwise run on with no parent). One window stays open: a
    dvc that dies between forking the shell and the shell's start-up hands the shell its reaper's
    pid as ``$PPID``; no shell can learn the pid of a parent already gone. Called by the
    ``pipeline`` package before it imports anything else. The variable is taken out of the environment, so the
    stage's own children (the missions workers, which import ``pipeline`` again) die with the stage,
    not with dvc, whose pid is not their parent's."""
    if not os.environ.get("DVC_STAGE"):
        return
    try:
        parent = int(os.environ.pop(STAGE_PARENT_ENV, ""))
    except ValueError:
        parent = os.getppid()
    die_with_parent(expected_parent=parent, sig=sig)
