import numpy as np
import pytest

from temp_gym.problem import Problem, Workspace
from temp_gym.problem.obstacles import BOX, CYLINDER, SPHERE, Box, Cylinder, Sphere
from temp_gym.worlds.rendering.solids import (
    CURVE_SEGMENTS,
    Solids,
    box_faces,
    outline,
    surface,
    triangle_mesh,
)

TURNED = np.array([0.0, np.sin(np.pi / 8), 0.0, np.cos(np.pi / 8)])  # 45 degrees about y


def rotation_about(axis: int, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    i, j = [k for k in range(3) if k != axis]
    rotation = np.eye(3)
    rotation[i, i], rotation[i, j], rotation[j, i], rotation[j, j] = c, -s, s, c
    return rotation


def outward(polygons: list[np.ndarray], center: np.ndarray) -> bool:
    """Whether every polygon's winding normal points away from ``center``."""
    for polygon in polygons:
        normal = np.cross(polygon[1] - polygon[0], polygon[2] - polygon[1])
        if np.dot(normal, polygon.mean(axis=0) - center) <= 0.0:
            return False
    return True


def test_a_turned_rectangles_outline_is_its_corners_turned():
    center, half = np.array([5.0, 3.0]), np.array([2.0, 1.0])
    angle = 0.5
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    corners = outline(BOX, center, half, rotation)
    expected = center + np.array([[-2, -1], [2, -1], [2, 1], [-2, 1]]) @ rotation.T
    np.testing.assert_allclose(corners, expected)
    straight = outline(BOX, center, half, np.eye(2))
    assert not np.allclose(corners, straight)
    np.testing.assert_allclose(straight, [[3, 2], [7, 2], [7, 4], [3, 4]])


def test_a_discs_outline_lies_on_its_circle():
    ring = outline(SPHERE, np.array([1.0, 2.0]), np.array([3.0, 3.0]), np.eye(2))
    np.testing.assert_allclose(np.linalg.norm(ring - [1, 2], axis=1), 3.0)
    assert len(ring) >= 32


def test_a_turned_boxs_faces_have_its_corners():
    center, half = np.array([1.0, 2.0, 3.0]), np.array([0.5, 0.2, 0.1])
    rotation = rotation_about(2, 0.7)
    corners = np.unique(np.concatenate(surface(BOX, center, half, rotation)).round(9), axis=0)
    local = (corners - center) @ rotation  # back in the box's frame
    np.testing.assert_allclose(np.sort(np.abs(local), axis=0), np.tile(half, (8, 1)))
    straight = surface(BOX, center, half, np.eye(3))
    np.testing.assert_allclose(straight, box_faces(center - half, center + half))


def test_a_cylinders_surface_lies_on_it_and_faces_out():
    center, half = np.array([0.0, 1.0, -1.0]), np.array([0.3, 0.3, 0.8])
    rotation = rotation_about(0, 1.1)
    polygons = surface(CYLINDER, center, half, rotation)
    assert len(polygons) == CURVE_SEGMENTS + 2  # side strips and two caps
    local = (np.concatenate(polygons) - center) @ rotation
    np.testing.assert_allclose(np.linalg.norm(local[:, :2], axis=1), 0.3)
    np.testing.assert_allclose(np.abs(local[:, 2]), 0.8)
    assert outward(polygons, center)


def test_a_spheres_surface_lies_on_it_and_faces_out():
    center = np.array([2.0, 0.0, 1.0])
    polygons = surface(SPHERE, center, np.full(3, 0.4), np.eye(3))
    np.testing.assert_allclose(np.linalg.norm(np.concatenate(polygons) - center, axis=1), 0.4)
    assert outward(polygons, center)
    assert {len(polygon) for polygon in polygons} == {3, 4}  # triangles at the poles


def test_triangle_mesh_fans_each_polygon():
    square = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    vertices, faces = triangle_mesh([square, square[:3] + 5])
    assert vertices.shape == (7, 3) and faces.tolist() == [[0, 1, 2], [0, 2, 3], [4, 5, 6]]


def test_solids_of_a_workspace_and_of_boxes():
    workspace = Workspace.from_obstacles(
        "point3d",
        [[0, 0, 0], [10, 10, 10]],
        [
            Box((2, 2, 2), (1, 1, 1)),
            Box((5, 5, 5), (1, 2, 1), tuple(TURNED)),
            Cylinder((8, 2, 2), 0.5, 2.0),
            Sphere((2, 8, 8), 1.0),
        ],
    )
    solids = Solids.of_workspace(workspace)
    assert solids.kinds.tolist() == [BOX, BOX, CYLINDER, SPHERE] and len(solids) == 4
    assert solids.aligned_boxes.tolist() == [True, False, False, False]
    np.testing.assert_allclose(solids.lower, workspace.obstacle_lower)
    boxes = Solids.boxes([[0, 0, 0]], [[2, 4, 6]])
    np.testing.assert_allclose(boxes.centers, [[1, 2, 3]])
    np.testing.assert_allclose(boxes.half_extents, [[1, 2, 3]])
    assert boxes.aligned_boxes.tolist() == [True]
    flat = Problem.from_dict(
        {"robot": "point2d", "bounds": [[0, 0], [9, 9]], "obstacles": [],
         "start": [1, 1], "goal": [8, 8], "goal_radius": 0.5}
    )  # fmt: skip
    with pytest.raises(ValueError, match="workspace: Solids.of_workspace takes a 3D"):
        Solids.of_workspace(flat.workspace)
