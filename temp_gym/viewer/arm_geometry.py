"""An arm's geometry as the viewer needs it: link meshes in link frames, link poses along a path.

This module is the viewer's one door to an arm's model. Everything else in
`temp_gym.viewer` is robot-agnostic: it reads the robot's spec (dimensions, region) and,
for an arm, the two functions below. A robot whose configuration is its position in the
workspace (a point robot) needs neither.

Today the only arm with a model is the KUKA iiwa 14 (`temp_gym.worlds.iiwa14.kinematics`);
an arm described otherwise (its URDF, say) is wired in here and nowhere else.

Example:
    >>> spec = robot_spec("kuka_iiwa14")
    >>> meshes = arm_link_meshes(spec)  # one (vertices, faces) per link, in the link's frame
    >>> arm_link_poses(spec, np.zeros((3, 7))).shape  # (configs, links, 4, 4) world poses
    (3, 8, 4, 4)
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from temp_gym.worlds.robots import RobotSpec

LinkMesh = tuple[np.ndarray, np.ndarray]
"""``(vertices (V, 3) in the link's frame, faces (F, 3) vertex indices)``."""


def _kinematics(spec: RobotSpec):
    """The module holding ``spec``'s arm model, or a `ValueError` for a robot without one."""
    from temp_gym.worlds.robots.kuka_iiwa14 import KUKA_IIWA14

    if spec.name == KUKA_IIWA14.name:
        from temp_gym.worlds.iiwa14 import kinematics

        return kinematics
    raise ValueError(f"robot: {spec.name!r} has no arm geometry the viewer knows")


def is_point_robot(spec: RobotSpec) -> bool:
    """Whether a configuration of ``spec`` is a position in its workspace (2D or 3D)."""
    return spec.dim == spec.workspace_dim


def has_arm_geometry(spec: RobotSpec) -> bool:
    """Whether `arm_link_meshes` and `arm_link_poses` know ``spec``."""
    try:
        _kinematics(spec)
    except ValueError:
        return False
    return True


def arm_link_meshes(spec: RobotSpec) -> tuple[LinkMesh, ...]:
    """The arm's links as meshes, base first, each in its link's frame (`LinkMesh`).

    Raises:
        ValueError: ``spec`` is not an arm with a known model.
    """
    return tuple(_kinematics(spec).link_meshes())


def arm_link_poses(spec: RobotSpec, configs: np.ndarray) -> np.ndarray:
    """World poses ``(N, links, 4, 4)`` of the arm's links at configurations ``(N, dim)``.

    Link ``k``'s pose maps its frame (the frame of `arm_link_meshes`'s ``k``-th mesh) into
    the world.

    Raises:
        ValueError: ``spec`` is not an arm with a known model, or ``configs`` is misshaped.
    """
    configs = np.asarray(configs, dtype=np.float64)
    if configs.ndim != 2 or configs.shape[1] != spec.dim:
        raise ValueError(f"configs: expected shape (N, {spec.dim}), got {configs.shape}")
    return _kinematics(spec).forward_kinematics(configs)
