"""Progress bars for long stages (rich), quiet when not attached to a terminal."""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")


def progress(items: Iterable[T], description: str, total: int | None = None) -> Iterator[T]:
    """Iterate with a rich progress bar on a terminal (or INTERLLM_PROGRESS=1); plain otherwise."""
    show = sys.stderr.isatty() or os.environ.get("INTERLLM_PROGRESS") == "1"
    if not show or os.environ.get("INTERLLM_PROGRESS") == "0":
        yield from items
        return
    from rich.progress import (  # lazy: only when a terminal shows the bars
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
    )

    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), transient=False) as bar:
        task = bar.add_task(description, total=total)
        for it in items:
            yield it
            bar.advance(task)
