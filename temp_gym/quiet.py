"""Keep third-party chatter out of the user's terminal.

A user who plans a path or loads a dataset should see what they asked for, not the banners of
the libraries underneath:

* pybullet prints its build time when imported and ``argv[0]=`` when a client connects,
  from C, straight to the process's file descriptors 1 and 2 (Python's ``sys.stdout``
  redirection cannot catch that): `native_output_silenced` points those descriptors at a
  temporary file for the duration, and replays it on stderr if the block fails, so an error
  message is never lost.
* torchrl logs an ``[INFO]`` line each time a `LazyMemmapStorage` is created or loaded:
  `torchrl_info_silenced` raises torchrl's logger to WARNING for the block and restores it.

Both are scoped to our own calls into those libraries; nothing is changed for the rest of
the process.

Examples:
    >>> pybullet = import_pybullet()  # no banner
    >>> with native_output_silenced():
    ...     client = BulletClient(connection_mode=pybullet.DIRECT)
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import os
import sys
import tempfile
from collections.abc import Iterator
from types import ModuleType


@contextlib.contextmanager
def native_output_silenced() -> Iterator[None]:
    """Send what C code writes to file descriptors 1 and 2 to a scratch file in the block.

    If the block raises, the captured output is written to stderr before the exception
    propagates: it may explain the failure.
    """
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    with tempfile.TemporaryFile() as scratch:
        saved = [os.dup(1), os.dup(2)]
        try:
            os.dup2(scratch.fileno(), 1)
            os.dup2(scratch.fileno(), 2)
            try:
                yield
            finally:
                _flush_c_streams()  # C's stdio buffers, or they are written after the block
                os.dup2(saved[0], 1)
                os.dup2(saved[1], 2)
        except BaseException:
            scratch.seek(0)
            captured = scratch.read().decode(errors="replace")
            if captured:
                sys.stderr.write(captured)
            raise
        finally:
            for descriptor in saved:
                os.close(descriptor)


def _flush_c_streams() -> None:
    """``fflush(NULL)``: write out every C stdio buffer (where C code's printf output waits)."""
    with contextlib.suppress(Exception):
        ctypes.CDLL(None).fflush(None)


def import_pybullet() -> ModuleType:
    """``import pybullet`` without its build-time banner."""
    if "pybullet" in sys.modules:
        return sys.modules["pybullet"]
    with native_output_silenced():
        import pybullet
    return pybullet


@contextlib.contextmanager
def torchrl_info_silenced() -> Iterator[None]:
    """Hide torchrl's INFO log lines (storage initialisation) within the block."""
    logger = logging.getLogger("torchrl")
    previous = logger.level
    logger.setLevel(logging.WARNING)
    try:
        yield
    finally:
        logger.setLevel(previous)
