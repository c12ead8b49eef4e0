"""Obstacle kinds in the problem format (version 2) and their geometry in `Workspace`."""

import json

import numpy as np
import pytest

from temp_gym import Box, Cylinder, Problem, Sphere, Workspace
from temp_gym.problem.obstacles import (
    BOX,
    CYLINDER,
    SPHERE,
    rotation_matrices,
    world_half_extents,
)

BOUNDS_3D = [[0, 0, 0], [10, 10, 10]]
TURN_Z_45 = (0.0, 0.0, np.sin(np.pi / 8), np.cos(np.pi / 8))


def mixed_3d() -> Workspace:
    return Workspace.from_obstacles(
        "point3d",
        BOUNDS_3D,
        [
            Box((5, 5, 5), (1, 2, 3), TURN_Z_45),
            Cylinder((2, 7, 5), 0.5, 4.0),
            Sphere((8, 2, 5), 1.0),
            Box((2, 2, 8), (0.5, 0.5, 0.5)),
        ],
    )


def test_version_1_files_read_and_write_unchanged():
    data = {
        "robot": "point2d",
        "bounds": [[0.0, 0.0], [20.0, 20.0]],
        "obstacles": [{"center": [10.0, 10.0], "half_extents": [1.0, 3.0]}],
        "start": [2.0, 2.0],
        "goal": [18.0, 18.0],
        "goal_radius": 0.5,
    }
    problem = Problem.from_dict(data)
    assert problem.workspace.axis_aligned
    assert problem.to_dict() == data  # no "version", no "type": what older readers read
    assert Problem.from_dict({**data, "version": 1}) == problem
    typed = {**data, "obstacles": [{"type": "box", **data["obstacles"][0]}]}
    assert Problem.from_dict(typed) == problem
    assert Problem.from_dict({**typed, "version": 1}) == problem
    # A file that declares version 1 promises older readers axis-aligned boxes alone.
    disc = {**data, "version": 1, "obstacles": [{"type": "sphere", "center": [5, 5], "radius": 1}]}
    with pytest.raises(ValueError, match=r'^obstacles\[0\]: a sphere needs "version": 2'):
        Problem.from_dict(disc)
    turned = {**typed, "version": 1, "obstacles": [{**typed["obstacles"][0], "orientation": 0.5}]}
    with pytest.raises(ValueError, match=r'^obstacles\[0\]: an oriented box needs "version": 2'):
        Problem.from_dict(turned)
    assert Problem.from_dict({**disc, "version": 2}).workspace.num_obstacles == 1


def test_version_2_round_trips_exactly_through_json():
    problem = Problem(mixed_3d(), [0.5, 0.5, 0.5], [9.5, 9.5, 0.5], 0.5)
    data = problem.to_dict()
    assert data["version"] == 2
    kinds = [entry["type"] for entry in data["obstacles"]]
    assert kinds == ["box", "cylinder", "sphere", "box"]
    assert "orientation" in data["obstacles"][0] and "orientation" not in data["obstacles"][3]
    assert data["obstacles"][1]["length"] == 4.0 and data["obstacles"][1]["radius"] == 0.5
    again = Problem.from_dict(json.loads(json.dumps(data)))
    assert again == problem and hash(again) == hash(problem)
    assert again.workspace.obstacles == problem.workspace.obstacles


def test_objects_and_arrays_agree():
    workspace = mixed_3d()
    assert workspace.obstacle_kinds.tolist() == [BOX, CYLINDER, SPHERE, BOX]
    assert workspace.obstacle_half_extents[1].tolist() == [0.5, 0.5, 2.0]
    assert workspace.obstacle_half_extents[2].tolist() == [1.0, 1.0, 1.0]
    assert not workspace.axis_aligned
    assert workspace.unrotated.tolist() == [False, True, True, True]
    assert workspace.obstacles[1] == Cylinder((2.0, 7.0, 5.0), 0.5, 4.0, None)
    assert Workspace.from_obstacles("point3d", BOUNDS_3D, workspace.obstacles) == workspace


