"""Every planner's 7D paths are free of self-collision, by pybullet's independent verdict."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from temp_gym.evaluation.runner import evaluation_problem
from temp_gym.planning import plan
from temp_gym.problem import Problem
from temp_gym.worlds.arm.model import load_arm
from temp_gym.worlds.checkers import certify_path
from temp_gym.worlds.collision.pybullet_reference import PybulletArm, densify
from temp_gym.worlds.robots import robot_spec

PLANNERS = ["temp", "rrt_star", "informed_rrt_star"]
if importlib.util.find_spec("ompl") is not None:
    PLANNERS += ["ompl_rrt_star", "ompl_informed_rrt_star"]
# The straight motion from start to goal folds the forearm into the base (link_0 - link_5):
# a planner that ignored self-collision would take it.
FOLDED = Problem.from_dict(
    {
        "robot": "kuka_iiwa14",
        "obstacles": [],
        "start": [-0.66, 1.91, 2.44, -2.08, 2.06, 0.86, -0.22],
        "goal": [0.58, 1.92, -2.07, -1.95, -1.02, 0.14, 2.89],
        "goal_radius": 0.15,
    }
)


@pytest.fixture(scope="module")
def problems():
    return [FOLDED] + [evaluation_problem("kuka_iiwa14", "any", index) for index in (0, 1)]


@pytest.mark.parametrize("planner", PLANNERS)
def test_returned_paths_are_free_of_self_collision(problems, planner):
    with PybulletArm(load_arm(robot_spec("kuka_iiwa14").description)) as bullet:
        straight = densify(np.stack([FOLDED.start, FOLDED.goal]), 0.01)
        assert not bullet.self_collision_free(straight).all()  # the premise
        for problem in problems:
            result = plan(problem, planner=planner, seed=0, max_nodes=3000, stop_at_first=True)
            assert result.success or problem is not FOLDED
            if result.success:  # the test tasks are hard for some planners at this budget
                assert certify_path(problem, result.path)
                assert bullet.self_collision_free(densify(result.path, 0.01)).all()
