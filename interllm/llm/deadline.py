"""A whole-call deadline for blocking backend calls.

HTTP clients bound each socket read, not a call: a server that trickles one byte a second keeps a
request alive forever. :func:`call_with_deadline` runs the call in a daemon thread and stops
waiting when the deadline passes; the abandoned thread holds only its connection, which the
caller drops (the backend opens a new client), and it cannot keep the process alive at exit.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TypeVar

from interllm.errors import UserError

T = TypeVar("T")
# an HTTP client library's own timeout, in units of the deadline: set past it, so that the deadline
# always notices a hang first and a hang always reads as one
LIBRARY_TIMEOUT = 2.0


class DeadlineExceeded(UserError, TimeoutError):
    """A backend call took longer than its whole-call deadline (``llm.timeout_s``)."""


def call_with_deadline(fn: Callable[[], T], timeout_s: float, describe: str,
                       configured_s: float | None = None) -> T:
    """``fn()``, or :class:`DeadlineExceeded` after ``timeout_s`` [s] of waiting for it.

    describe: what is called, for the message (e.g. "Ollama chat at http://127.0.0.1:11434");
    configured_s: the ``llm.timeout_s`` the message names when ``timeout_s`` is only what is left of
    it (an attempt after a retry; default: ``timeout_s``).
    """
    box: dict = {}
    done = threading.Event()

    def run() -> None:
        try:
            box["value"] = fn()
        except BaseException as e:  # noqa: BLE001 - re-raised in the caller's thread
            box["error"] = e
        finally:
            done.set()

    threading.Thread(target=run, daemon=True, name="llm-call").start()
    if not done.wait(timeout_s):
        raise deadline_exceeded(describe, timeout_s if configured_s is None else configured_s)
    if "error" in box:
        raise box["error"]
    return box["value"]


def deadline_exceeded(describe: str, timeout_s: float) -> DeadlineExceeded:
    """The one message of a call that outlived its deadline (also for a client library's own timeout,
    so that a hang reads the same whichever timer noticed it first)."""
    return DeadlineExceeded(f"{describe} did not answer within llm.timeout_s={timeout_s:g} s (a whole-call "
                            f"deadline); the server is stuck or too slow: check it, or raise llm.timeout_s")
