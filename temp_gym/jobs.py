"""What long jobs tell their user: estimates, resume state, and a clean exit on Ctrl-C.

The long jobs (`trainers/generate.py`, `trainers/bc.py`, `trainers/evaluate.py`) are
resumable, so an interruption is routine: `run_script` turns Ctrl-C, and the SIGTERM that
``kill``, Slurm, systemd and ``docker stop`` send, into one line saying to rerun the same
command, and a `JobError` (a damaged file, a locked directory, a run that
would mix settings) into one line naming the file or setting, instead of a traceback.
`progress_line` and `estimate_line` are the lines they print before work starts: what is
already done, and how long the rest should take from a measured per-unit cost.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from typing import Any

from temp_gym.limits import MAX_MESSAGE_LENGTH, MAX_MESSAGE_VALUE

INTERRUPTED = 130
"""Exit status after Ctrl-C (the shell's 128 + SIGINT)."""
TERMINATED = 143
"""Exit status after SIGTERM (128 + SIGTERM)."""
BAD_INPUT = 2
"""Exit status for a `JobError` (as argparse uses for a bad command line)."""
BROKEN_PIPE = 141
"""Exit status when the output was closed (``... | head``): 128 + SIGPIPE, as a shell gives."""


class JobError(Exception):
    """An error whose message is all a user needs: what is wrong, where, and what to do.

    Scripts print it as one line (`run_script`); the classes that inherit it also inherit
    the builtin error that callers already catch (`ValueError`, `RuntimeError`).
    """


def brief(value: Any, limit: int = MAX_MESSAGE_VALUE) -> str:
    """``repr(value)`` for a message, cut to ``limit`` characters (a user's value may be huge).

    A value that cannot even be shown (a recursive structure, say) is named by its type.
    """
    try:
        text = repr(value)
    except (RecursionError, ValueError):
        return f"<a {type(value).__name__}>"
    if len(text) <= limit:
        return text
    return f"{text[: limit - 20]}... ({len(text)} characters)"


def one_line(message: object, limit: int = MAX_MESSAGE_LENGTH) -> str:
    """``message`` as one line of at most ``limit`` characters: what a command prints on error.

    Line breaks (a YAML parser's, a traceback's) become ``; ``, runs of spaces one space, and
    characters the terminal's encoding cannot show (a file name that is not UTF-8) escapes.
    """
    text = " ".join(str(message).replace("\r", "\n").replace("\n", " ; ").split())
    text = text.replace(" ; ", "; ")
    if len(text) > limit:
        text = f"{text[: limit - 30]}... (message cut at {limit} characters)"
    try:  # a file name's undecodable bytes (surrogate escapes) shown as \xff
        text = text.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")
    except UnicodeEncodeError:
        pass
    encoding = getattr(sys.stderr, "encoding", None) or "utf-8"
    return text.encode(encoding, "backslashreplace").decode(encoding, "replace")


def display_path(path: str | os.PathLike) -> str:
    r"""A file name as text any terminal can print: bytes that are not UTF-8 as ``\xff``.

    A name the file system holds in another encoding reaches Python with surrogate escapes;
    printed as it is to a strict UTF-8 stream it raises `UnicodeEncodeError`.
    """
    return os.fsencode(path).decode("utf-8", "backslashreplace")


def report(message: str) -> None:
    """Print a status line for the user (stderr, so results on stdout stay clean)."""
    print(message, file=sys.stderr, flush=True)


def format_duration(seconds: float) -> str:
    """A rough, readable duration: ``45 s``, ``12 min``, ``2.5 h``."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 90 * 60:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def progress_line(done: int, total: int, unit: str) -> str:
    """``resuming: 80/133 units done`` (or ``starting: 133 units`` when none is done)."""
    if done == 0:
        return f"starting: {total} {unit}"
    if done >= total:
        return f"all {total} {unit} done"
    return f"resuming: {done}/{total} {unit} done"


def estimate_line(
    remaining: int, seconds_per_unit: float, workers: int | None, unit: str, basis: str
) -> str:
    """``estimate: ~25 min for 53 units on 2 workers (9.1 s per unit, measured on ...)``.

    ``unit`` is a plural noun (``units``, ``tasks``, ``epochs``); ``workers=None`` for work
    done one unit at a time.
    """
    parallel = 1 if workers is None else max(1, min(workers, remaining))
    total = remaining * seconds_per_unit / parallel
    where = "" if workers is None else f" on {parallel} worker{'s' if parallel > 1 else ''}"
    return (
        f"estimate: ~{format_duration(total)} for {remaining} {unit}{where} "
        f"({seconds_per_unit:.3g} s per {unit.removesuffix('s')}, {basis})"
    )


def run_script(name: str, main: Callable[[Sequence[str] | None], Any], argv=None) -> int:
    """Run a script's ``main``; one line and an exit status on Ctrl-C or a `JobError`.

    Returns 0 on success, `INTERRUPTED` after Ctrl-C ("rerun the same command to resume"),
    `TERMINATED` after SIGTERM (the same line, "terminated")
    and `BAD_INPUT` after a `JobError` (or a ``SystemExit`` with a message); argparse's own
    exit status passes through. Any other exception keeps its traceback: it is a bug.
    """
    previous = _on_sigterm(_terminate)
    try:
        main(argv)
    except SystemExit as exit:
        if exit.code is None or isinstance(exit.code, int):
            return exit.code or 0
        report(one_line(f"{name}: error: {exit.code}"))
        return BAD_INPUT
    except _Terminated:
        _close_progress_bars()
        report(f"{name}: terminated; rerun the same command to resume")
        return TERMINATED
    except KeyboardInterrupt:
        _close_progress_bars()
        report(f"{name}: interrupted; rerun the same command to resume")
        return INTERRUPTED
    except JobError as error:
        report(one_line(f"{name}: error: {error}"))
        return BAD_INPUT
    except BrokenPipeError:  # ``... | head`` closed the output: stop quietly, as a shell does
        _silence_stdout()
        report(f"{name}: its output was closed; rerun the same command to resume")
        return BROKEN_PIPE
    finally:
        _on_sigterm(previous)
    return 0


def _silence_stdout() -> None:
    """Point stdout at /dev/null, so that flushing it at exit raises no second error."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # no file descriptor (a test's capture)
        pass


class _Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the job is, so that it unwinds as after Ctrl-C."""


def _terminate(signum: int, frame: object) -> None:
    raise _Terminated


def _on_sigterm(handler: Any) -> Any:
    """Install ``handler`` for SIGTERM (main thread only); returns the one it replaced."""
    if handler is None or threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGTERM, handler)


def _close_progress_bars() -> None:
    """Close the progress bars an interruption left open, so none redraws after the last line."""
    try:
        from tqdm import tqdm
    except ImportError:
        return
    for bar in list(getattr(tqdm, "_instances", ())):
        bar.close()
