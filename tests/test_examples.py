"""The shipped example problems: valid, solvable, with clearance, and kept so for the arms.

The arm examples must stay valid with self-collision checked: their poses are plain and
unfolded, away from the joint limits and the furniture, and for the iiwa pybullet's own
self-collision test (the mesh model, non-adjacent links) finds the links well apart.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from temp_gym import Problem, plan
from temp_gym.worlds.checkers import make_checker
from temp_gym.worlds.robots import robot_spec

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
FILES = sorted(EXAMPLES.glob("*.json"))


def test_there_is_an_example_per_robot():
    from temp_gym.worlds.robots import BUILT_IN

    assert {Problem.load(path).robot for path in FILES} == {spec.name for spec in BUILT_IN}


@pytest.mark.parametrize("path", FILES, ids=[path.stem for path in FILES])
def test_example_is_valid_and_solvable(path):
    problem = Problem.load(path)  # validates: bounds, collisions, goal radius
    result = plan(problem, planner="rrt_star", seed=0, max_nodes=5000, stop_at_first=True)
    assert result.success  # plan() certifies the path with the exact checker
    if problem.robot != "point2d":  # the pictures and snippets show a detour, not a line
        assert not make_checker(problem).edge_free(problem.start, problem.goal)


ARM_FILES = [
    path for path in FILES if robot_spec(json.loads(path.read_text())["robot"]).description
]


def _iiwa():
    return Problem.load(EXAMPLES / "kuka_iiwa14.json")


@pytest.mark.parametrize("path", ARM_FILES, ids=[path.stem for path in ARM_FILES])
def test_arm_example_keeps_away_from_limits_and_furniture(path):
    from temp_gym.worlds.arm_world import arm_of
    from temp_gym.worlds.collision.arm_fast import ArmSphereChecker

    problem = Problem.load(path)
    configs = np.stack([problem.start, problem.goal])
    low, high = problem.bounds
    assert np.all(configs - low >= 0.3) and np.all(high - configs >= 0.3)
    furniture = problem.workspace.obstacle_upper[:, 2] > 0.0  # all but the floor slab
    margin = 0.05
    grown = ArmSphereChecker(
        arm_of(problem.robot),
        problem.bounds,
        problem.workspace.obstacle_lower[furniture] - margin,
        problem.workspace.obstacle_upper[furniture] + margin,
    )
    assert grown.states_free(configs).all()


def test_iiwa_example_is_no_more_folded_than_the_straight_arm():
    # pybullet's mesh model with self-collision on: every pair of non-adjacent links is as far
    # apart as in the straight, zero pose (the wrist's links 5 and 7 are 3 cm apart there),
    # up to 5 cm and a 5 mm tolerance.
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    from temp_gym.worlds.arm_world import arm_of

    problem = _iiwa()
    client = BulletClient(connection_mode=pybullet.DIRECT)
    try:
        urdf = str(arm_of(problem.robot).chain.urdf)
        arm = client.loadURDF(urdf, useFixedBase=True, flags=pybullet.URDF_USE_SELF_COLLISION)
        links = client.getNumJoints(arm)
        pairs = [(a, b) for a in range(-1, links) for b in range(a + 2, links)]

        def distances(config):
            for joint, angle in enumerate(config):
                client.resetJointState(arm, joint, float(angle))
            return {
                pair: min(
                    [p[8] for p in client.getClosestPoints(arm, arm, 0.05, *pair)], default=0.05
                )
                for pair in pairs
            }

        straight = distances(np.zeros(7))
        for config in (problem.start, problem.goal):
            for pair, distance in distances(config).items():
                assert distance >= min(straight[pair], 0.05) - 0.005, (config, pair, distance)
    finally:
        client.disconnect()
