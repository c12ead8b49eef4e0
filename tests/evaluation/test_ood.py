"""The out-of-distribution family: stored as built, valid, and every task a real detour."""

import pytest

from temp_gym.evaluation.ood import WORLD_DIRS, build_ood_family, load_ood_family
from temp_gym.worlds.checkers import make_checker


@pytest.mark.parametrize("robot", ["point2d", "point3d"])
def test_stored_point_problems_are_the_builders(robot):
    assert load_ood_family(robot) == build_ood_family(robot)


@pytest.mark.parametrize("robot", list(WORLD_DIRS))
def test_every_problem_is_valid_and_its_straight_line_is_blocked(robot):
    family = load_ood_family(robot)
    assert len(family) >= 5
    for name, problem in family.items():  # loading validated start, goal, bounds, collisions
        assert problem.robot == robot
        assert not make_checker(problem).edge_free(problem.start, problem.goal), name


def test_an_unknown_robot_has_no_family(tmp_path):
    with pytest.raises(ValueError, match="robot"):
        load_ood_family("point4d")
    with pytest.raises(FileNotFoundError, match="temp_gym.evaluation.ood"):
        load_ood_family("point2d", tmp_path)


def test_the_command_rewrites_the_point_families_and_the_arms_only_when_named(tmp_path):
    """The arms' tasks are searched by planning: rewriting them by default would change the
    family of record whenever the planners change."""
    from temp_gym.evaluation.ood import main

    main(["--out", str(tmp_path)])
    assert sorted(path.name for path in tmp_path.iterdir()) == ["2d", "3d"]
    assert load_ood_family("point2d", tmp_path / "2d") == build_ood_family("point2d")
