"""Problems and plans the viewer tests draw (small, so no planner runs)."""

import numpy as np

from temp_gym.planning.result import PlanTree
from temp_gym.problem import Problem

POINT2D = {
    "robot": "point2d",
    "bounds": [[0, 0], [20, 20]],
    "obstacles": [{"center": [10, 10], "half_extents": [2, 6]}],
    "start": [2, 2],
    "goal": [18, 18],
    "goal_radius": 0.8,
}
POINT3D = {
    "robot": "point3d",
    "bounds": [[0, 0, 0], [20, 20, 20]],
    "obstacles": [{"center": [10, 10, 10], "half_extents": [2, 6, 4]}],
    "start": [2, 2, 2],
    "goal": [18, 18, 18],
    "goal_radius": 0.8,
}
IIWA = {
    "robot": "kuka_iiwa14",
    "obstacles": [
        {"center": [0.0, 0.0, -0.06], "half_extents": [1.5, 1.5, 0.05]},  # the floor slab
        {"center": [0.75, 0.0, 0.35], "half_extents": [0.15, 0.45, 0.35]},
    ],
    "start": [0, 0, 0, 0, 0, 0, 0],
    "goal": [1, 0.5, 0, -1, 0, 0.5, 0],
    "goal_radius": 0.1,
}


def random_tree(problem: Problem, count: int, seed: int = 0) -> PlanTree:
    """A tree of ``count`` random nodes (each node's parent an earlier one), rooted at start."""
    rng = np.random.default_rng(seed)
    positions = rng.uniform(*problem.bounds, size=(count, problem.dim))
    positions[0] = problem.start
    parents = np.array([-1] + [int(rng.integers(i)) for i in range(1, count)])
    return PlanTree(positions, parents)


def straight_path(problem: Problem, states: int = 5) -> np.ndarray:
    return np.linspace(problem.start, problem.goal, states)


def reference_body_poses(robot: str, config: np.ndarray) -> np.ndarray:
    """Plain-numpy world poses ``(bodies, 4, 4)`` of an arm's bodies at one configuration.

    Read from the arm's chain (each body is its parent's pose, times the joint's origin, times
    a turn about or a slide along z), apart from the compiled kinematics the package uses.
    """
    from temp_gym.worlds.arm.urdf import PRISMATIC
    from temp_gym.worlds.arm_world import arm_of

    chain = arm_of(robot).chain
    poses = [np.eye(4)]
    for origin, kind, value in zip(chain.joint_origins, chain.joint_types, config):
        motion = np.eye(4)
        if kind == PRISMATIC:
            motion[2, 3] = value
        else:
            c, s = np.cos(value), np.sin(value)
            motion[:2, :2] = [[c, -s], [s, c]]
        poses.append(poses[-1] @ origin @ motion)
    return np.stack(poses)
