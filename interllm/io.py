"""Atomic, deterministic file output shared by every stage, confined to the run's folders.

Names from input data (scene, mission and planner ids) become file names only through
:func:`child_path`, which checks each against :data:`NAME_RULE`. Every write of this module (and of
the writers that call :func:`check_inside`: the MCAP recorder, the call log, the plots) checks
that the resolved target lies inside the folders a stage or run confined its writes to
(:func:`confine_writes`), so a ``..``, an absolute path or a symlinked output folder cannot lead a
write out of them, whichever code path built the name.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
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

WRITE_ROOTS_ENV = "INTERLLM_WRITE_ROOTS"  # os.pathsep-joined folders writes are confined to (inherited by workers)
NAME_MAX = 100  # [characters] longest id that becomes a file or folder name
NAME_RULE = (f"1 to {NAME_MAX} characters of A-Z a-z 0-9 _ . -, starting with a letter, digit or _ "
             f"(so never '.', '..', a path or a hidden file), and no Windows device name (CON, NUL, COM1, ...)")
_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.\-]*")
_DEVICE_NAMES = frozenset({"con", "prn", "aux", "nul", *(f"com{i}" for i in range(10)), *(f"lpt{i}" for i in range(10))})


class UnsafePathError(UserError, ValueError):
    """A name from input data cannot be a file name, or a write would land outside the folders the
    run confined its writes to (a ``..``, an absolute path, a symlinked folder)."""


def shown(value: object, limit: int = 60) -> str:
    """``repr(value)`` cut to ``limit`` characters, for messages about hostile input."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(str(value))} characters)"


def name_problem(name: object) -> str | None:
    """Why ``name`` cannot be one file or folder name (None: it can); see :data:`NAME_RULE`."""
    if not isinstance(name, str):
        return f"is a {type(name).__name__}, not a string"
    if not 1 <= len(name) <= NAME_MAX:
        return f"has {len(name)} characters (1 to {NAME_MAX} allowed)"
    if not _NAME.fullmatch(name):
        return "has characters or a form a file name must not have"
    if name.split(".")[0].lower() in _DEVICE_NAMES:
        return "is a reserved device name on Windows"
    return None


def check_name(name: object, what: str) -> str:
    """``name`` unchanged if it can be a file or folder name, else :class:`UnsafePathError` naming
    ``what`` it is (e.g. "the scene id ($.id of scene.json)") and the rule."""
    problem = name_problem(name)
    if problem is not None:
        raise UnsafePathError(f"{what} {shown(name)} {problem}: it becomes a file name, so it must be {NAME_RULE}; "
                              f"rename it in the input")
    return name  # type: ignore[return-value]


def write_roots() -> tuple[Path, ...]:
    """The resolved folders writes are confined to (empty: unconfined, as in library use)."""
    raw = os.environ.get(WRITE_ROOTS_ENV, "")
    return tuple(Path(r) for r in raw.split(os.pathsep) if r)


@contextlib.contextmanager
def confine_writes(*roots: str | os.PathLike) -> Iterator[tuple[Path, ...]]:
    """Within the block, every write through this module (and :func:`check_inside`) must resolve
    inside one of ``roots`` (resolved now, so a root may itself be a link, e.g. data/ on a larger
    disk). Kept in the environment, so the spawned worker processes inherit it."""
    resolved = tuple(Path(r).resolve() for r in roots)
    before = os.environ.get(WRITE_ROOTS_ENV)
    os.environ[WRITE_ROOTS_ENV] = os.pathsep.join(map(str, resolved))
    try:
        yield resolved
    finally:
        if before is None:
            os.environ.pop(WRITE_ROOTS_ENV, None)
        else:
            os.environ[WRITE_ROOTS_ENV] = before


def check_inside(path: str | os.PathLike) -> Path:
    """``path`` unchanged if it resolves (links followed) inside the confined folders, or if writes
    are not confined; else :class:`UnsafePathError`."""
    path = Path(path)
    roots = write_roots()
    if not roots:
        return path
    target = path.resolve()
    if any(target == r or target.is_relative_to(r) for r in roots):
        return path
    via = next((p for p in (path, *path.parents) if p.is_symlink()), None)
    why = f"{via} is a symbolic link to {via.resolve()}" if via else f"it resolves to {target}"
    raise UnsafePathError(f"refusing to write {path}: {why}, outside the folders this run writes to "
                          f"({', '.join(map(str, roots))}); remove the link or the name that leads out "
                          f"(outputs are recreated)")


def child_path(root: str | os.PathLike, *names: str, what: str = "a name from the input") -> Path:
    """``root/names...`` after checking each name (:func:`check_name`) and the result (:func:`check_inside`)."""
    for name in names:
        check_name(name, what)
    return check_inside(Path(root).joinpath(*names))


class FolderInUseError(UserError, RuntimeError):
    """Another live process writes into the same run folder."""


LOCK_FILE = ".interllm.lock"  # in a run folder, held (flock) by the process writing it


@contextlib.contextmanager
def exclusive_folder(folder: str | os.PathLike) -> Iterator[Path]:
    """Hold ``folder`` (created if needed) for this process for the block: a second process asking
    for it while this one lives gets :class:`FolderInUseError` at once (an advisory ``flock`` on
    ``folder/.interllm.lock``, released by the kernel when the holder dies, so a killed run leaves
    no stale lock). Where the OS has no ``fcntl`` the folder is not held."""
    folder = ensure_dir(folder)
    try:
        import fcntl  # lazy: POSIX only
    except ImportError:
        yield folder
        return
    fd = os.open(folder / LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode("ascii", "replace").strip() or "another process"
            raise FolderInUseError(f"the run folder {folder} is in use by process {holder}: two runs in one folder "
                                   f"would mix their outputs; wait for it, or give this run its own folder "
                                   f"(hydra.run.dir=... or data_dir=...)") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode("ascii"), 0)
        yield folder
    finally:
        os.close(fd)


def ensure_dir(path: str | os.PathLike) -> Path:
    """``mkdir -p`` of a folder inside the confined folders (checked first: nothing is created outside)."""
    path = check_inside(path)
    path.mkdir(parents=True, exist_ok=True)
    return path


@contextlib.contextmanager
def temp_file_beside(path: Path) -> Iterator[str]:
    """The name of a new, empty file in ``path``'s folder, with a new file's usual permissions (not
    mkstemp's owner-only 0600). Write it (``write_synced``), then move it into place (``os.replace``
    or ``os.link``) inside the block; whatever is still at that name when the block ends, by an
    error or not, is removed, so a failure leaves nothing half-written behind. ``path`` must lie
    inside the confined folders (:func:`check_inside`)."""
    check_inside(path)
    ensure_dir(path.parent)
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
