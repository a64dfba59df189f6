"""The one base class of errors a user can fix: bad input or a bad environment.

A ``UserError``'s message names the problem (the config key, the file and JSON path or byte
offset, the URL) and the fix; entry points print it as one line, without a traceback. Any other
exception is a bug and keeps its traceback. Standard library only (``interllm.numerics`` uses it
before numpy loads).
"""

from __future__ import annotations

import errno
from typing import Optional

_DISK_FULL = (errno.ENOSPC, errno.EDQUOT)
_NO_WRITE = (errno.EROFS, errno.EACCES, errno.EPERM)


class UserError(Exception):
    """Bad input or environment; the message says what and how to fix it."""


class StageError(UserError, RuntimeError):
    """A stage failed on a user-fixable error in one of its jobs (the message names the job).
    Plain message only, so it pickles from a worker process to the parent."""


class MissingInputError(UserError, FileNotFoundError):
    """An input file or folder a stage or command needs is absent; the message says what makes it."""


class OutputError(UserError, OSError):
    """An output cannot be written: the disk is full, the folder is read-only or not this user's, or
    a file stands where an output folder belongs (the message says which and what to do). What was
    written before stays as it is."""


INTERRUPTED_EXIT = 130  # the shell's status for a process stopped by Ctrl-C (128 + SIGINT)


def interrupted_message(what: str) -> str:
    """What a Ctrl-C leaves behind and how to go on, for ``what`` (e.g. "stage 'missions'")."""
    return (f"{what} interrupted (Ctrl-C): the files it had finished are kept, none is half-written (an "
            f"unfinished run log stays as a .mcap.partial); rerun the same command to finish")


def output_error(e: Optional[BaseException]) -> Optional[OutputError]:
    """The :class:`OutputError` for a full disk or an unwritable folder anywhere in ``e``'s chain
    (the exception, its causes and contexts), or None: any other error is a bug and keeps its traceback."""
    seen: set[int] = set()
    while e is not None and id(e) not in seen:
        seen.add(id(e))
        if isinstance(e, OSError) and e.errno in _DISK_FULL + _NO_WRITE:
            return OutputError(f"{_what_failed(e)}; the files written before are kept")
        e = e.__cause__ or e.__context__
    return None


def _what_failed(e: OSError) -> str:
    """Which file could not be written, why, and the fix."""
    where = e.filename or "an output file"
    if e.errno in _DISK_FULL:
        return (f"cannot write {where}: {e.strerror} (the disk is full); free some space, or move the project "
                f"(its data folder, data_dir) to a larger disk, and rerun")
    if e.errno == errno.EROFS:
        return f"cannot write {where}: {e.strerror}; run in a writable copy of the project"
    return (f"no access to {where}: {e.strerror}; give this user write access to it and its folder (chmod, "
            f"chown), or run in a writable copy of the project")
