"""The viewer tests' problems as fixtures (`viewer_cases`)."""

import pytest
from viewer_cases import IIWA, POINT2D, POINT3D

from temp_gym.problem import Problem


@pytest.fixture(scope="module")
def point2d() -> Problem:
    return Problem.from_dict(POINT2D)


@pytest.fixture(scope="module")
def point3d() -> Problem:
    return Problem.from_dict(POINT3D)


@pytest.fixture(scope="module")
def iiwa() -> Problem:
    return Problem.from_dict(IIWA)
