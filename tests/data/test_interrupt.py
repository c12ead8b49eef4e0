"""Ctrl-C on a long job: one line, no tracebacks or leaked semaphores; the rerun resumes."""

from __future__ import annotations

import signal
import subprocess
import sys

from test_generate import ROOT, SCRIPT, TINY, signal_after_first_unit


def test_ctrl_c_prints_one_line_and_the_rerun_says_what_is_done(tmp_path):
    command = [
        sys.executable, str(SCRIPT), "--config", str(TINY), "--workers", "2",
        f"data.dir={tmp_path}", "data.tasks_per_workspace=30", "data.workspaces.train=12",
    ]  # fmt: skip
    # 13 units on 2 workers: the driver writes units as they arrive, so with only a few a
    # quiet machine could finish them all in the burst before the signal lands.
    status, stderr = signal_after_first_unit(command, tmp_path, signal.SIGINT)
    units = tmp_path / "train" / "units"
    assert not (tmp_path / "dataset_card.json").exists(), (
        f"interrupted too late to test: status {status}, stderr {stderr[-1500:]!r}"
    )
    assert status == 130, stderr[-3000:]
    lines = [line for line in stderr.replace("\r", "\n").splitlines() if line.strip()]
    assert lines[-1] == "generate.py: interrupted; rerun the same command to resume"
    assert "Traceback" not in stderr and "leaked" not in stderr and "Error" not in stderr
    done = len(list(units.glob("*.npz")))

    again = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    assert again.returncode == 0, again.stderr[-2000:]
    assert f"resuming: {done}/13 units done" in again.stderr
    assert "estimate: ~" in again.stderr
