"""A problem's collision checkers, as its robot's spec names them, and path certification.

Examples:
    >>> checker = make_checker(problem)
    >>> checker.states_free(np.array([[2.0, 2.0], [10.0, 10.0]]))
    array([ True, False])
"""

from __future__ import annotations

import numpy as np

from temp_gym.problem import Problem, Workspace
from temp_gym.worlds.collision import CollisionChecker
from temp_gym.worlds.robots import robot_spec


def make_checker(where: Problem | Workspace, exact: bool = False) -> CollisionChecker:
    """The fast (default) or the exact collision checker of a workspace or a problem's."""
    workspace = where.workspace if isinstance(where, Problem) else where
    return robot_spec(workspace.robot).make_checker(workspace, exact)


def certify_path(problem: Problem, path: np.ndarray) -> bool:
    """Certify ``path`` with the exact checker: every state and motion is collision-free.

    For the iiwa that includes self-collision and the URDF joint limits at every waypoint.
    """
    from temp_gym.worlds.collision.arm_inputs import as_path

    if not isinstance(problem, Problem):
        raise ValueError(f"problem: expected a Problem, got {type(problem).__name__}")
    path = as_path(path, problem.dim)
    return bool(make_checker(problem, exact=True).path_free(path))


__all__ = ["certify_path", "make_checker"]
