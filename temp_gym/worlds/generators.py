"""Seeded workspaces and tasks for any robot, drawn by the generators its spec names.

All randomness comes from the `numpy.random.Generator` passed in; nothing touches global
state, so the same seed always gives the same problems. What "easy" and "challenging" mean is
the robot's generators' to say: `temp_gym.worlds.point_world` (a detour ratio against a
reference path) and `temp_gym.worlds.arm_world` (a blocked straight motion).

Examples:
    >>> problem = generate_problem(POINT2D.name, np.random.default_rng(0), "challenging")
"""

from __future__ import annotations

import numpy as np

from temp_gym.problem import Problem, Workspace
from temp_gym.worlds.difficulty import DIFFICULTIES, check_difficulty
from temp_gym.worlds.robots import robot_spec
from temp_gym.worlds.structured import (
    BOXES,
    MIXED,
    check_family,
    draw_family,
)

WORKSPACE_TRIES = 20
"""Workspaces `generate_problem` draws before giving up on a difficulty."""


def generate_workspace(robot: str, rng: np.random.Generator, family: str = BOXES) -> Workspace:
    """Draw a workspace for ``robot`` of a workspace ``family``.

    ``boxes``: the robot's own generator (its spec's); ``mixed``: a family drawn from ``rng``
    per workspace; any other name: the robot's structured family of that name (its spec's
    ``structured_generator``: `temp_gym.worlds.structured` for point robots,
    `temp_gym.worlds.arm_structured` for arms).

    Raises:
        ValueError: an unknown family, or a structured one for a robot that has none.
    """
    check_family(robot, family)
    if family == MIXED:
        family = draw_family(rng)
    if family == BOXES:
        return robot_spec(robot).generate_workspace(rng)
    return robot_spec(robot).generate_structured_workspace(rng, family)


def generate_task(
    workspace: Workspace,
    rng: np.random.Generator,
    difficulty: str = "any",
    goal_radius: float | None = None,
) -> Problem:
    """`RobotSpec.generate_task` of the workspace's robot, the difficulty checked first."""
    check_difficulty(difficulty)
    return robot_spec(workspace.robot).generate_task(workspace, rng, difficulty, goal_radius)


def generate_problem(robot: str, rng: np.random.Generator, difficulty: str = "any") -> Problem:
    """Draw a fresh workspace and one task in it.

    Some workspaces have no task of the requested difficulty (a nearly empty one has no
    challenging task); then a new workspace is drawn, up to `WORKSPACE_TRIES`.
    """
    check_difficulty(difficulty)
    last_error: RuntimeError | None = None
    for _ in range(WORKSPACE_TRIES):
        workspace = generate_workspace(robot, rng)
        try:
            return generate_task(workspace, rng, difficulty)
        except RuntimeError as error:
            last_error = error
    raise RuntimeError(
        f"no {difficulty} {robot} problem found in {WORKSPACE_TRIES} workspaces"
    ) from last_error


__all__ = ["DIFFICULTIES", "generate_problem", "generate_task", "generate_workspace"]
