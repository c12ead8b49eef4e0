"""The exact point checker at every scale the problem format accepts, against exact arithmetic.

The independent check is the slab test in rational arithmetic (`fractions.Fraction`): every
float is a rational, so it decides whether a segment meets a closed box without rounding.
"""

from __future__ import annotations

import json
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

from temp_gym import Problem, plan
from temp_gym.worlds.collision.point import PointBoxChecker

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "point2d.json"
SCALES = [1e-29, 1e-20, 1e-10, 1.0, 1e10, 1e28]


def scaled(scale: float) -> Problem:
    data = json.loads(EXAMPLE.read_text())
    data["bounds"] = [[v * scale for v in row] for row in data["bounds"]]
    for box in data["obstacles"]:
        box["center"] = [v * scale for v in box["center"]]
        box["half_extents"] = [v * scale for v in box["half_extents"]]
    data["start"] = [v * scale for v in data["start"]]
    data["goal"] = [v * scale for v in data["goal"]]
    data["goal_radius"] *= scale
    return Problem.from_dict(data)


def hits_exactly(start, end, lower, upper) -> bool:
    """Whether the closed segment meets the closed box, in exact rational arithmetic."""
    enter, leave = Fraction(0), Fraction(1)
    for a, b, low, high in zip(start, end, lower, upper):
        a, b, low, high = map(Fraction, (float(a), float(b), float(low), float(high)))
        if a == b:
            if a < low or a > high:
                return False
            continue
        t0, t1 = sorted(((low - a) / (b - a), (high - a) / (b - a)))
        enter, leave = max(enter, t0), min(leave, t1)
        if enter > leave:
            return False
    return True


def free_exactly(problem: Problem, start, end) -> bool:
    workspace = problem.workspace
    return not any(
        hits_exactly(start, end, low, high)
        for low, high in zip(workspace.obstacle_lower, workspace.obstacle_upper)
    )


def checker(problem: Problem) -> PointBoxChecker:
    workspace = problem.workspace
    return PointBoxChecker(workspace.bounds, workspace.obstacle_lower, workspace.obstacle_upper)


@pytest.mark.parametrize("scale", SCALES)
def test_the_straight_segment_through_the_wall_is_not_free_at_any_scale(scale):
    problem = scaled(scale)
    assert not free_exactly(problem, problem.start, problem.goal)
    assert not checker(problem).edge_free(problem.start, problem.goal)


@pytest.mark.parametrize("scale", SCALES)
def test_the_checker_agrees_with_exact_arithmetic_on_random_segments(scale):
    problem = scaled(scale)
    rng = np.random.default_rng(7)
    low, high = problem.bounds
    starts = rng.uniform(low, high, size=(300, 2))
    ends = starts + rng.normal(scale=0.2, size=(300, 2)) * (high - low)
    ends = np.clip(ends, low, high)
    ends[:40, 0] = starts[:40, 0]  # axis-parallel segments too
    ends[40:80, 1] = starts[40:80, 1]
    ends[80:90] = starts[80:90] + (high - low) * 1e-14  # near-parallel, tiny steps
    answers = checker(problem).edges_free(starts, ends)
    expected = [free_exactly(problem, a, b) for a, b in zip(starts, ends)]
    assert answers.tolist() == expected
    assert 30 < sum(expected) < 290  # both answers are exercised


@pytest.mark.parametrize("planner", ["rrt_star", "informed_rrt_star", "temp"])
@pytest.mark.parametrize("scale", [1e-29, 1e-20, 1.0, 1e28])
def test_paths_planned_in_scaled_worlds_clear_the_boxes_exactly(planner, scale):
    problem = scaled(scale)
    result = plan(problem, planner=planner, seed=0, stop_at_first=True, max_nodes=3000)
    assert result.success
    path = np.asarray(result.path)
    for start, end in zip(path[:-1], path[1:]):
        assert free_exactly(problem, start, end)
