"""The layouts of the responses the client stores in the cache, checked whenever an entry is read.

An entry whose key and checksum hold may still hold a response of another layout (written by another
version or tool, or edited by hand with its checksum redone); the cache treats it as corrupt — a miss,
named in a warning and overwritten by the next store — rather than handing it to code that would
fail on it (:meth:`interllm.llm.cache.ResponseCache.get`'s ``layout``). Each check returns what is
wrong, or None.
"""

from __future__ import annotations

import json
import math
from typing import Any, Optional


def _is_int(x: Any) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def _finite_numbers(x: Any, n: int) -> bool:
    return isinstance(x, list) and len(x) == n and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in x)


def complete_problem(resp: Any, with_schema: bool) -> Optional[str]:
    """What keeps ``resp`` from being a generation's stored outcome (an answer, or a failure with
    ``failed: true``); ``with_schema``: the request had a JSON schema, so an answer's text is JSON."""
    if not isinstance(resp, dict):
        return "the response is not an object"
    if not isinstance(resp.get("text"), str):
        return "no string 'text'"
    if not (_is_int(resp.get("tokens_in")) and _is_int(resp.get("tokens_out"))):
        return "no integer 'tokens_in' and 'tokens_out'"
    errors = resp.get("errors", [])
    if not (isinstance(errors, list) and all(isinstance(e, str) for e in errors)):
        return "'errors' is not a list of strings"
    failed = resp.get("failed", False)
    if not isinstance(failed, bool):
        return "'failed' is not true or false"
    if failed:
        if not errors or not (_is_int(resp.get("attempts")) and resp["attempts"] >= 1):
            return "a failure without its errors and attempts"
        return None
    if with_schema:
        try:
            json.loads(resp["text"])
        except ValueError:
            return "the answer's 'text' is not the JSON its schema asked for"
    return None


def score_problem(resp: Any, n: int) -> Optional[str]:
    """What keeps ``resp`` from being the stored scores of ``n`` continuations."""
    if not isinstance(resp, dict):
        return "the response is not an object"
    for key in ("raw", "scores"):
        if not _finite_numbers(resp.get(key), n):
            return f"no list '{key}' of {n} finite numbers"
    calibration = resp.get("calibration")
    if calibration is not None and not _finite_numbers(calibration, n):
        return f"'calibration' is neither null nor a list of {n} finite numbers"
    if not _is_int(resp.get("tokens_in")):
        return "no integer 'tokens_in'"
    return None
