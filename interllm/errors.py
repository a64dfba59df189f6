"""The one base class of errors a user can fix: bad input or a bad environment.

A ``UserError``'s message names the problem (the config key, the file and JSON path or byte
offset, the URL) and the fix; entry points print it as one line, without a traceback. Any other
exception is a bug and keeps its traceback. Standard library only (``interllm.numerics`` uses it
before numpy loads).
"""

from __future__ import annotations


class UserError(Exception):
    """Bad input or environment; the message says what and how to fix it."""


class StageError(UserError, RuntimeError):
    """A stage failed on a user-fixable error in one of its jobs (the message names the job).
    Plain message only, so it pickles from a worker process to the parent."""


class MissingInputError(UserError, FileNotFoundError):
    """An input file or folder a stage or command needs is absent; the message says what makes it."""
