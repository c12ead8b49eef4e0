"""Point robots among obstacles: the factory behind `point2d` and `point3d`.

A point robot's configuration is its position in a world ``[0, 20]^d`` of obstacles: the
analytic segment tests (`temp_gym.worlds.collision.point_shapes`) are exact (one checker
serves both levels), tasks are drawn by `temp_gym.worlds.point_world`, pictures by
matplotlib. Factories import their machinery on
first use, so registering a robot loads none of it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from temp_gym.worlds.robots.spec import RobotSpec, lazy

if TYPE_CHECKING:
    from temp_gym.problem import Workspace
    from temp_gym.worlds.collision import CollisionChecker

GOAL_RADIUS = 0.5
"""Goal radius of drawn tasks (world units): a step is 1.0 in the ``[0, 20]^d`` worlds."""
MAX_NODES = 3000
"""The env's default node budget."""
EVALUATION_TASKS = 100
"""Test tasks per evaluation row (easy and challenging: the paper's 100 + 100)."""


def _point_checker(workspace: Workspace, exact: bool) -> CollisionChecker:
    """The analytic test of every obstacle kind; it is exact, so it is also the fast checker."""
    from temp_gym.worlds.collision.point_shapes import point_checker

    del exact
    return point_checker(workspace)


def point_robot(
    name: str, env_id: str, short_name: str, seed_code: int, dim: int, encoding_resolution: int
) -> RobotSpec:
    """The spec of a point robot in a ``dim``-dimensional world (see the module docstring).

    Its evaluation has an easy and a challenging row, named after ``short_name``.
    """
    label = short_name.upper()
    return RobotSpec(
        name=name,
        env_id=env_id,
        short_name=short_name,
        seed_code=seed_code,
        dim=dim,
        workspace_dim=dim,
        encoding_resolution=encoding_resolution,
        goal_radius=GOAL_RADIUS,
        max_nodes=MAX_NODES,
        evaluation_rows={f"{label} easy": "easy", f"{label} challenging": "challenging"},
        evaluation_tasks=EVALUATION_TASKS,
        checker_factory=_point_checker,
        workspace_generator=lazy("temp_gym.worlds.point_world", "generate_point_workspace"),
        task_generator=lazy("temp_gym.worlds.point_world", "generate_point_task"),
        structured_generator=lazy("temp_gym.worlds.structured", "generate_structured_workspace"),
        renderer_factory=lazy("temp_gym.worlds.rendering.points", "PointWorldRenderer"),
        cube_symmetric=True,
    )