def test_bounding_boxes_contain_every_point_of_each_obstacle_and_touch_it():
    """The tight AABB: sampled points of each kind stay inside it and reach its faces."""
    rng = np.random.default_rng(0)
    turns = rng.normal(size=(6, 4))
    turns /= np.linalg.norm(turns, axis=1, keepdims=True)
    obstacles = []
    for q in turns[:3]:
        obstacles.append(Box((5, 5, 5), (1.0, 0.3, 2.0), tuple(q)))
    for q in turns[3:]:
        obstacles.append(Cylinder((5, 5, 5), 0.4, 3.0, tuple(q)))
    obstacles.append(Sphere((5, 5, 5), 0.7))
    workspace = Workspace.from_obstacles("point3d", BOUNDS_3D, obstacles)
    for b in range(workspace.num_obstacles):
        local = surface_points(workspace.obstacle_kinds[b], workspace.obstacle_half_extents[b])
        world = local @ workspace.obstacle_rotations[b].T + workspace.obstacle_centers[b]
        lower, upper = workspace.obstacle_lower[b], workspace.obstacle_upper[b]
        assert np.all(world >= lower - 1e-9) and np.all(world <= upper + 1e-9)
        assert np.allclose(world.min(axis=0), lower, atol=2e-3)
        assert np.allclose(world.max(axis=0), upper, atol=2e-3)


def surface_points(kind: int, half: np.ndarray, count: int = 4000) -> np.ndarray:
    """Dense points on the surface of one obstacle in its own frame (corners and rims too)."""
    angle = np.linspace(0.0, 2.0 * np.pi, count)
    if kind == BOX:
        corners = np.array(np.meshgrid(*[[-1, 1]] * 3)).reshape(3, -1).T
        return corners * half
    if kind == CYLINDER:
        rim = np.stack([np.cos(angle), np.sin(angle)], axis=1) * half[0]
        return np.concatenate(
            [np.column_stack([rim, np.full(count, z)]) for z in (-half[2], half[2])]
        )
    polar = np.arccos(np.linspace(-1.0, 1.0, 200))
    theta, phi = np.meshgrid(angle[::20], polar)
    return half[0] * np.column_stack(
        [
            (np.sin(phi) * np.cos(theta)).ravel(),
            (np.sin(phi) * np.sin(theta)).ravel(),
            np.cos(phi).ravel(),
        ]  # fmt: skip
    )


