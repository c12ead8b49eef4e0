"""Fixtures shared across the test packages."""

import pytest


@pytest.fixture
def wall() -> dict:
    """A 2D problem (as a dict) whose straight line is blocked by a tall thin wall."""
    return {
        "robot": "point2d",
        "bounds": [[0, 0], [20, 20]],
        "obstacles": [{"center": [10, 10], "half_extents": [0.5, 8]}],
        "start": [2, 10],
        "goal": [18, 10],
        "goal_radius": 0.5,
    }
