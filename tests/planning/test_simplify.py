"""Path simplification: shorter, certified, same ends, seeded; and the bad inputs it refuses."""

from __future__ import annotations

import json

import numpy as np
import pytest

from temp_gym.planning import plan
from temp_gym.planning.simplify import (
    path_length,
    reduce_vertices,
    shortcut,
    shorter_path,
    simplify_path,
)
from temp_gym.problem import Box, Cylinder, Problem, Sphere, Workspace
from temp_gym.worlds.arm.model import load_arm
from temp_gym.worlds.checkers import certify_path, make_checker
from temp_gym.worlds.collision.pybullet_reference import PybulletArm, densify
from temp_gym.worlds.robots import robot_spec

EMPTY_2D = Problem.from_dict(
    {"robot": "point2d", "bounds": [[0, 0], [10, 10]], "obstacles": [],
     "start": [1, 1], "goal": [9, 9], "goal_radius": 0.5}
)  # fmt: skip


def _on_a_line(count: int) -> np.ndarray:
    return np.stack([np.arange(count, dtype=float), np.zeros(count)], axis=1)


def test_vertex_reduction_jumps_to_the_farthest_reachable_of_its_halving_candidates():
    # A motion is free when it spans at most 3 waypoints; candidates from 0 are 9, 5, 3.
    path = _on_a_line(10)
    kept = reduce_vertices(path, lambda a, b: abs(b[0] - a[0]) <= 3)
    assert kept[:, 0].tolist() == [0, 3, 6, 9]
    assert reduce_vertices(path, lambda a, b: False)[:, 0].tolist() == list(range(10))
    assert reduce_vertices(path, lambda a, b: True)[:, 0].tolist() == [0, 9]


def test_shortcuts_keep_the_ends_never_lengthen_and_need_a_free_motion():
    rng = np.random.default_rng(0)
    zigzag = np.array([[0, 0], [1, 1], [2, 0], [3, 1], [4, 0], [5, 1], [6, 0]], float)
    blocked = shortcut(zigzag, lambda a, b: False, rng, steps=100, patience=100)
    np.testing.assert_array_equal(blocked, zigzag)
    free = shortcut(zigzag, lambda a, b: True, np.random.default_rng(0), steps=200, patience=200)
    np.testing.assert_array_equal(free[0], zigzag[0])
    np.testing.assert_array_equal(free[-1], zigzag[-1])
    assert path_length(free) < path_length(zigzag)
    # Only motions that stay below y = 0.5 are free: every kept cut does, so no waypoint added
    # by a cut lies above it, and the path only ever shortens.
    low = shortcut(zigzag, lambda a, b: max(a[1], b[1]) <= 0.5, np.random.default_rng(1), 200, 200)
    assert path_length(low) <= path_length(zigzag)
    added = [point for point in low if not any(np.array_equal(point, z) for z in zigzag)]
    assert all(point[1] <= 0.5 for point in added)


def test_a_zigzag_in_free_space_becomes_its_straight_segment():
    zigzag = np.array([[1, 1], [3, 6], [5, 2], [7, 8], [9, 9]], float)
    simplified = simplify_path(EMPTY_2D, zigzag)
    np.testing.assert_array_equal(simplified, zigzag[[0, -1]])


@pytest.mark.parametrize("name", ["problem_2d", "problem_3d"])
def test_a_planners_path_gets_shorter_certified_and_keeps_its_ends(name, request):
    problem = request.getfixturevalue(name)
    result = plan(problem, planner="rrt_star", seed=3, max_nodes=1500, stop_at_first=True)
    assert result.success
    simplified = simplify_path(problem, result.path, seed=0)
    assert certify_path(problem, simplified)
    np.testing.assert_array_equal(simplified[0], result.path[0])
    np.testing.assert_array_equal(simplified[-1], result.path[-1])
    assert path_length(simplified) < result.cost
    np.testing.assert_array_equal(simplify_path(problem, result.path, seed=0), simplified)


def test_the_same_seed_gives_the_same_path_and_steps_zero_only_reduces_vertices(problem_2d):
    problem = problem_2d
    path = plan(problem, planner="rrt_star", seed=5, max_nodes=1500, stop_at_first=True).path
    checker = make_checker(problem)
    reduced = reduce_vertices(path, lambda a, b: bool(checker.edge_free(a, b)))
    only_reduced = shorter_path(problem, path, steps=0)
    if only_reduced is None:  # reduction found nothing shorter
        assert path_length(reduced) == pytest.approx(path_length(path))
    else:
        np.testing.assert_array_equal(only_reduced, reduced)
    runs = [simplify_path(problem, path, seed=s) for s in (7, 7)]
    np.testing.assert_array_equal(runs[0], runs[1])
    # The three passes as documented: reduce, shortcut with the seed's generator, reduce again.
    cut = shortcut(reduced, lambda a, b: bool(checker.edge_free(a, b)), np.random.default_rng(7))
    assert not np.array_equal(cut, reduced)  # the premise: a shortcut was kept
    np.testing.assert_array_equal(
        runs[0], reduce_vertices(cut, lambda a, b: bool(checker.edge_free(a, b)))
    )


