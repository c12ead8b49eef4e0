import pytest

from temp_gym.problem import Problem


def make_problem_2d() -> Problem:
    return Problem.from_dict(
        {
            "robot": "point2d",
            "bounds": [[0, 0], [20, 20]],
            "obstacles": [
                {"center": [10, 10], "half_extents": [1.5, 7]},
                {"center": [5, 15], "half_extents": [2, 2]},
                {"center": [15, 4], "half_extents": [2, 2]},
            ],
            "start": [2, 2],
            "goal": [18, 18],
            "goal_radius": 0.5,
        }
    )


def make_problem_3d() -> Problem:
    return Problem.from_dict(
        {
            "robot": "point3d",
            "bounds": [[0, 0, 0], [20, 20, 20]],
            "obstacles": [
                {"center": [10, 10, 10], "half_extents": [2, 8, 8]},
                {"center": [5, 15, 5], "half_extents": [2, 2, 4]},
            ],
            "start": [2, 2, 2],
            "goal": [18, 18, 18],
            "goal_radius": 0.5,
        }
    )


def make_enclosed_goal_2d() -> Problem:
    """A 2D problem without a solution: its goal lies inside a closed square shell of boxes."""
    return Problem.from_dict(
        {
            "robot": "point2d",
            "bounds": [[0, 0], [20, 20]],
            "obstacles": [
                {"center": [13, 15], "half_extents": [0.25, 2.25]},
                {"center": [17, 15], "half_extents": [0.25, 2.25]},
                {"center": [15, 13], "half_extents": [2.25, 0.25]},
                {"center": [15, 17], "half_extents": [2.25, 0.25]},
            ],
            "start": [2, 2],
            "goal": [15, 15],
            "goal_radius": 0.5,
        }
    )


@pytest.fixture
def enclosed_goal_2d() -> Problem:
    return make_enclosed_goal_2d()


@pytest.fixture
def problem_2d() -> Problem:
    return make_problem_2d()


@pytest.fixture
def problem_3d() -> Problem:
    return make_problem_3d()


@pytest.fixture
def empty_2d() -> Problem:
    return Problem.from_dict(
        {
            "robot": "point2d",
            "bounds": [[0, 0], [20, 20]],
            "obstacles": [],
            "start": [1, 1],
            "goal": [19, 19],
            "goal_radius": 0.5,
        }
    )
