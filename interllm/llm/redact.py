"""Keeping API keys out of messages and logs: a server's text (an error body, a page) may echo the
request's key, and that text is quoted in the errors and warnings the LLM layer raises.

:func:`redact` replaces, in any text about to be quoted, the keys the backend sends (the values of
the environment variables it reads them from, e.g. the one named by ``llm.api_key_env``) and any
``Bearer <token>`` (an echoed ``Authorization`` header) with ``[redacted]``. Quote a server's text
only through it, and redact before cutting the text short (a cut key would survive).
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable

REDACTED = "[redacted]"
MIN_SECRET_LEN = 8  # shorter values (e.g. a local server's dummy key "x") are no secret worth garbling text for
_BEARER = re.compile(r"(?i)(bearer(?:\s+|%20|\+))(?!\[redacted\])[^\s\"'\\,;&<>)\]}]+")


def env_secrets(names: Iterable[str]) -> tuple[str, ...]:
    """The values of the environment variables ``names`` that are set and long enough to be keys."""
    out = []
    for name in names:
        value = os.environ.get(name, "") if name else ""
        if len(value) >= MIN_SECRET_LEN:
            out.append(value)
    return tuple(out)


def redact(text: object, secrets: Iterable[str] = ()) -> str:
    """``str(text)`` with every ``secrets`` value and every bearer token replaced by ``[redacted]``."""
    s = str(text)
    for secret in sorted(set(secrets), key=len, reverse=True):  # a key inside another: the longer first
        if secret:
            s = s.replace(secret, REDACTED)
    return _BEARER.sub(lambda m: m.group(1) + REDACTED, s)
