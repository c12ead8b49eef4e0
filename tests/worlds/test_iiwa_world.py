"""Random iiwa workspaces and tasks."""

from __future__ import annotations

import numpy as np
import pytest

from temp_gym.problem import Problem, Workspace
from temp_gym.worlds import iiwa_world
from temp_gym.worlds.checkers import make_checker
from temp_gym.worlds.collision.iiwa_exact import IiwaExactChecker
from temp_gym.worlds.collision.iiwa_fast import IiwaSphereChecker
from temp_gym.worlds.collision.pybullet_reference import PybulletIiwa
from temp_gym.worlds.iiwa14.kinematics import joint_limits


def generate_iiwa_workspace(rng):
    return iiwa_world.generate_iiwa_workspace("kuka_iiwa14", rng)


def generate_iiwa_task(workspace, rng, difficulty="any", goal_radius=0.1, **kwargs):
    return iiwa_world.generate_iiwa_task(workspace, rng, difficulty, goal_radius, **kwargs)


def test_same_seed_same_workspace_and_tasks():
    def draw(seed):
        rng = np.random.default_rng(seed)
        workspace = generate_iiwa_workspace(rng)
        return workspace, [generate_iiwa_task(workspace, rng) for _ in range(3)]

    (w1, t1), (w2, t2) = draw(7), draw(7)
    np.testing.assert_array_equal(w1.obstacle_centers, w2.obstacle_centers)
    np.testing.assert_array_equal(w1.obstacle_half_extents, w2.obstacle_half_extents)
    assert t1 == t2
    w3, _ = draw(8)
    assert not np.array_equal(w1.obstacle_centers, w3.obstacle_centers) or len(
        w1.obstacle_centers
    ) != len(w3.obstacle_centers)


@pytest.mark.parametrize("seed", range(5))
def test_workspace_is_structured_and_plannable(seed):
    workspace = generate_iiwa_workspace(np.random.default_rng(seed))
    assert workspace.robot == "kuka_iiwa14"
    np.testing.assert_array_equal(workspace.bounds, joint_limits())
    assert len(workspace.obstacle_centers) >= 4  # the floor and at least three pieces
    exact = IiwaExactChecker(workspace.bounds, workspace.obstacle_lower, workspace.obstacle_upper)
    assert exact.base_free
    states = np.random.default_rng(100 + seed).uniform(*joint_limits(), size=(5000, 7))
    fast = IiwaSphereChecker(workspace.bounds, workspace.obstacle_lower, workspace.obstacle_upper)
    fraction = fast.states_free(states).mean()
    assert 0.3 <= fraction <= 0.8, fraction


@pytest.mark.parametrize("difficulty", ["any", "easy", "challenging"])
def test_tasks_are_free_and_match_difficulty(difficulty):
    rng = np.random.default_rng(3)
    workspace = generate_iiwa_workspace(rng)
    for _ in range(3):
        problem = generate_iiwa_task(workspace, rng, difficulty=difficulty, goal_radius=0.2)
        assert isinstance(problem, Problem) and problem.goal_radius == 0.2
        assert np.linalg.norm(problem.goal - problem.start) > 0.4
        ends = np.stack([problem.start, problem.goal])
        fast, exact = make_checker(problem), make_checker(problem, exact=True)
        assert fast.states_free(ends).all() and exact.states_free(ends).all()
        # with the clearance that lets edges leave them (iiwa_world's docstring)
        assert fast.states_free(ends, fast.resolution / 2).all()
        straight = fast.edge_free(problem.start, problem.goal)
        if difficulty == "easy":
            assert straight
        elif difficulty == "challenging":
            assert not straight
        assert Problem.from_dict(problem.to_dict()) == problem


def test_bad_inputs():
    rng = np.random.default_rng(0)
    workspace = generate_iiwa_workspace(rng)
    with pytest.raises(ValueError, match="difficulty"):
        generate_iiwa_task(workspace, rng, difficulty="hard")
    with pytest.raises(ValueError, match="goal_radius"):
        generate_iiwa_task(workspace, rng, goal_radius=-1.0)
    with pytest.raises(ValueError, match="rng"):
        generate_iiwa_workspace(0)
    point = Workspace("point2d", [[0, 0], [1, 1]], np.zeros((0, 2)), np.zeros((0, 2)))
    with pytest.raises(ValueError, match="workspace"):
        generate_iiwa_task(point, rng)


def test_impossible_task_gives_up():
    # A block around the shoulder: link_1 always hits it, so nothing is free.
    blocked = Workspace("kuka_iiwa14", joint_limits(), [[0.0, 0.0, 0.3]], [[0.2, 0.2, 0.05]])
    with pytest.raises(RuntimeError, match="no 'any' start-goal pair in 100 tries"):
        generate_iiwa_task(blocked, np.random.default_rng(0), max_tries=100)


def test_tasks_never_start_or_end_in_self_collision():
    # About 8% of random configurations self-collide, so 80 unchecked states would almost
    # surely include some; pybullet, independent of our checkers, is the referee.
    rng = np.random.default_rng(9)
    ends = []
    for _ in range(4):
        workspace = generate_iiwa_workspace(rng)
        for _ in range(10):
            problem = generate_iiwa_task(workspace, rng)
            ends += [problem.start, problem.goal]
    ends = np.array(ends)
    with PybulletIiwa() as bullet:
        assert bullet.self_collision_free(ends).all()
    exact = IiwaExactChecker(joint_limits(), np.zeros((0, 3)), np.zeros((0, 3)))
    assert exact.states_free(ends).all()
