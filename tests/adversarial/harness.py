"""How every hostile input is run: a real command in a child process, its memory capped.

`run` starts the command with its address space limited (``RLIMIT_AS``, as ``prlimit --as``
would) and its wall time bounded, reads what it printed, and measures its peak resident
memory from the kernel's own account of the command (``wait4``), taken by a small launcher
(`launcher.py`) that forks it: a command forked from the pytest worker itself would be
charged the worker's memory too. `files_under` lists a folder
so that a test can say that a refused command wrote nothing. Large inputs are made by the
tests themselves, in their ``tmp_path``.
"""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
LAUNCHER = Path(__file__).with_name("launcher.py")
ADDRESS_SPACE = 3 * 2**30
"""The cap on a command's virtual memory: PyTorch and numba map about 1 GB between them."""
PEAK_RSS = 2 * 2**30
"""What a command may hold in memory at most, refusing the worst input."""
SECONDS = 180
"""The wall time a command may take at most, on a loaded machine."""

COMMANDS = {
    "temp-plan": [sys.executable, "-m", "temp_gym.cli"],
    "bc.py": [sys.executable, str(ROOT / "trainers" / "bc.py")],
    "generate.py": [sys.executable, str(ROOT / "trainers" / "generate.py")],
    "evaluate.py": [sys.executable, str(ROOT / "trainers" / "evaluate.py")],
    "tune_planner.py": [sys.executable, str(ROOT / "trainers" / "tune_planner.py")],
    "correct.py": [sys.executable, str(ROOT / "trainers" / "correct.py")],
    "compare_policies.py": [sys.executable, str(ROOT / "trainers" / "compare_policies.py")],
    "ship.py": [sys.executable, str(ROOT / "trainers" / "ship.py")],
    "ood": [sys.executable, "-m", "temp_gym.evaluation.ood"],
    "make_results.py": [sys.executable, str(ROOT / "docs" / "make_results.py")],
    "make_images.py": [sys.executable, str(ROOT / "docs" / "make_images.py")],
}
"""Every command of the project, as a user starts it."""


@dataclass
class Outcome:
    """What a command did."""

    code: int
    out: str
    err: str
    seconds: float
    peak_rss: int
    """Bytes."""

    @property
    def err_lines(self) -> list[str]:
        return self.err.strip().splitlines()


def _limit() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE, ADDRESS_SPACE))
    os.setsid()  # its own process group, so a timeout ends its children too


def run(command: str, *args: str | os.PathLike, cwd: Path, env: dict | None = None) -> Outcome:
    """Run one of `COMMANDS` with ``args`` under the caps; return what it did."""
    environment = {**os.environ, "OMP_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1", **(env or {})}
    environment.pop("TEMP_GYM_OVERRIDES", None)
    began = time.perf_counter()
    report_start, report_end = os.pipe()
    child = subprocess.Popen(
        [sys.executable, str(LAUNCHER), str(report_end), *COMMANDS[command],
         *map(os.fspath, args)],
        cwd=cwd, env=environment, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        preexec_fn=_limit, pass_fds=(report_end,),
    )  # fmt: skip
    os.close(report_end)
    report = open(report_start, "rb")  # noqa: SIM115 (closed below)
    streams: dict[str, bytes] = {}
    readers = [
        threading.Thread(target=lambda name=name, pipe=pipe: streams.update({name: pipe.read()}))
        for name, pipe in (("out", child.stdout), ("err", child.stderr), ("report", report))
    ]
    for reader in readers:
        reader.start()
    timer = threading.Timer(SECONDS, lambda: os.killpg(child.pid, signal.SIGKILL))
    timer.start()
    try:
        _, status, usage = os.wait4(child.pid, 0)
    finally:
        timer.cancel()
    for reader in readers:
        reader.join()
    report.close()
    peak_kib = usage.ru_maxrss  # the launcher's own account, if it was killed before reporting
    if streams["report"]:
        status, peak_kib = map(int, streams["report"].split())
    child.returncode = os.waitstatus_to_exitcode(status)
    return Outcome(
        code=child.returncode,
        out=streams["out"].decode("utf-8", "backslashreplace"),
        err=streams["err"].decode("utf-8", "backslashreplace"),
        seconds=time.perf_counter() - began,
        peak_rss=peak_kib * 1024,
    )


def files_under(folder: Path) -> dict[str, tuple[int, int]]:
    """Every file and folder under ``folder``: path -> (size, modification time)."""
    listing = {}
    for path in sorted(folder.rglob("*")):
        status = path.lstat()
        listing[str(path.relative_to(folder))] = (status.st_size, status.st_mtime_ns)
    return listing


def assert_refused(outcome: Outcome, *fragments: str) -> None:
    """Exit status 2, one line on stderr naming ``fragments``, no traceback, within the caps."""
    assert outcome.code == 2, (outcome.code, outcome.err[-2000:])
    assert len(outcome.err_lines) == 1, outcome.err[-2000:]
    line = outcome.err_lines[0]
    assert "error:" in line and "Traceback" not in outcome.err
    for fragment in fragments:
        assert fragment in line, line
    assert outcome.peak_rss < PEAK_RSS and outcome.seconds < SECONDS