def _panda_problem() -> Problem:
    spec = robot_spec("franka_panda")
    obstacles = [
        Box(center=(0.5, 0.0, 0.35), half_extents=(0.12, 0.3, 0.015),
            orientation=(0.0, 0.0, 0.258819, 0.9659258)),
        Cylinder(center=(0.45, -0.35, 0.5), radius=0.04, length=0.3),
        Sphere(center=(0.3, 0.35, 0.6), radius=0.07),
    ]  # fmt: skip
    workspace = Workspace.from_obstacles("franka_panda", spec.joint_limits(), obstacles)
    start = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
    goal = np.array([-0.5, 0.6, 0.0, -1.5, 0.0, 2.2, 0.8])  # not straight from the start
    return Problem(workspace, start=start, goal=goal, goal_radius=0.1)


def test_an_arm_path_simplified_stays_free_for_pybullet():
    problem = _panda_problem()
    result = plan(problem, planner="rrt_connect", seed=2, max_nodes=5000, stop_at_first=True)
    assert result.success
    assert not make_checker(problem, exact=True).edge_free(problem.start, problem.goal)
    simplified = simplify_path(problem, result.path, seed=1)
    assert certify_path(problem, simplified)
    assert path_length(simplified) <= result.cost
    arm = load_arm(robot_spec("franka_panda").description)
    with PybulletArm(arm, problem) as bullet:
        dense = densify(simplified, 0.01)
        assert bullet.states_free(dense).all()
    lower, upper = problem.workspace.bounds
    assert ((simplified >= lower) & (simplified <= upper)).all()


def test_plan_simplifies_on_request_and_keeps_the_planners_figures(problem_2d):
    problem = problem_2d
    raw = plan(problem, planner="rrt_star", seed=4, max_nodes=1500, stop_at_first=True)
    result = plan(problem, planner="rrt_star", seed=4, max_nodes=1500, stop_at_first=True,
                  simplify=True)  # fmt: skip
    assert raw.simplification is None
    assert result.simplification["cost"] == raw.cost
    assert result.simplification["waypoints"] == len(raw.path)
    assert result.simplification["time"] >= 0
    assert result.cost == pytest.approx(path_length(result.path)) and result.cost < raw.cost
    assert certify_path(problem, result.path)
    assert result.nodes == raw.nodes and result.history["best_cost"][0] == raw.cost
    assert json.loads(json.dumps(result.to_dict()))["simplification"]["waypoints"] == len(raw.path)
    assert "simplified from cost" in result.summary()


def test_plan_without_a_path_has_nothing_to_simplify(enclosed_goal_2d):
    result = plan(enclosed_goal_2d, planner="rrt_star", max_nodes=200, simplify=True)
    assert not result.success and result.simplification is None


def test_a_colliding_path_is_refused_unless_a_certified_shortening_is_found(problem_2d):
    problem = problem_2d
    through_the_wall = np.array([[2.0, 2.0], [10.0, 10.0], [18.0, 18.0]])
    with pytest.raises(ValueError, match="^path: the exact checker finds it in collision"):
        simplify_path(problem, through_the_wall)
    # The middle waypoint is in a box, but the straight motion past it is free.
    box = Problem.from_dict(
        {"robot": "point2d", "bounds": [[0, 0], [10, 10]],
         "obstacles": [{"center": [5, 8], "half_extents": [1, 1]}],
         "start": [1, 1], "goal": [9, 1], "goal_radius": 0.5}
    )  # fmt: skip
    around = simplify_path(box, np.array([[1.0, 1.0], [5.0, 8.0], [9.0, 1.0]]))
    np.testing.assert_array_equal(around, [[1.0, 1.0], [9.0, 1.0]])


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"path": None}, "^path: expected a \\(K, d\\) array of numbers, got None"),
        ({"path": [[1.0, 1.0]]}, "^path: expected shape \\(K >= 2, 2\\)"),
        ({"path": [[1.0, 1.0, 1.0], [2.0, 2.0, 2.0]]}, "^path: expected shape"),
        ({"path": [[1.0, np.nan], [2.0, 2.0]]}, "^path: every number must be finite"),
        ({"path": [["a", 1.0], [2.0, 2.0]]}, "^path: expected a \\(K, d\\) array"),
        ({"path": np.array([[1, 1], [9, 9]], dtype=complex)}, "^path: .* got complex"),
        ({"path": np.array([[True, True], [True, False]])}, "^path: .* real numbers, got bool"),
        ({"seed": -1}, "^seed: "),
        ({"steps": -1}, "^steps: "),
        ({"steps": 2.5}, "^steps: "),
        ({"patience": 0}, "^patience: "),
        ({"problem": "examples/point2d.json"}, "^problem: expected a Problem"),
    ],
)
def test_bad_arguments_are_refused_in_one_line(arguments, message):
    call = {"problem": EMPTY_2D, "path": [[1.0, 1.0], [9.0, 9.0]], **arguments}
    with pytest.raises(ValueError, match=message):
        simplify_path(**call)


def test_plan_refuses_a_simplify_that_is_not_a_flag():
    with pytest.raises(ValueError, match="^simplify: expected True or False"):
        plan(EMPTY_2D, planner="rrt_star", simplify="yes")
