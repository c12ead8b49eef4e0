"""The planning query: `Problem` (a `Workspace`, start, goal, goal region) and its JSON format.

The lowest layer: it imports nothing else of temp_gym. A robot is known here only by name
and through the `Robot` protocol (`temp_gym.problem.robots`); its spec lives in
`temp_gym.worlds.robots`, which registers it.
"""

from temp_gym.problem.obstacles import Box, Cylinder, Obstacle, Sphere
from temp_gym.problem.parsing import MAX_MAGNITUDE, MIN_LENGTH, parse_problem_json
from temp_gym.problem.query import Problem
from temp_gym.problem.robots import (
    Robot,
    register_robot,
    robot_named,
    robot_names,
    unregister_robot,
)
from temp_gym.problem.workspace import Workspace


def __getattr__(name: str) -> object:
    """``ROBOTS``, as before the robot registry: registered name -> (dim, workspace dim)."""
    if name == "ROBOTS":
        return {robot: (robot_named(robot).dim, robot_named(robot).workspace_dim)
                for robot in robot_names()}  # fmt: skip
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "MAX_MAGNITUDE",
    "Box",
    "Cylinder",
    "Obstacle",
    "Sphere",
    "MIN_LENGTH",
    "Problem",
    "Robot",
    "Workspace",
    "parse_problem_json",
    "register_robot",
    "robot_named",
    "robot_names",
    "unregister_robot",
]
