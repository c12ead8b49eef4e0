import numpy as np
import pytest

from temp_gym import Problem
from temp_gym.problem import Workspace
from temp_gym.worlds.checkers import make_checker
from temp_gym.worlds.generators import generate_problem, generate_task
from temp_gym.worlds.point_world import (
    CHALLENGING_MIN_RATIO,
    EASY_MAX_RATIO,
    classify_task,
    generate_point_workspace,
)
from temp_gym.worlds.reference import ReferencePlanner
from temp_gym.worlds.robots import robot_spec


@pytest.mark.parametrize("robot", ["point2d", "point3d"])
def test_same_seed_same_problems(robot):
    def draw(seed):
        rng = np.random.default_rng(seed)
        workspace = generate_point_workspace(robot, rng)
        return [generate_task(workspace, rng).to_dict() for _ in range(5)]

    assert draw(3) == draw(3)
    assert draw(3) != draw(4)


def test_generators_do_not_touch_global_state():
    np.random.seed(0)
    before = np.random.random()
    np.random.seed(0)
    generate_problem("point2d", np.random.default_rng(1))
    assert np.random.random() == before


@pytest.mark.parametrize("robot", ["point2d", "point3d"])
def test_easy_and_challenging_differ_by_the_documented_criterion(robot):
    rng = np.random.default_rng(11)
    dim = 2 if robot == "point2d" else 3
    ratios = {}
    for difficulty in ("easy", "challenging"):
        ratios[difficulty] = []
        for _ in range(4):
            problem = generate_problem(robot, rng, difficulty)
            assert isinstance(problem, Problem)
            reference = ReferencePlanner(problem.workspace)
            label, ratio = classify_task(reference, problem.start, problem.goal)
            assert label == difficulty
            checker = make_checker(problem)
            blocked = not checker.edge_free(problem.start, problem.goal)
            if difficulty == "easy":
                assert ratio <= EASY_MAX_RATIO
            else:
                assert blocked and ratio >= CHALLENGING_MIN_RATIO[dim]
            ratios[difficulty].append(ratio)
    assert max(ratios["easy"]) < min(ratios["challenging"])


def test_reference_path_is_collision_free_and_near_optimal():
    workspace = Workspace("point2d", [[0, 0], [20, 20]], [[10, 10]], [[1, 6]])
    reference = ReferencePlanner(workspace)
    solution = reference.solve(np.array([2.0, 10.0]), np.array([18.0, 10.0]))
    checker = robot_spec(workspace.robot).make_checker(workspace)
    assert checker.path_free(solution.path)
    optimal = 2 * np.hypot(7, 6) + 2  # around the corners (9, 4) and (11, 4)
    assert optimal - 1e-9 <= solution.cost <= 1.03 * optimal


def test_bad_difficulty():
    with pytest.raises(ValueError, match="difficulty"):
        generate_problem("point2d", np.random.default_rng(0), "medium")
