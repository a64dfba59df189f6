"""Imported through ``planner.modules`` by a test that kills the missions stage (no tests here).

Every process imports ``planner.modules``; in a missions worker (a process started by
multiprocessing) this module holds each run at its start, once its run log is open as
``<mission>.mcap.partial``: the worker writes a marker file ``<INTERLLM_TEST_HELD_DIR>/<pid>`` and
waits there until it is killed. The test acts when every worker has written its marker, so the
workers are certain to be running and writing when it does, on any machine. 600 s bound a test that
never kills them.
"""

from __future__ import annotations

import multiprocessing
import os
import time
from pathlib import Path

from interllm.stages import missions

HELD_DIR_ENV = "INTERLLM_TEST_HELD_DIR"
_run_mission = missions.run_mission


def _held_run(*args, **kw):
    held_dir = os.environ.get(HELD_DIR_ENV)
    if held_dir and multiprocessing.parent_process() is not None:  # a worker, not the stage itself
        Path(held_dir, str(os.getpid())).touch()
        time.sleep(600)
        raise RuntimeError("held run: the test did not kill this worker within 600 s")
    return _run_mission(*args, **kw)


missions.run_mission = _held_run
