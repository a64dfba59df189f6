"""Retrying a backend call within its whole-call deadline: how long to wait before the next attempt
(the server's ``Retry-After``, else exponential backoff) and when to stop instead.

``llm.max_retries`` bounds the attempts after the first; ``llm.timeout_s`` bounds the whole call:
its attempts and the waits between them. A server that answers HTTP 429 or 503 with a
``Retry-After`` (seconds or an HTTP-date; OpenAI's ``retry-after-ms`` too) is waited for exactly
that long; one that asks to wait past the deadline stops the call at once with
:class:`ServerAskedToWait`, which says so and what to do (it is a rate limit or an overload, never
the model's fault). A backoff that would pass the deadline ends the retries: the caller raises the
last attempt's error.
"""

from __future__ import annotations

import email.utils
import math
import time
from collections.abc import Callable, Mapping
from typing import Optional

from interllm.errors import UserError

BACKOFF_S = 0.5  # [s] first retry delay when the server names none, doubled per retry
RETRY_AFTER_STATUSES = (429, 503)  # the statuses whose Retry-After header is honoured


class ServerAskedToWait(UserError, RuntimeError):
    """The server asked (Retry-After) to wait longer than what is left of the call's deadline."""


def retry_after_s(headers: Optional[Mapping[str, str]], now: Optional[float] = None) -> Optional[float]:
    """Seconds [s] the server asks to wait before a retry: ``retry-after-ms``, or ``Retry-After`` as
    delta-seconds or an HTTP-date (a date in the past: 0); None when absent or unreadable.

    headers: the response's headers (case-insensitive lookups, as httpx gives them, or a plain dict
    with lower-case names); now: the epoch time [s] a date is measured from (default: now).
    """
    if not headers:
        return None
    ms = _header(headers, "retry-after-ms")
    if ms is not None:
        try:
            v = float(ms) / 1000.0
            if math.isfinite(v):
                return max(0.0, v)
        except ValueError:
            pass
    value = _header(headers, "retry-after")
    if value is None:
        return None
    value = value.strip()
    try:
        v = float(value)
        return max(0.0, v) if math.isfinite(v) else None
    except ValueError:
        pass
    try:
        when = email.utils.parsedate_to_datetime(value)
    except (TypeError, ValueError, IndexError):
        return None
    if when is None or when.tzinfo is None:
        return None
    return max(0.0, when.timestamp() - (time.time() if now is None else now))


def _header(headers: Mapping[str, str], name: str) -> Optional[str]:
    v = headers.get(name)
    if v is None:
        v = next((val for k, val in headers.items() if str(k).lower() == name), None)
    return None if v is None else str(v)


class CallBudget:
    """The time and attempts one backend call has, its retries included.

    timeout_s: the whole-call deadline [s] (``llm.timeout_s``); max_retries: attempts after the
    first (``llm.max_retries``); sleep/clock: injectable for tests.
    """

    def __init__(self, timeout_s: float, max_retries: int, sleep: Callable[[float], None] = time.sleep,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.timeout_s = float(timeout_s)
        self.max_retries = int(max_retries)
        self._sleep, self._clock = sleep, clock
        self._end = clock() + self.timeout_s
        self.attempts = 0  # attempts started

    def remaining(self) -> float:
        """Seconds [s] left of the deadline (never below a millisecond, so an attempt can still start
        and be stopped by the deadline, which then names the hang)."""
        return max(0.001, self._end - self._clock())

    def start_attempt(self) -> float:
        """Count an attempt; the seconds [s] it may take."""
        self.attempts += 1
        return self.remaining()

    def wait_to_retry(self, retry_after: Optional[float], what: str) -> bool:
        """Sleep before the next attempt; False when none is left (retries used up, or a backoff past the
        deadline): the caller raises the last attempt's error.

        retry_after: what the server asked for [s] (None: exponential backoff from ``BACKOFF_S``);
        what: the server and its answer for the message, e.g. "the server at http://... answered HTTP 429".
        Raises :class:`ServerAskedToWait` when the server asks to wait past the deadline.
        """
        if self.attempts > self.max_retries:
            return False
        left = self._end - self._clock()
        if retry_after is not None:
            if retry_after >= left:
                raise ServerAskedToWait(
                    f"{what} and asked to wait {retry_after:.3g} s before retrying (Retry-After), beyond "
                    f"llm.timeout_s={self.timeout_s:g} s (the whole call's deadline, retries included; "
                    f"{max(0.0, left):.1f} s of it left): the server is rate-limiting or overloaded. Wait and "
                    f"rerun (answers already received are in the LLM cache), send fewer requests at once "
                    f"(jobs=1), or raise llm.timeout_s above {math.ceil(retry_after) + 1}")
            delay = retry_after
        else:
            delay = BACKOFF_S * 2 ** (self.attempts - 1)
            if delay >= left:
                return False
        self._sleep(delay)
        return True
