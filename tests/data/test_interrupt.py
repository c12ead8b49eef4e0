"""Ctrl-C on a long job: one line, no tracebacks or leaked semaphores; the rerun resumes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

from test_generate import ROOT, SCRIPT, TINY


def test_ctrl_c_prints_one_line_and_the_rerun_says_what_is_done(tmp_path):
    command = [
        sys.executable, str(SCRIPT), "--config", str(TINY), "--workers", "2",
        f"data.dir={tmp_path}", "data.tasks_per_workspace=30", "data.workspaces.train=4",
    ]  # fmt: skip
    process = subprocess.Popen(
        command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        start_new_session=True,  # a terminal's Ctrl-C reaches the whole process group
    )  # fmt: skip
    units = tmp_path / "train" / "units"
    deadline = time.monotonic() + 120
    while not (units.is_dir() and any(units.glob("*.npz"))) and time.monotonic() < deadline:
        assert process.poll() is None, "the run ended before it could be interrupted"
        time.sleep(0.02)
    os.killpg(process.pid, signal.SIGINT)
    _, stderr = process.communicate(timeout=120)
    assert not (tmp_path / "dataset_card.json").exists(), "interrupted too late to test"
    assert process.returncode == 130
    lines = [line for line in stderr.replace("\r", "\n").splitlines() if line.strip()]
    assert lines[-1] == "generate.py: interrupted; rerun the same command to resume"
    assert "Traceback" not in stderr and "leaked" not in stderr and "Error" not in stderr
    done = len(list(units.glob("*.npz")))

    again = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    assert again.returncode == 0, again.stderr[-2000:]
    assert f"resuming: {done}/5 units done" in again.stderr
    assert "estimate: ~" in again.stderr
