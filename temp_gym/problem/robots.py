"""The robots a problem may name: what the problem layer needs of one, and the registry.

A problem names its robot (``"robot": "point2d"`` in a problem file). Everything that differs
between robots lives in the robot's `temp_gym.worlds.robots.RobotSpec`; this layer, below the
worlds, sees a robot only through the `Robot` protocol: its dimensions, its joint limits, and
why a state collides. `temp_gym.worlds.robots` registers every built-in spec when `temp_gym`
is imported, so a problem can be read and validated anywhere.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

import numpy as np


class Robot(Protocol):
    """What validating a problem needs to know of its robot."""

    name: str
    """The name problem files use, e.g. ``"point2d"``."""
    dim: int
    """Configuration-space dimension."""
    workspace_dim: int
    """Dimension of the workspace the boxes live in."""
    joint_limits: Callable[[], np.ndarray] | None
    """The robot's own ``(2, dim)`` limits, which a problem's bounds must lie within and
    default to; None for a robot without (a point's bounds are the problem's to choose)."""

    def collision_reasons(self, workspace: Any, states: np.ndarray) -> list[str | None]:
        """Per state of ``states`` (N x dim): None when free, else why not (names the checker).

        ``workspace`` is the problem's `temp_gym.problem.Workspace` (typed loosely here: this
        module sits below it).
        """
        ...


_ROBOTS: dict[str, Robot] = {}


def register_robot(robot: Robot) -> None:
    """Make ``robot`` known by its name (`temp_gym.worlds.robots` registers the built-in ones).

    Raises:
        ValueError: another robot is registered under that name.
    """
    known = _ROBOTS.get(robot.name)
    if known is not None and known is not robot:
        raise ValueError(f"robot: {robot.name!r} is already registered")
    _ROBOTS[robot.name] = robot


def unregister_robot(name: str) -> None:
    """Forget the robot registered as ``name`` (a robot defined for a test, say)."""
    _ROBOTS.pop(name, None)


def robot_names() -> list[str]:
    """The registered robots' names, in registration order."""
    return list(_ROBOTS)


def robot_named(name: object) -> Robot:
    """The registered robot called ``name``.

    Raises:
        ValueError: no robot of that name (the message lists the known ones).
    """
    robot = _ROBOTS.get(name) if isinstance(name, str) else None
    if robot is None:
        raise ValueError(f"robot: unknown robot {name!r}; expected one of {robot_names()}")
    return robot
