"""Oriented pieces of furniture: boxes and cylinders built in a structure's frame, then placed.

The manipulation scenes (`temp_gym.worlds.arm_manipulation`) build each structure in a frame
of its own: ``x`` points away from the robot, ``y`` is lateral, ``z`` is up, and the robot's
base is at the origin. A `Piece` is one obstacle in that frame; `placed` turns a structure's
pieces about the vertical axis (any angle, not only the four sides of
`temp_gym.worlds.arm_world`), and `as_obstacles` hands them to
`temp_gym.problem.Workspace.from_obstacles`. `bar` and `objects_on` build the parts every
structure shares: bars and legs, and cans and boxes standing on a surface.

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
OBJECT_RADIUS = (0.02, 0.06)
"""Radius range (m) of a can (an upright cylinder)."""
OBJECT_HALF = (0.015, 0.12)
"""Range of a box object's horizontal half sides (m)."""
OBJECT_HALF_HEIGHT = (0.03, 0.2)
"""Range of an object's half height (m), cut to the room above its surface."""


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

    def scaled(self, scale: float, drop: float = 0.0) -> Piece:
        """This piece scaled about the origin (the robot's base), then raised by ``drop``.

        ``drop`` is `temp_gym.worlds.arm_world.scene_drop`, at most 0.
        """
        center = self.center * scale + np.array([0.0, 0.0, drop])
        return Piece(self.kind, center, self.half * scale, self.orientation)


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


def objects_on(rng: np.random.Generator, count: int, rect: tuple, surface: float,
                room: float) -> list[Piece]:  # fmt: skip
    """Up to ``count`` cans and boxes standing on ``surface`` within ``rect`` (x0, x1, y0, y1).

    ``room`` is the free height above the surface; objects take at most 80% of it and do not
    overlap one another (footprint circles apart). Fewer come when the surface is full.
    """
    x0, x1, y0, y1 = rect
    highest = min(OBJECT_HALF_HEIGHT[1], 0.4 * room)
    if highest < OBJECT_HALF_HEIGHT[0]:
        return []
    pieces: list[Piece] = []
    circles: list[tuple[float, float, float]] = []
    for _ in range(count):
        for _ in range(10):
            half_height = rng.uniform(OBJECT_HALF_HEIGHT[0], highest)
            if rng.random() < 0.5:
                radius = rng.uniform(*OBJECT_RADIUS)
                footprint, yaw, half = radius, None, None
            else:
                half = np.array([*rng.uniform(*OBJECT_HALF, size=2), half_height])
                footprint, yaw, radius = (
                    float(np.hypot(half[0], half[1])),
                    rng.uniform(-np.pi, np.pi),
                    None,
                )
            if x1 - x0 <= 2 * footprint or y1 - y0 <= 2 * footprint:
                continue
            x, y = (
                rng.uniform(x0 + footprint, x1 - footprint),
                rng.uniform(y0 + footprint, y1 - footprint),
            )
            if any(np.hypot(x - cx, y - cy) < footprint + r for cx, cy, r in circles):
                continue
            center = (x, y, surface + half_height)
            pieces.append(
                cylinder(center, radius, half_height) if half is None else box(center, half, yaw)
            )
            circles.append((x, y, footprint))
            break
    return pieces


def bar(start, end, thickness: float, round_bar: bool) -> Piece:
    """A bar (a box, or a cylinder when ``round_bar``) between two points on one world axis."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    axis = int(np.argmax(np.abs(end - start)))
    half_length = abs(end[axis] - start[axis]) / 2
    center = (start + end) / 2
    if round_bar:
        return cylinder(center, thickness, half_length, axis)
    half = np.full(3, thickness)
    half[axis] = half_length
    return box(center, half)


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
    "OBJECT_HALF",
    "OBJECT_HALF_HEIGHT",
    "OBJECT_RADIUS",
    "Piece",
    "as_obstacles",
    "axis_quaternion",
    "bar",
    "bounding_boxes",
    "box",
    "compose",
    "cylinder",
    "objects_on",
    "placed",
    "turn_about_z",
]
