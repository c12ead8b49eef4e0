"""Oriented pieces (`temp_gym.worlds.arm_pieces`): turns, cylinders' axes, bounding boxes."""

from __future__ import annotations

import numpy as np
import pytest

from temp_gym.problem import Workspace
from temp_gym.problem.obstacles import BOX, CYLINDER, rotation_matrices
from temp_gym.worlds.arm_pieces import (
    IDENTITY,
    as_obstacles,
    axis_quaternion,
    bounding_boxes,
    box,
    compose,
    cylinder,
    placed,
)
from temp_gym.worlds.robots import robot_spec


def _matrix(quaternion: np.ndarray) -> np.ndarray:
    return rotation_matrices(np.asarray(quaternion, float)[None])[0]


def _turn_z(angle: float) -> np.ndarray:
    cos, sin = np.cos(angle), np.sin(angle)
    return np.array([[cos, -sin, 0.0], [sin, cos, 0.0], [0.0, 0.0, 1.0]])


def test_composed_quaternions_are_the_product_of_their_matrices():
    rng = np.random.default_rng(0)
    for _ in range(20):
        first = axis_quaternion(int(rng.integers(3)), rng.uniform(-3, 3))
        then = axis_quaternion(int(rng.integers(3)), rng.uniform(-3, 3))
        np.testing.assert_allclose(
            _matrix(compose(first, then)), _matrix(then) @ _matrix(first), atol=1e-12
        )


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_a_cylinder_lies_along_the_axis_asked_for(axis):
    piece = cylinder((0.1, 0.2, 0.3), 0.05, 0.4, axis)
    assert piece.kind == CYLINDER
    np.testing.assert_allclose(
        np.abs(_matrix(piece.orientation)[:, 2]), np.eye(3)[axis], atol=1e-12
    )
    lower, upper = bounding_boxes([piece])
    expected = np.full(3, 0.05)
    expected[axis] = 0.4
    np.testing.assert_allclose(upper[0] - lower[0], 2 * expected, atol=1e-12)


def test_placing_turns_centres_and_orientations_together():
    """A point fixed on a piece (a corner) lands where turning the whole scene puts it."""
    piece = box((0.8, 0.1, 0.4), (0.2, 0.05, 0.1), yaw=0.3)
    corner = piece.center + _matrix(piece.orientation) @ np.array([0.2, -0.05, 0.1])
    yaw, twist, anchor = 1.1, -0.25, np.array([0.7, 0.0, 0.0])
    (moved,) = placed([piece], yaw, twist, anchor)
    turned_corner = anchor + _turn_z(twist) @ (corner - anchor)
    turned_corner = _turn_z(yaw) @ turned_corner
    np.testing.assert_allclose(
        moved.center + _matrix(moved.orientation) @ np.array([0.2, -0.05, 0.1]), turned_corner
    )
    np.testing.assert_allclose(np.linalg.norm(moved.orientation), 1.0)


def test_bounding_boxes_and_obstacles_agree_with_the_workspace():
    pieces = placed(
        [box((0.6, 0.0, 0.2), (0.1, 0.2, 0.02)), cylinder((0.7, 0.1, 0.3), 0.03, 0.1, 1)], 0.7
    )
    pieces.append(box((0.0, 0.0, -0.06), (1.5, 1.5, 0.05)))
    limits = robot_spec("franka_panda").joint_limits()
    workspace = Workspace.from_obstacles("franka_panda", limits, as_obstacles(pieces))
    lower, upper = bounding_boxes(pieces)
    np.testing.assert_allclose(workspace.obstacle_lower, lower, atol=1e-12)
    np.testing.assert_allclose(workspace.obstacle_upper, upper, atol=1e-12)
    assert workspace.obstacle_kinds.tolist() == [BOX, CYLINDER, BOX]
    assert workspace.unrotated.tolist() == [False, False, True]
    assert np.array_equal(pieces[2].orientation, IDENTITY)