def test_rotations_are_proper_and_match_an_independent_formula():
    rng = np.random.default_rng(1)
    q = rng.normal(size=(20, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    rotations = rotation_matrices(q)
    for quaternion, rotation in zip(q, rotations):
        assert np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
        assert np.isclose(np.linalg.det(rotation), 1.0)
        # Rodrigues: rotation by angle 2 acos(w) about the quaternion's axis
        x, y, z, w = quaternion
        angle = 2.0 * np.arccos(np.clip(w, -1, 1))
        axis = np.array([x, y, z]) / np.linalg.norm([x, y, z])
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        expected = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
        assert np.allclose(rotation, expected, atol=1e-12)
    assert np.array_equal(rotation_matrices(np.array([[0.0, 0, 0, -1]]))[0], np.eye(3))
    angle = rotation_matrices(np.array([[np.pi / 2]]))[0]
    assert np.allclose(angle @ [1.0, 0.0], [0.0, 1.0])


def test_2d_kinds_rotated_rectangles_and_discs():
    workspace = Workspace.from_obstacles(
        "point2d", [[0, 0], [20, 20]], [Box((10, 10), (2, 1), np.pi / 2), Sphere((4, 4), 1.5)]
    )
    assert np.allclose(workspace.obstacle_lower, [[9, 8], [2.5, 2.5]])
    assert np.allclose(workspace.obstacle_upper, [[11, 12], [5.5, 5.5]])
    data = Problem(workspace, [1, 18], [18, 1], 0.5).to_dict()
    assert data["obstacles"][0]["orientation"] == np.pi / 2
    assert data["obstacles"][1] == {"type": "sphere", "center": [4.0, 4.0], "radius": 1.5}
    assert np.isclose(workspace.obstacle_volumes[1], np.pi * 1.5**2)


def test_grown_grows_every_kind_by_the_margin():
    grown = mixed_3d().grown(0.25)
    assert grown.obstacle_half_extents[1].tolist() == [0.75, 0.75, 2.25]
    assert grown.obstacle_half_extents[2].tolist() == [1.25, 1.25, 1.25]
    assert grown.obstacle_kinds.tolist() == mixed_3d().obstacle_kinds.tolist()
    kept = mixed_3d().with_obstacles(np.array([False, True, True, False]))
    assert kept.obstacle_kinds.tolist() == [CYLINDER, SPHERE]


def test_world_half_extents_of_an_upright_cylinder_is_radius_and_half_length():
    kinds = np.array([CYLINDER])
    half = np.array([[0.5, 0.5, 2.0]])
    assert world_half_extents(kinds, half, np.eye(3)[None]).tolist() == [[0.5, 0.5, 2.0]]


BASE = {
    "robot": "point3d",
    "bounds": BOUNDS_3D,
    "start": [0.5, 0.5, 0.5],
    "goal": [9.5, 9.5, 9.5],
    "goal_radius": 0.5,
}


@pytest.mark.parametrize(
    "obstacle, field, reason",
    [
        ({"type": "cone", "center": [1, 1, 1]}, "obstacles[0].type", "not an obstacle type"),
        ({"type": 3, "center": [1, 1, 1]}, "obstacles[0].type", "not an obstacle type"),
        ({"type": "cylinder", "center": [5, 5, 5], "radius": 1}, "obstacles[0]", "length is"),
        (
            {"type": "cylinder", "center": [5, 5, 5], "radius": 0, "length": 1},
            "obstacles[0].radius",
            "positive",
        ),  # fmt: skip
        (
            {"type": "sphere", "center": [5, 5, 5], "radius": float("nan")},
            "obstacles[0].radius",
            "positive",
        ),  # fmt: skip
        (
            {"type": "sphere", "center": [5, 5, 5], "radius": 1, "orientation": [0, 0, 0, 1]},
            "obstacles[0].orientation",
            "unknown key",
        ),  # fmt: skip
        (
            {"type": "sphere", "center": [5, 5, 5], "radius": 1, "half_extents": [1, 1, 1]},
            "obstacles[0].half_extents",
            "a sphere has center and radius",
        ),  # fmt: skip
        (
            {"center": [5, 5, 5], "half_extents": [1, 1, 1], "orientation": [0, 0, 0, 0.5]},
            "obstacles[0].orientation",
            "unit length",
        ),  # fmt: skip
        (
            {"center": [5, 5, 5], "half_extents": [1, 1, 1], "orientation": [0, 0, 1]},
            "obstacles[0].orientation",
            "expected 4 numbers",
        ),  # fmt: skip
        (
            {"center": [5, 5, 5], "half_extents": [1, 1, 1], "orientation": 0.3},
            "obstacles[0].orientation",
            "quaternion",
        ),  # fmt: skip
    ],
)
def test_invalid_obstacles_name_the_field_and_the_reason(obstacle, field, reason):
    with pytest.raises(ValueError) as error:
        Problem.from_dict({**BASE, "obstacles": [obstacle]})
    message = str(error.value)
    assert message.startswith(field), message
    assert reason in message, message
    assert "\n" not in message


@pytest.mark.parametrize(
    "obstacles, message",
    [
        ([Box((1, 2), (1, 1, 1))], r"^obstacles\[0\].center: expected 3 numbers, got 2$"),
        ([Sphere((5, 5, 5), 1), Box("abc", (1, 1, 1))], r"^obstacles\[1\].center: expected a list"),
        ([Cylinder((5, 5, 5), 0, 1)], r"^obstacles\[0\].radius: must be positive"),
        ([Sphere((5, 5, 5), -1)], r"^obstacles\[0\].radius: must be positive"),
        ([Sphere((5, 5, 5), [1])], r"^obstacles\[0\].radius: expected a number"),
        ([Box((5, 5, 5), (1e-300, 1, 1))], r"^obstacles\[0\].half_extents: every side must be"),
        ([Cylinder((5, 5, 5), None, 1)], r"^obstacles\[0\].radius: expected a number"),
        ([Box((5, 5, 5), (1, 1, 1), (0, 0, 0, 0))], r"^obstacles\[0\].orientation: "),
        ([(5, 5, 5)], r"^obstacles\[0\]: expected a Box, Cylinder or Sphere, got tuple$"),
        (Box((5, 5, 5), (1, 1, 1)), r"^obstacles: expected a list of Box, Cylinder or Sphere"),
    ],
)
def test_obstacle_objects_are_checked_as_file_entries_are(obstacles, message):
    with pytest.raises(ValueError, match=message):
        Workspace.from_obstacles("point3d", BOUNDS_3D, obstacles)


def test_missing_bounds_are_named_as_missing():
    with pytest.raises(ValueError, match=r"^bounds: expected numbers, got None$"):
        Workspace.from_obstacles("point3d", None, [])


def test_a_2d_angle_that_is_not_finite_is_named():
    flat = {**BASE, "robot": "point2d", "bounds": [[0, 0], [10, 10]], "start": [1, 1],
            "goal": [9, 9]}  # fmt: skip
    box = {"center": [5, 5], "half_extents": [1, 1], "orientation": float("nan")}
    with pytest.raises(ValueError, match=r"^obstacles\[0\].orientation: must be finite"):
        Problem.from_dict({**flat, "obstacles": [box]})


def test_obstacle_objects_may_hold_numpy_arrays():
    turned = Workspace.from_obstacles("point3d", BOUNDS_3D, [
        Box(np.array([5.0, 5, 5]), np.array([1.0, 2, 3]), np.array(TURN_Z_45))])  # fmt: skip
    assert turned.obstacles == [Box((5.0, 5.0, 5.0), (1.0, 2.0, 3.0), TURN_Z_45)]


def test_cylinders_need_a_3d_workspace_and_versions_are_checked():
    flat = {**BASE, "robot": "point2d", "bounds": [[0, 0], [10, 10]], "start": [1, 1],
            "goal": [9, 9]}  # fmt: skip
    with pytest.raises(ValueError, match=r"^obstacles\[0\].type: a cylinder needs a 3D"):
        Problem.from_dict(
            {
                **flat,
                "obstacles": [{"type": "cylinder", "center": [5, 5], "radius": 1, "length": 1}],
            }  # fmt: skip
        )
    for version in (3, 0, "2", True, None):
        with pytest.raises(ValueError, match=r"^version: .* is not a problem-format version"):
            Problem.from_dict({**BASE, "obstacles": [], "version": version})


def test_workspace_arrays_are_validated():
    centers, halves = [[5.0, 5, 5]], [[1.0, 2, 2]]
    with pytest.raises(ValueError, match="radius and must be equal"):
        Workspace("point3d", BOUNDS_3D, centers, halves, np.array([CYLINDER]))
    with pytest.raises(ValueError, match="a sphere's are all its radius"):
        Workspace("point3d", BOUNDS_3D, centers, halves, np.array([SPHERE]))
    with pytest.raises(ValueError, match="unknown kind 7"):
        Workspace("point3d", BOUNDS_3D, centers, halves, np.array([7]))
    with pytest.raises(ValueError, match=r"shape \(1, 4\)"):
        Workspace("point3d", BOUNDS_3D, centers, halves, np.array([BOX]), np.zeros((1, 1)))
    with pytest.raises(ValueError, match="a sphere has no orientation"):
        Workspace("point3d", BOUNDS_3D, centers, [[1.0, 1, 1]], np.array([SPHERE]),
                  np.array([TURN_Z_45]))  # fmt: skip


def test_a_nearly_unit_quaternion_is_normalized_and_kept_as_written():
    q = [0.0, 0.0, 0.7071068, 0.7071068]  # six digits, as scene files write them
    problem = Problem.from_dict(
        {
            **BASE,
            "obstacles": [{"center": [5, 5, 5], "half_extents": [1, 2, 1], "orientation": q}],
        }  # fmt: skip
    )
    assert problem.to_dict()["obstacles"][0]["orientation"] == q
    rotation = problem.workspace.obstacle_rotations[0]
    assert np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-14)
    assert np.allclose(problem.workspace.obstacle_upper[0], [7, 6, 6])


def test_obstacle_rows_of_another_width_are_refused_not_reshaped():
    # Six numbers are three 2D centers or two 3D ones: reading either as the other would
    # silently make different obstacles.
    with pytest.raises(ValueError, match=r"^obstacles: center: expected one row of 2 numbers"):
        Workspace("point2d", [[0, 0], [20, 20]], [[1, 2, 3], [4, 5, 6]], [[1, 1, 1], [1, 1, 1]])
    with pytest.raises(ValueError, match=r"^obstacles: half_extents: .* got \(1, 2\)"):
        Workspace("point3d", BOUNDS_3D, [[5.0, 5, 5]], [[1.0, 1]])
    with pytest.raises(ValueError, match=r"got \(3,\)"):
        Workspace("point3d", BOUNDS_3D, [5.0, 5, 5], [1.0, 1, 1])
    with pytest.raises(ValueError, match=r"^obstacles: center: expected real numbers"):
        Workspace("point2d", [[0, 0], [20, 20]], np.array([[True, True]]), [[1.0, 1]])
    empty = Workspace("point3d", BOUNDS_3D, [], np.zeros((0, 3)))
    assert empty.obstacle_centers.shape == empty.obstacle_half_extents.shape == (0, 3)


@pytest.mark.parametrize(
    "q",
    [[0.0, 0.0, 0.0, -1.0], [0.0, 0.0, -0.3826834, -0.9238795], [0.6, -0.8, 0.0, 0.0]],
)
def test_a_quaternion_and_its_negative_make_one_workspace_and_round_trip(q):
    def workspace(orientation):
        return Workspace("point3d", BOUNDS_3D, [[5.0, 5, 5]], [[1.0, 2, 1]], np.array([BOX]),
                         np.array([orientation]))  # fmt: skip

    given, negated = workspace(q), workspace([-v for v in q])
    assert given == negated and hash(given) == hash(negated)
    np.testing.assert_array_equal(given.obstacle_rotations, negated.obstacle_rotations)
    problem = Problem(given, [1, 1, 1], [9, 9, 9], 0.5)
    assert Problem.from_dict(json.loads(json.dumps(problem.to_dict()))) == problem
