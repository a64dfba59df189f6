"""The canonical JSON encodings of the library, each named for where it is used.

They differ in separators, indentation and fallbacks, and each one's bytes are part of a
contract (cache keys and checksums, committed files, run-log messages), so they are not merged.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any, Optional


def compact(obj: Any) -> str:
    """Cache keys and checksums: sorted keys, no spaces, UTF-8 kept, NaN refused."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False)


def pretty(obj: Any) -> str:
    """Files (records, candidates, metrics): sorted keys, indent 1, NaN refused, trailing newline."""
    return json.dumps(obj, indent=1, sort_keys=True, ensure_ascii=False, allow_nan=False) + "\n"


def message(obj: Any, default: Optional[Callable[[Any], Any]] = None) -> str:
    """Run-log JSON channels and call-log lines: sorted keys, default separators, UTF-8 kept;
    ``default`` converts what JSON lacks (numpy arrays, dataclasses)."""
    return json.dumps(obj, sort_keys=True, default=default, ensure_ascii=False)


def normalised(obj: Any) -> Any:
    """``obj`` as plain JSON types with sorted keys (a round trip through ``json``)."""
    return json.loads(json.dumps(obj, sort_keys=True))
