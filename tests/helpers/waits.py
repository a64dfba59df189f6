"""Bounded waits for the tests that interrupt, kill or race a process (no tests here).

Such a test acts at a moment the process announces: a line it prints, or a marker file it writes
when it STARTS a piece of work, never an output that appears only once the work is done (on a
loaded machine the work may be over before the test looks). Every wait has a deadline and fails
with a message that says what did not happen, and the process's output so far.
"""

from __future__ import annotations

import subprocess
import threading
import time
from collections.abc import Callable

import pytest


class Output:
    """Reads a ``Popen``'s stdout and stderr (text pipes) to the end in background threads, so a full
    pipe never blocks the process, and lets a test wait for a line on either."""

    def __init__(self, proc: subprocess.Popen) -> None:
        self.proc = proc
        self.lines: dict[str, list[str]] = {}
        self._changed = threading.Condition()  # its lock is re-entrant: the messages read the lines under it
        self._threads = [threading.Thread(target=self._read, args=(name, stream), daemon=True)
                         for name, stream in (("stdout", proc.stdout), ("stderr", proc.stderr)) if stream is not None]
        for t in self._threads:
            t.start()

    def _read(self, name: str, stream) -> None:
        for line in stream:
            with self._changed:
                self.lines.setdefault(name, []).append(line)
                self._changed.notify_all()
        with self._changed:
            self.lines.setdefault(name, [])
            self._changed.notify_all()

    def text(self, name: str) -> str:
        with self._changed:
            return "".join(self.lines.get(name, []))

    def _so_far(self) -> str:
        return f"stdout so far:\n{self.text('stdout')}\nstderr so far:\n{self.text('stderr')}"

    def wait_for_line(self, name: str, want: str, timeout: float, what: str) -> str:
        """The first line of stream ``name`` ("stdout" or "stderr") that holds ``want``; fails the test
        naming ``what`` when the process ends first or ``timeout`` [s] pass."""
        deadline = time.monotonic() + timeout
        with self._changed:
            while True:
                hit = next((x for x in self.lines.get(name, []) if want in x), None)
                if hit is not None:
                    return hit
                if self.proc.poll() is not None and not any(t.is_alive() for t in self._threads):
                    pytest.fail(f"{what}: the process ended (status {self.proc.returncode}) before it printed "
                                f"{want!r} on {name}\n{self._so_far()}")
                left = deadline - time.monotonic()
                if left <= 0:
                    pytest.fail(f"{what}: no {want!r} on {name} within {timeout:g} s\n{self._so_far()}")
                self._changed.wait(min(left, 0.1))

    def finish(self, timeout: float, what: str) -> tuple[str, str]:
        """Wait (at most ``timeout`` [s]) for the process to end and its pipes to close; its whole stdout
        and stderr. Fails the test naming ``what`` (and kills the process) when it does not end."""
        try:
            self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(timeout=30)
            pytest.fail(f"{what}: the process was still running {timeout:g} s later (killed now)\n{self._so_far()}")
        for t in self._threads:
            t.join(timeout=30)
        return self.text("stdout"), self.text("stderr")


def wait_until(ready: Callable[[], bool], timeout: float, what: str, gone: Callable[[], bool] | None = None,
               period_s: float = 0.02, details: Callable[[], str] = lambda: "") -> None:
    """Poll ``ready()`` every ``period_s`` [s] until it is true; fail the test naming ``what`` after
    ``timeout`` [s], or as soon as ``gone()`` says the process it waits on has ended (its ``details()``
    in the message)."""
    deadline = time.monotonic() + timeout
    while not ready():
        if gone is not None and gone():
            pytest.fail(f"{what}: the process ended before that\n{details()}")
        if time.monotonic() > deadline:
            pytest.fail(f"{what}: not within {timeout:g} s\n{details()}")
        time.sleep(period_s)


def assert_running(proc: subprocess.Popen, what: str, output: Output | None = None) -> None:
    """The state a test waited for, checked right before it acts: ``proc`` has not ended."""
    status = proc.poll()
    assert status is None, (f"{what}: the process had already ended (status {status}) when the test was about to "
                            f"act; the test must hold it at a known point" +
                            (f"\n{output._so_far()}" if output is not None else ""))
