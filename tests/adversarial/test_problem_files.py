"""Hostile problem files through ``temp-plan`` and the API: scale, size, count, limits, keys."""

from __future__ import annotations

import json
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from harness import ROOT, assert_refused, files_under, run

from temp_gym import Problem
from temp_gym.limits import MAX_OBSTACLES, MAX_PROBLEM_BYTES
from temp_gym.problem import Workspace

EXAMPLE = json.loads((ROOT / "examples" / "point2d.json").read_text())


def scaled(scale: float) -> dict:
    data = json.loads(json.dumps(EXAMPLE))
    data["bounds"] = [[v * scale for v in row] for row in data["bounds"]]
    for box in data["obstacles"]:
        box["center"] = [v * scale for v in box["center"]]
        box["half_extents"] = [v * scale for v in box["half_extents"]]
    data["start"] = [v * scale for v in data["start"]]
    data["goal"] = [v * scale for v in data["goal"]]
    data["goal_radius"] *= scale
    return data


def segment_meets_box(start, end, lower, upper) -> bool:
    """The slab test in exact rational arithmetic (an independent check)."""
    enter, leave = Fraction(0), Fraction(1)
    for a, b, low, high in zip(start, end, lower, upper):
        a, b, low, high = map(Fraction, (a, b, low, high))
        if a == b:
            if not low <= a <= high:
                return False
            continue
        t0, t1 = sorted(((low - a) / (b - a), (high - a) / (b - a)))
        enter, leave = max(enter, t0), min(leave, t1)
        if enter > leave:
            return False
    return True


def many_boxes(count: int, identical: bool = False) -> dict:
    """The example's world with ``count`` small boxes along its lower edge, off every path."""
    rng = np.random.default_rng(0)
    xs = np.full(count, 10.0) if identical else rng.uniform(0.5, 19.5, count)
    boxes = [{"center": [float(x), 0.05], "half_extents": [0.01, 0.01]} for x in xs]
    return {**EXAMPLE, "obstacles": EXAMPLE["obstacles"] + boxes}


def test_the_tiny_wall_world_gets_a_path_that_clears_the_wall_exactly(tmp_path):
    problem, out = tmp_path / "tiny.json", tmp_path / "result.json"
    problem.write_text(json.dumps(scaled(1e-20)))  # 2e-19 across
    outcome = run("temp-plan", problem, "--stop-at-first", "--out", out, cwd=tmp_path)
    assert outcome.code == 0, outcome.err
    path = json.loads(out.read_text())["path"]
    boxes = Problem.load(problem).workspace
    for start, end in zip(path[:-1], path[1:]):
        for lower, upper in zip(boxes.obstacle_lower, boxes.obstacle_upper):
            assert not segment_meets_box(start, end, lower.tolist(), upper.tolist())


@pytest.mark.parametrize("identical", [False, True])
def test_one_box_past_the_supported_count_is_refused_quickly(tmp_path, identical):
    problem = tmp_path / "boxes.json"
    problem.write_text(json.dumps(many_boxes(MAX_OBSTACLES + 1 - 3, identical)))
    before = files_under(tmp_path)
    outcome = run("temp-plan", problem, "--out", tmp_path / "r.json", cwd=tmp_path)
    assert_refused(outcome, f"at most {MAX_OBSTACLES}")
    assert files_under(tmp_path) == before and outcome.seconds < 60


def test_the_time_limit_covers_the_search_at_the_supported_count(tmp_path):
    problem, out = tmp_path / "boxes.json", tmp_path / "r.json"
    problem.write_text(json.dumps(many_boxes(MAX_OBSTACLES - 3)))
    limit = 1.0
    outcome = run("temp-plan", problem, "--planner", "rrt_star", "--time-limit", str(limit),
                  "--max-nodes", "1000000000", "--out", out, cwd=tmp_path)  # fmt: skip
    assert outcome.code in (0, 3), outcome.err
    result = json.loads(out.read_text())
    assert result["wall_time"] <= 1.5 * limit  # search and certification
    assert outcome.peak_rss < 2 * 2**30 and outcome.seconds < 60  # loading and preparing


@pytest.mark.parametrize(
    "name",
    [
        "oversized",
        "endless",
        "deep",
        "joint limits",
        "box key",
        "duplicate keys",
        "not utf-8",
        "missing",
        "folder",
    ],
)
def test_a_hostile_problem_file_gets_one_line(tmp_path, name):
    problem = tmp_path / "problem.json"
    words: list[str] = []
    if name == "oversized":
        problem.write_text(json.dumps(EXAMPLE) + " " * MAX_PROBLEM_BYTES)
        words = ["larger than 16 MB"]
    elif name == "endless":
        problem = Path("/dev/zero")
        words = ["larger than"]
    elif name == "deep":
        problem.write_text("[" * 200_000 + "]" * 200_000)
        words = ["too deeply"]
    elif name == "joint limits":
        arm = json.loads((ROOT / "examples" / "kuka_iiwa14.json").read_text())
        arm["start"] = [4.0, *arm["start"][1:6], 3.5]
        problem.write_text(json.dumps(arm))
        words = ["start: outside the bounds: joint 1 = 4 is above its limit 2.96706", "joint 7"]
    elif name == "box key":
        bad = {**EXAMPLE, "obstacles": [{"center": [5, 5], "half_extent": [1, 1]}]}
        problem.write_text(json.dumps(bad))
        words = ["obstacles[0].half_extent: unknown key; a box has center and half_extents"]
    elif name == "duplicate keys":
        problem.write_text(json.dumps(EXAMPLE).replace('"robot"', '"robot": "x", "robot"', 1))
        words = ["duplicate key"]
    elif name == "missing":
        problem = tmp_path / "nope.json"
        words = ["nope.json: cannot read the problem file (no such file or directory)"]
    elif name == "folder":
        problem = tmp_path
        words = ["cannot read the problem file (is a directory)"]
    else:
        problem.write_bytes(json.dumps(EXAMPLE).encode("utf-16"))
        words = ["not UTF-8"]
    before = files_under(tmp_path)
    outcome = run("temp-plan", problem, "--out", tmp_path / "r.json", cwd=tmp_path)
    assert_refused(outcome, *words)
    assert len(outcome.err_lines[0]) < 300
    assert files_under(tmp_path) == before


def test_the_api_refuses_too_many_boxes_before_parsing_them():
    with pytest.raises(ValueError, match=f"at most {MAX_OBSTACLES}"):
        Problem.from_dict(many_boxes(MAX_OBSTACLES + 1))
    centers = np.full((MAX_OBSTACLES + 1, 2), 10.0)
    with pytest.raises(ValueError, match=f"at most {MAX_OBSTACLES}"):
        Workspace("point2d", [[0, 0], [20, 20]], centers, np.full_like(centers, 0.1))
