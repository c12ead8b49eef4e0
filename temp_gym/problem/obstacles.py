"""Obstacle kinds: boxes (optionally oriented), cylinders and spheres, and their geometry.

A `Workspace` stores its obstacles as arrays, one row per obstacle, so that compiled checkers
read them directly:

* ``kinds``: `BOX`, `CYLINDER` or `SPHERE`;
* ``centers``: the obstacle's center in workspace coordinates;
* ``half_extents``: the half sides of the obstacle's box *in its own frame*. A box's are its
  half sides; a cylinder's are ``(radius, radius, length / 2)`` (its axis is its local z); a
  sphere's are its radius on every axis. Growing every half extent by a margin grows every
  kind by that margin;
* ``orientations``: a unit quaternion ``[x, y, z, w]`` per obstacle in 3D (ROS's and MoveIt's
  order), an angle in radians in 2D; the identity for a sphere.

The user-facing objects `Box`, `Cylinder` and `Sphere` are what `Workspace.obstacles`
returns and `Workspace.from_obstacles` takes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

BOX = 0
"""A box: ``half_extents`` are its half sides (in its own frame)."""
CYLINDER = 1
"""A solid cylinder whose axis is its local z: ``half_extents = (radius, radius, length / 2)``."""
SPHERE = 2
"""A solid sphere (a disc in 2D): every half extent is its radius."""
KIND_NAMES = ("box", "cylinder", "sphere")
"""The ``"type"`` of each kind in the problem format, indexed by kind."""

UNIT_TOLERANCE = 1e-3
"""How far a quaternion's norm may be from 1. Within it the quaternion is normalized (files
written with six digits are accepted); beyond it, it is refused rather than guessed at."""


@dataclass(frozen=True)
class Box:
    """A box with ``half_extents`` about ``center``, rotated by ``orientation`` (identity if None).

    ``orientation`` is a quaternion ``[x, y, z, w]`` in 3D and an angle (radians) in 2D.
    """

    center: tuple[float, ...]
    half_extents: tuple[float, ...]
    orientation: tuple[float, ...] | float | None = None


@dataclass(frozen=True)
class Cylinder:
    """A solid cylinder of ``radius`` and ``length`` (end to end) along its local z (3D only)."""

    center: tuple[float, ...]
    radius: float
    length: float
    orientation: tuple[float, ...] | None = None


@dataclass(frozen=True)
class Sphere:
    """A solid sphere (a disc in 2D) of ``radius`` about ``center``."""

    center: tuple[float, ...]
    radius: float


Obstacle = Box | Cylinder | Sphere
"""Any obstacle a workspace holds."""


def identity_orientations(count: int, workspace_dim: int) -> np.ndarray:
    """``count`` identity orientations: quaternions ``[0, 0, 0, 1]`` in 3D, angles 0 in 2D."""
    if workspace_dim == 2:
        return np.zeros((count, 1))
    orientations = np.zeros((count, 4))
    orientations[:, 3] = 1.0
    return orientations


def orientation_width(workspace_dim: int) -> int:
    """Numbers per orientation: 4 (a quaternion) in 3D, 1 (an angle) in 2D."""
    return 1 if workspace_dim == 2 else 4


def is_identity(orientations: np.ndarray) -> np.ndarray:
    """``bool[M]``: which orientations are exactly the identity (``q`` and ``-q`` alike)."""
    if orientations.shape[1] == 1:
        return orientations[:, 0] == 0.0
    axis_zero = np.all(orientations[:, :3] == 0.0, axis=1)
    return axis_zero & (np.abs(orientations[:, 3]) == 1.0)


def rotation_matrices(orientations: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(M, w, w)`` of orientations ``(M, 4)`` (quaternions) or ``(M, 1)``.

    A quaternion is normalized first; exactly-identity orientations give exactly the identity.
    """
    count = len(orientations)
    if orientations.shape[1] == 1:
        angle = orientations[:, 0]
        cos, sin = np.cos(angle), np.sin(angle)
        rotations = np.empty((count, 2, 2))
        rotations[:, 0, 0], rotations[:, 0, 1] = cos, -sin
        rotations[:, 1, 0], rotations[:, 1, 1] = sin, cos
    else:
        q = orientations / np.linalg.norm(orientations, axis=1, keepdims=True)
        x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
        rotations = np.empty((count, 3, 3))
        rotations[:, 0, 0] = 1 - 2 * (y * y + z * z)
        rotations[:, 0, 1] = 2 * (x * y - z * w)
        rotations[:, 0, 2] = 2 * (x * z + y * w)
        rotations[:, 1, 0] = 2 * (x * y + z * w)
        rotations[:, 1, 1] = 1 - 2 * (x * x + z * z)
        rotations[:, 1, 2] = 2 * (y * z - x * w)
        rotations[:, 2, 0] = 2 * (x * z - y * w)
        rotations[:, 2, 1] = 2 * (y * z + x * w)
        rotations[:, 2, 2] = 1 - 2 * (x * x + y * y)
    identity = is_identity(orientations)
    rotations[identity] = np.eye(rotations.shape[1])
    return rotations


