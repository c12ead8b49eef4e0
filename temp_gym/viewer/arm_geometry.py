"""An arm's geometry as the viewer needs it: link meshes in link frames, link poses along a path.

This module is the viewer's one door to an arm's model. Everything else in
`temp_gym.viewer` is robot-agnostic: it reads the robot's spec (dimensions, region) and,
for an arm, the two functions below. A robot whose configuration is its position in the
workspace (a point robot) needs neither.

Every arm is read from its robot description (`temp_gym.worlds.arm`): its bodies' collision
meshes in the bodies' frames, and the bodies' poses from its kinematics.

Example:
    >>> spec = robot_spec("kuka_iiwa14")
    >>> meshes = arm_link_meshes(spec)  # one (vertices, faces) per body, in the body's frame
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


def _arm(spec: RobotSpec):
    """``spec``'s arm model, or a `ValueError` for a robot without one."""
    if spec.description is None:
        raise ValueError(f"robot: {spec.name!r} has no arm geometry the viewer knows")
    from temp_gym.worlds.arm.model import load_arm

    return load_arm(spec.description)


def is_point_robot(spec: RobotSpec) -> bool:
    """Whether a configuration of ``spec`` is a position in its workspace (2D or 3D)."""
    return spec.dim == spec.workspace_dim


def has_arm_geometry(spec: RobotSpec) -> bool:
    """Whether `arm_link_meshes` and `arm_link_poses` know ``spec``."""
    return spec.description is not None


def arm_link_meshes(spec: RobotSpec) -> tuple[LinkMesh, ...]:
    """The arm's bodies as meshes, base first, each in its body's frame (`LinkMesh`).

    Each merges the collision elements of the links riding on the body.

    Raises:
        ValueError: ``spec`` is not an arm with a known model.
    """
    meshes = []
    for geometry in _arm(spec).geometry:
        offsets = np.cumsum([0] + [len(v) for v, _ in geometry.meshes])
        vertices = (np.concatenate([v for v, _ in geometry.meshes]) if geometry.meshes
                    else np.zeros((0, 3)))  # fmt: skip
        faces = (np.concatenate([f + o for (_, f), o in zip(geometry.meshes, offsets)])
                 if geometry.meshes else np.zeros((0, 3), dtype=np.int64))  # fmt: skip
        meshes.append((vertices, faces))
    return tuple(meshes)


def arm_link_poses(spec: RobotSpec, configs: np.ndarray) -> np.ndarray:
    """World poses ``(N, bodies, 4, 4)`` of the arm's bodies at configurations ``(N, dim)``.

    Body ``k``'s pose maps its frame (the frame of `arm_link_meshes`'s ``k``-th mesh) into
    the world.

    Raises:
        ValueError: ``spec`` is not an arm with a known model, or ``configs`` is misshaped.
    """
    configs = np.asarray(configs, dtype=np.float64)
    if configs.ndim != 2 or configs.shape[1] != spec.dim:
        raise ValueError(f"configs: expected shape (N, {spec.dim}), got {configs.shape}")
    return _arm(spec).forward_kinematics(configs)
