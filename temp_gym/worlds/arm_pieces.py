"""Oriented pieces of furniture: boxes and cylinders built in a structure's frame, then placed.

The manipulation scenes (`temp_gym.worlds.arm_manipulation`) build each structure in a frame
of its own: ``x`` points away from the robot, ``y`` is lateral, ``z`` is up, and the robot's
base is at the origin. A `Piece` is one obstacle in that frame; `placed` turns a structure's
pieces about the vertical axis (any angle, not only the four sides of
`temp_gym.worlds.arm_world`), and `as_obstacles` hands them to
`temp_gym.problem.Workspace.from_obstacles`.

Orientations are quaternions ``[x, y, z, w]``, as in the problem format
(`temp_gym.problem.obstacles`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from temp_gym.problem.obstacles import (
    BOX,
    CYLINDER,
    Box,
    Cylinder,
    Obstacle,
    rotation_matrices,
    world_half_extents,
)

IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])
"""The identity quaternion ``[x, y, z, w]``."""


def axis_quaternion(axis: int, angle: float) -> np.ndarray:
    """The quaternion of a turn by ``angle`` (radians) about world axis ``axis`` (0, 1 or 2)."""
    quaternion = np.zeros(4)
    quaternion[axis] = np.sin(angle / 2)
    quaternion[3] = np.cos(angle / 2)
    return quaternion


def compose(first: np.ndarray, then: np.ndarray) -> np.ndarray:
    """The quaternion of turning by ``first`` and then by ``then`` (both in the world frame)."""
    x1, y1, z1, w1 = then
    x2, y2, z2, w2 = first
    return np.array([
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
    ])  # fmt: skip


def turn_about_z(points: np.ndarray, angle: float) -> np.ndarray:
    """``points`` ``(..., 3)`` turned by ``angle`` about the vertical axis through the origin."""
    cos, sin = np.cos(angle), np.sin(angle)
    turned = np.array(points, dtype=np.float64, copy=True)
    turned[..., 0] = cos * points[..., 0] - sin * points[..., 1]
    turned[..., 1] = sin * points[..., 0] + cos * points[..., 1]
    return turned


@dataclass(frozen=True, eq=False)
class Piece:
    """One obstacle: a box or a cylinder (axis along its local z) about ``center``.

    ``half`` are its half sides in its own frame (a cylinder's ``(r, r, length / 2)``, as
    `temp_gym.problem.Workspace` stores them); ``orientation`` is a quaternion.
    """

    kind: int
    center: np.ndarray
    half: np.ndarray
    orientation: np.ndarray = field(default_factory=IDENTITY.copy)

    def turned(self, angle: float, about: np.ndarray) -> Piece:
        """This piece turned by ``angle`` about the vertical line through ``about``."""
        center = about + turn_about_z(self.center - about, angle)
        return Piece(
            self.kind, center, self.half, compose(self.orientation, axis_quaternion(2, angle))
        )

    def scaled(self, scale: float) -> Piece:
        """This piece scaled about the origin (the robot's base)."""
        return Piece(self.kind, self.center * scale, self.half * scale, self.orientation)


def box(center, half, yaw: float = 0.0) -> Piece:
    """A box with half sides ``half`` about ``center``, turned by ``yaw`` about its z axis."""
    orientation = IDENTITY if yaw == 0.0 else axis_quaternion(2, yaw)
    return Piece(BOX, np.asarray(center, float), np.asarray(half, float), orientation)


def cylinder(center, radius: float, half_length: float, axis: int = 2) -> Piece:
    """A cylinder of ``radius`` along world ``axis`` (2: upright; 0, 1: lying) about ``center``."""
    if axis == 2:
        orientation = IDENTITY
    else:  # the local z axis laid along x (a turn about y) or along y (a turn about x)
        orientation = axis_quaternion(1 - axis, np.pi / 2 if axis == 0 else -np.pi / 2)
    half = np.array([radius, radius, half_length], dtype=np.float64)
    return Piece(CYLINDER, np.asarray(center, float), half, orientation)


def placed(pieces: list[Piece], yaw: float, twist: float = 0.0, anchor=None) -> list[Piece]:
    """A structure's ``pieces`` turned by ``twist`` about its ``anchor``, then by ``yaw``.

    ``yaw`` turns about the robot's base (the vertical axis through the origin).
    """
    origin = np.zeros(3)
    if twist != 0.0:
        pieces = [piece.turned(twist, np.asarray(anchor, float)) for piece in pieces]
    return [piece.turned(yaw, origin) for piece in pieces]


def bounding_boxes(pieces: list[Piece]) -> tuple[np.ndarray, np.ndarray]:
    """The tight axis-aligned ``(lower, upper)`` corners of each piece, ``(M, 3)`` each."""
    if not pieces:
        return np.zeros((0, 3)), np.zeros((0, 3))
    kinds = np.array([piece.kind for piece in pieces], dtype=np.int8)
    centers = np.array([piece.center for piece in pieces])
    halves = np.array([piece.half for piece in pieces])
    rotations = rotation_matrices(np.array([piece.orientation for piece in pieces]))
    extents = world_half_extents(kinds, halves, rotations)
    return centers - extents, centers + extents


def as_obstacles(pieces: list[Piece]) -> list[Obstacle]:
    """The pieces as `Box` and `Cylinder` objects (identity orientations left out)."""
    obstacles: list[Obstacle] = []
    for piece in pieces:
        identity = bool(np.array_equal(piece.orientation, IDENTITY))
        orientation = None if identity else tuple(float(v) for v in piece.orientation)
        center = tuple(float(v) for v in piece.center)
        if piece.kind == CYLINDER:
            obstacles.append(Cylinder(center, float(piece.half[0]), float(2 * piece.half[2]),
                                      orientation))  # fmt: skip
        else:
            obstacles.append(Box(center, tuple(float(v) for v in piece.half), orientation))
    return obstacles


__all__ = [
    "IDENTITY",
    "Piece",
    "as_obstacles",
    "axis_quaternion",
    "bounding_boxes",
    "box",
    "compose",
    "cylinder",
    "placed",
    "turn_about_z",
]
