"""Files that long jobs keep on disk: atomic writes, damage-aware reads, directory locks.

Every file a job relies on to resume (dataset units and tables, evaluation records, manifests,
checkpoints) is written through `atomic_write`: a temporary file beside the target, flushed
and fsynced, renamed into place, and the directory entry fsynced. A reader therefore sees the
whole old file or the whole new one, also after a power cut. A file that is damaged anyway
(a full disk, a bad copy) is reported by `StoredFileError`, which names the file and says
what to do, instead of a traceback from deep inside a parser.

`DirectoryLock` keeps two runs out of the same output directory. It is an advisory
``fcntl.flock`` lock on ``{dir}/.lock``: the kernel drops it when its process dies, however
it dies, so a killed run never leaves a stale lock behind. The file records the holder's pid
and host for the message a second run prints.

Examples:
    >>> with atomic_write(Path("out/record.json"), "w") as handle:
    ...     json.dump(record, handle)
    >>> record = read_json(Path("out/record.json"), "delete it and rerun to recompute it")
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import socket
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np

from temp_gym.jobs import JobError

LOCK_NAME = ".lock"


class StoredFileError(JobError, ValueError):
    """A stored file is missing, truncated or unreadable; the message names it and the fix."""

    def __init__(self, path: str | Path, problem: str, remedy: str) -> None:
        self.path = Path(path)
        self.problem = problem
        self.remedy = remedy
        super().__init__(f"{path}: {problem}; {remedy}")


class LockedError(JobError, RuntimeError):
    """Another live process holds the lock of a directory."""


@contextlib.contextmanager
def atomic_write(path: str | Path, mode: str = "wb") -> Iterator[IO]:
    """Open a temporary file for writing; on success fsync it and rename it to ``path``.

    On an exception the temporary file is removed and ``path`` is untouched.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        with open(temporary, mode) as handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    _fsync_directory(path.parent)


def _fsync_directory(directory: Path) -> None:
    """Make a rename durable (no-op where directories cannot be opened)."""
    try:
        descriptor = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(descriptor)
    except OSError:
        pass
    finally:
        os.close(descriptor)


def jsonable(value: Any) -> Any:
    """``json.dump``'s ``default``: a numpy scalar as its Python value; anything else fails."""
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON-able: {type(value).__name__}")


def write_json_atomic(path: str | Path, payload: Any, **dump_options: Any) -> None:
    """Write ``payload`` as JSON through `atomic_write`: the package's one JSON writer.

    Indented, keys sorted, numpy scalars as numbers (`jsonable`) unless ``dump_options`` (any
    of ``json.dump``'s) say otherwise; evaluation records, for instance, are written compact
    and in their own key order, with NaN refused.
    """
    options = {"indent": 2, "sort_keys": True, "default": jsonable, **dump_options}
    with atomic_write(path, "w") as handle:
        json.dump(payload, handle, **options)


def remove_leftovers(directory: str | Path) -> None:
    """Delete the temporary files of writers that were killed before their rename."""
    for leftover in Path(directory).glob(".*.tmp*"):
        leftover.unlink(missing_ok=True)


def read_capped(path: str | Path, limit: int, what: str, remedy: str) -> bytes:
    """The bytes of the regular file ``path`` if it holds at most ``limit`` of them.

    A device or pipe (``/dev/zero``, whose reading never ends) and a larger file are refused
    before anything is read, and reading stops at ``limit`` in case the file grows meanwhile.

    Raises:
        FileNotFoundError, IsADirectoryError, PermissionError: as `open` raises them.
        StoredFileError: not a regular file, or larger than ``limit`` (naming ``what``).
    """
    path = Path(path)
    status = os.stat(path)  # before opening: opening a pipe waits for a writer
    if stat.S_ISDIR(status.st_mode):
        raise IsADirectoryError(errno.EISDIR, "is a directory", str(path))
    if not stat.S_ISREG(status.st_mode):
        raise StoredFileError(path, f"not a regular file, so not {what}", remedy)
    if status.st_size > limit:
        raise StoredFileError(
            path, f"{status.st_size:,} bytes, more than {what} may hold ({limit:,})", remedy
        )
    with open(path, "rb") as handle:
        data = handle.read(limit + 1)
    if len(data) > limit:
        raise StoredFileError(path, f"more than {what} may hold ({limit:,} bytes)", remedy)
    return data


def read_json(path: str | Path, remedy: str) -> Any:
    """Parse a JSON file this package wrote; a damaged one raises `StoredFileError`."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise StoredFileError(path, "missing", remedy) from None
    except (OSError, UnicodeDecodeError) as error:
        raise StoredFileError(path, f"unreadable ({error})", remedy) from None
    if not text.strip():
        raise StoredFileError(path, "empty (a damaged file)", remedy)
    try:
        return json.loads(text)
    except (json.JSONDecodeError, RecursionError) as error:
        raise StoredFileError(path, f"damaged, not valid JSON ({error})", remedy) from None


class DirectoryLock:
    """An exclusive, crash-safe lock on a directory (see the module docstring).

    Args:
        directory: The directory to lock (created if missing).
        purpose: What the holder does there, for the other run's message.
        wait: as a context manager, wait for another holder to finish instead of raising
            `LockedError` (`acquire`'s ``wait``).
    """

    def __init__(self, directory: str | Path, purpose: str, wait: bool = False) -> None:
        self.directory = Path(directory)
        self.purpose = purpose
        self.wait = wait
        self._handle: IO | None = None

    @property
    def path(self) -> Path:
        """The lock file."""
        return self.directory / LOCK_NAME

    def acquire(self, wait: bool = False) -> None:
        """Take the lock; without ``wait``, raise `LockedError` naming the holder if it is taken.

        With ``wait``, block until the holder finishes (its process ends or releases it).
        """
        self.directory.mkdir(parents=True, exist_ok=True)
        handle = open(self.path, "a+")
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            if not wait:
                holder = self._holder(handle)
                handle.close()
                raise LockedError(
                    f"{self.directory} is in use by another run ({holder}); wait for it to "
                    "finish, or stop it, then rerun this command"
                ) from None
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX)
        handle.seek(0)
        handle.truncate()
        handle.write(f"pid {os.getpid()} on {socket.gethostname()}: {self.purpose}\n")
        handle.flush()
        self._handle = handle

    def holder(self) -> str:
        """Who holds the lock, as its file says (for messages)."""
        with open(self.path, "a+") as handle:
            return self._holder(handle)

    @staticmethod
    def _holder(handle: IO) -> str:
        handle.seek(0)
        return handle.read().strip() or "a process that has not written its pid yet"

    def is_held_elsewhere(self) -> bool:
        """Whether another process holds the lock right now."""
        if not self.path.exists():
            return False
        with open(self.path, "a+") as handle:
            try:
                fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                return True
            fcntl.flock(handle.fileno(), fcntl.LOCK_UN)
            return False

    def release(self) -> None:
        """Drop the lock (also dropped by the kernel when the process ends)."""
        if self._handle is not None:
            fcntl.flock(self._handle.fileno(), fcntl.LOCK_UN)
            self._handle.close()
            self._handle = None

    def __enter__(self) -> DirectoryLock:
        self.acquire(wait=self.wait)
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.release()
