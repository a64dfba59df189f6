"""Atomic, deterministic file output shared by every stage."""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from interllm.core import jsonfmt
from interllm.errors import UserError


def _umask() -> int:
    """The process umask, read without changing it where the OS tells (Linux); elsewhere set and
    restored once, at import."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0)
    os.umask(mask)
    return mask


_FILE_MODE = 0o666 & ~_umask()  # what open() would give a new file (mkstemp makes it 0600)


@contextlib.contextmanager
def temp_file_beside(path: Path) -> Iterator[str]:
    """The name of a new, empty file in ``path``'s folder, with a new file's usual permissions (not
    mkstemp's owner-only 0600). Write it (``write_synced``), then move it into place (``os.replace``
    or ``os.link``) inside the block; whatever is still at that name when the block ends, by an
    error or not, is removed, so a failure leaves nothing half-written behind."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        try:
            os.fchmod(fd, _FILE_MODE)
        finally:
            os.close(fd)
        yield tmp
    finally:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass


def write_synced(name: str, data: bytes) -> None:
    """Write ``data`` to the file ``name`` and fsync it (its bytes are on disk before a rename)."""
    with open(name, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write to a temp file in the same folder, fsync, then rename over ``path`` (which gets the
    usual permissions of a new file)."""
    path = Path(path)
    with temp_file_beside(path) as tmp:
        write_synced(tmp, data)
        os.replace(tmp, path)


def atomic_create_bytes(path: str | os.PathLike, data: bytes) -> bool:
    """Create ``path`` with ``data`` unless it exists, atomically (a complete file or none): True if
    this call created it, False if it was there already. Where the file system has no hard links,
    falls back to ``atomic_write_bytes`` (the last writer wins)."""
    path = Path(path)
    with temp_file_beside(path) as tmp:
        write_synced(tmp, data)
        try:
            os.link(tmp, path)
        except FileExistsError:
            return False
        except OSError:  # no hard links here
            os.replace(tmp, path)
        return True


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def write_json(path: str | os.PathLike, obj: Any) -> None:
    atomic_write_text(path, jsonfmt.pretty(obj))


class InputFileError(UserError, ValueError):
    """A file the user gave cannot be read as what it should be; ``problem`` says why and where
    (byte offset, line and column), ``path`` which file."""

    def __init__(self, path: str | os.PathLike, problem: str) -> None:
        super().__init__(f"{path}: {problem}")
        self.path, self.problem = str(path), problem

    def __reduce__(self):
        return (type(self), (self.path, self.problem))


def read_bytes(path: str | os.PathLike) -> bytes:
    """The file's bytes, or :class:`InputFileError` (missing, a directory, unreadable)."""
    path = Path(path)
    try:
        return path.read_bytes()
    except FileNotFoundError:
        raise InputFileError(path, "file not found") from None
    except IsADirectoryError:
        raise InputFileError(path, "is a directory, not a file") from None
    except PermissionError:
        raise InputFileError(path, "cannot be read (permission denied)") from None
    except OSError as e:
        raise InputFileError(path, f"cannot be read ({e.strerror or e})") from None


def decode_utf8(data: bytes, path: str | os.PathLike) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise InputFileError(path, f"byte {e.start}: not UTF-8 text ({data[e.start:e.start + 4]!r}); save the "
                                   f"file as UTF-8") from None


def parse_json(text: str, path: str | os.PathLike) -> Any:
    """``json.loads`` with every failure as an :class:`InputFileError` naming line and column."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as e:
        raise InputFileError(path, f"line {e.lineno} column {e.colno}: invalid JSON: {e.msg}") from None
    except RecursionError:
        raise InputFileError(path, "invalid JSON: nested too deeply (thousands of [ or { without their "
                                   "closing brackets?)") from None


def read_json(path: str | os.PathLike) -> Any:
    """Read a UTF-8 JSON file; any problem is an :class:`InputFileError` naming the file and where."""
    return parse_json(decode_utf8(read_bytes(path), path), path)
