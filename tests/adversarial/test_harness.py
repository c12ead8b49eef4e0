"""The harness itself (`harness.run`): what it measures is the command's own."""

from __future__ import annotations

import sys

import harness
from harness import ROOT


def test_a_commands_peak_memory_is_its_own_not_the_test_process(monkeypatch):
    """The harness charges a command what it holds, not what the pytest worker held when it
    started it (Linux keeps a process's high-water mark across ``exec``)."""
    ballast = b"x" * (600 * 2**20)  # the worker holds 600 MB more
    monkeypatch.setitem(harness.COMMANDS, "idle", [sys.executable, "-c", "pass"])
    monkeypatch.setitem(
        harness.COMMANDS, "hungry", [sys.executable, "-c", "b = b'x' * (300 * 2**20)"]
    )
    idle = harness.run("idle", cwd=ROOT)
    hungry = harness.run("hungry", cwd=ROOT)
    assert len(ballast) and idle.code == 0 and hungry.code == 0
    assert idle.peak_rss < 100 * 2**20
    assert 300 * 2**20 < hungry.peak_rss < 400 * 2**20