def world_half_extents(
    kinds: np.ndarray, half_extents: np.ndarray, rotations: np.ndarray
) -> np.ndarray:
    """Half sides ``(M, w)`` of each obstacle's axis-aligned bounding box, tight for every kind.

    A rotated box's is ``|R| h``; a cylinder's, along world axis ``i`` with the cylinder's axis
    ``a``, is ``|a_i| l + r sqrt(1 - a_i^2)``; a sphere's is its radius.
    """
    world = np.einsum("mij,mj->mi", np.abs(rotations), half_extents)
    cylinders = kinds == CYLINDER
    if np.any(cylinders):
        axis = rotations[cylinders][:, :, 2]
        radius = half_extents[cylinders][:, :1]
        half_length = half_extents[cylinders][:, 2:3]
        world[cylinders] = np.abs(axis) * half_length + radius * np.sqrt(
            np.clip(1.0 - axis * axis, 0.0, 1.0)
        )
    spheres = kinds == SPHERE
    world[spheres] = half_extents[spheres]
    return world


def kind_volumes(kinds: np.ndarray, half_extents: np.ndarray) -> np.ndarray:
    """Each obstacle's volume (area in 2D), whatever its orientation."""
    dim = half_extents.shape[1]
    volumes = np.prod(2.0 * half_extents, axis=1)
    radius = half_extents[:, 0]
    if dim == 2:
        ball = np.pi * radius**2
    else:
        ball = 4.0 / 3.0 * np.pi * radius**3
        cylinders = kinds == CYLINDER
        volumes[cylinders] = np.pi * radius[cylinders] ** 2 * 2.0 * half_extents[cylinders, 2]
    spheres = kinds == SPHERE
    volumes[spheres] = ball[spheres]
    return volumes


def as_obstacle(
    kind: int, center: np.ndarray, half: np.ndarray, orientation: np.ndarray
) -> Obstacle:
    """The user-facing object of one obstacle row (the inverse of `obstacle_row`)."""
    center_tuple = tuple(float(c) for c in center)
    identity = bool(is_identity(orientation.reshape(1, -1))[0])
    if len(orientation) == 1:
        turned: tuple[float, ...] | float | None = None if identity else float(orientation[0])
    else:
        turned = None if identity else tuple(float(v) for v in orientation)
    if kind == BOX:
        return Box(center_tuple, tuple(float(h) for h in half), turned)
    if kind == CYLINDER:
        return Cylinder(center_tuple, float(half[0]), float(2.0 * half[2]), turned)  # type: ignore[arg-type]
    return Sphere(center_tuple, float(half[0]))


def obstacle_entry(obstacle: Obstacle, where: str) -> dict:
    """One `Box`, `Cylinder` or `Sphere` as a problem-format entry, its values as given.

    `Workspace.from_obstacles` reads the entries as a problem file's, so that a bad value is
    refused with the same message naming its field (``where``, e.g. ``obstacles[2]``).
    """

    def plain(value):  # numpy arrays as lists, as a file would hold them
        return value.tolist() if isinstance(value, np.ndarray) else value

    if isinstance(obstacle, Box):
        entry = {"type": "box", "center": plain(obstacle.center),
                 "half_extents": plain(obstacle.half_extents)}  # fmt: skip
    elif isinstance(obstacle, Cylinder):
        entry = {"type": "cylinder", "center": plain(obstacle.center),
                 "radius": plain(obstacle.radius), "length": plain(obstacle.length)}  # fmt: skip
    elif isinstance(obstacle, Sphere):
        return {"type": "sphere", "center": plain(obstacle.center),
                "radius": plain(obstacle.radius)}  # fmt: skip
    else:
        raise ValueError(f"{where}: expected a Box, Cylinder or Sphere, got "
                         f"{type(obstacle).__name__}")  # fmt: skip
    if obstacle.orientation is not None:
        entry["orientation"] = plain(obstacle.orientation)
    return entry


__all__ = [
    "BOX",
    "CYLINDER",
    "KIND_NAMES",
    "SPHERE",
    "Box",
    "Cylinder",
    "Obstacle",
    "Sphere",
    "identity_orientations",
    "is_identity",
    "kind_volumes",
    "obstacle_entry",
    "rotation_matrices",
    "world_half_extents",
]
