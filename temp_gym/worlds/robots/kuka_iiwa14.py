"""``kuka_iiwa14``: the 7-DOF KUKA LBR iiwa 14 among furniture (`TEMP-7D-v0`).

Its model (URDF kinematics, hulls, spheres, allowed-collision matrix) is
`temp_gym.worlds.iiwa14`; its checkers are a covering sphere model (fast) and fcl on the link
meshes (exact, `temp_gym.worlds.collision`); its workspaces are tables, shelves, pillars and
walls (`temp_gym.worlds.iiwa_world`) or of a structured family (partitions with windows,
compartments, bins, slots and ceilings, clutter: `temp_gym.worlds.iiwa_structured`); its
pictures come from pybullet's software renderer.
Factories import their machinery on first use, so registering the robot loads none of it.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from temp_gym.worlds.robots.spec import RobotSpec, lazy

if TYPE_CHECKING:
    from temp_gym.problem import Workspace
    from temp_gym.worlds.collision import CollisionChecker

ENCODING_REGION = np.array([[-1.4, -1.4, -0.2], [1.4, 1.4, 1.6]])
"""Workspace region encoded for the iiwa (metres, base at the origin, z up); holds its reach."""
ALLOWED_COLLISIONS = Path(__file__).resolve().parents[1] / "iiwa14" / "acm.json"
"""The allowed-collision matrix (`temp_gym.worlds.iiwa14.acm`)."""


def _checker(workspace: Workspace, exact: bool) -> CollisionChecker:
    """Fast: spheres covering the links. Exact: fcl on the meshes, certified motions."""
    lower, upper = workspace.obstacle_lower, workspace.obstacle_upper
    if exact:
        from temp_gym.worlds.collision.iiwa_exact import IiwaExactChecker

        return IiwaExactChecker(workspace.bounds, lower, upper)
    from temp_gym.worlds.collision.iiwa_fast import IiwaSphereChecker

    return IiwaSphereChecker(workspace.bounds, lower, upper)


KUKA_IIWA14 = RobotSpec(
    name="kuka_iiwa14",
    env_id="TEMP-7D-v0",
    short_name="7d",
    seed_code=2,
    dim=7,
    workspace_dim=3,
    encoding_resolution=16,
    goal_radius=0.1,
    max_nodes=5000,
    evaluation_rows={"7D": "any"},
    evaluation_tasks=200,
    checker_factory=_checker,
    workspace_generator=lazy("temp_gym.worlds.iiwa_world", "generate_iiwa_workspace"),
    task_generator=lazy("temp_gym.worlds.iiwa_world", "generate_iiwa_task"),
    structured_generator=lazy(
        "temp_gym.worlds.iiwa_structured", "generate_iiwa_structured_workspace"
    ),
    renderer_factory=lazy("temp_gym.worlds.rendering.iiwa", "IiwaRenderer"),
    step_size=0.5,
    encoding_region=ENCODING_REGION,
    joint_limits=lazy("temp_gym.worlds.iiwa14.kinematics", "joint_limits"),
    allowed_collisions=ALLOWED_COLLISIONS,
    compile_minutes=2.0,
)
