import numpy as np
from viewer_cases import IIWA

from temp_gym.problem import Problem
from temp_gym.viewer.content import plan_content
from temp_gym.viewer.drawing import ARM_CAMERA_DISTANCE, ARM_VIEWS, _region_edges, camera_pose
from temp_gym.worlds.rendering.camera import orbit_position, visible_points


def test_a_2d_world_is_seen_from_above_its_centre(point2d):
    position, look_at = camera_pose(plan_content(point2d))
    np.testing.assert_allclose(look_at, [10, 10, 0])
    assert position[2] > 20 and np.linalg.norm(position[:2] - look_at[:2]) < 2


def test_region_outlines():
    region = np.array([[0.0, 0, 0], [1, 2, 3]])
    box, flat = _region_edges(region, False), _region_edges(region, True)
    assert box.shape == (12, 2, 3) and flat.shape == (4, 2, 3)
    lengths = sorted(np.linalg.norm(box[:, 1] - box[:, 0], axis=1).round(6))
    assert lengths == [1] * 4 + [2] * 4 + [3] * 4
    np.testing.assert_allclose(flat[..., 2], 0.0)


def test_the_arm_is_seen_from_where_the_goal_hand_is_in_sight():
    # A shelf back right behind the goal hand hides it from the +y half of the ring.
    shelved = Problem.from_dict(
        {
            **IIWA,
            "obstacles": [
                {"center": [0.2, 0.85, 0.7], "half_extents": [0.7, 0.05, 0.7]},
                {"center": [0.2, 0.55, 1.35], "half_extents": [0.7, 0.3, 0.05]},
            ],
        }
    )
    content = plan_content(shelved)
    hand = content.arm.goal_poses[-3:, :3, 3]
    position, look_at = camera_pose(content)
    assert visible_points(position, hand, content.obstacles).all()
    hidden = [
        view
        for view in ARM_VIEWS
        if not visible_points(
            orbit_position(look_at, *view, ARM_CAMERA_DISTANCE), hand, content.obstacles
        ).all()
    ]
    assert hidden  # the shelf does hide the hand from some views
    assert np.isclose(np.linalg.norm(position - look_at), ARM_CAMERA_DISTANCE)


class RecordingScene:
    """Stands in for a viser scene: records each ``add_*`` call's name and keywords."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, str, dict]] = []

    def __getattr__(self, method: str):
        def record(name, *args, **keywords):
            self.calls.append((method, name, {"args": args, **keywords}))

        return record


def quaternion_matrix(wxyz) -> np.ndarray:
    from temp_gym.problem.obstacles import rotation_matrices

    w, x, y, z = wxyz
    return rotation_matrices(np.array([[x, y, z, w]]))[0]


def test_each_obstacle_kind_is_added_by_its_shape():
    from temp_gym.problem import Workspace
    from temp_gym.problem.obstacles import Box, Cylinder, Sphere
    from temp_gym.viewer.drawing import _add_obstacle

    turn = (np.sin(0.4), 0.0, 0.0, np.cos(0.4))  # 0.8 rad about x
    obstacles = [
        Box((2, 3, 4), (1, 2, 3)),
        Box((10, 10, 10), (1, 2, 3), turn),
        Cylinder((15, 5, 5), 1.5, 4.0, turn),
        Sphere((5, 15, 15), 2.0),
    ]
    workspace = Workspace.from_obstacles("point3d", [[0, 0, 0], [20, 20, 20]], obstacles)
    content = plan_content(Problem(workspace, start=[19, 19, 1], goal=[1, 1, 19], goal_radius=1))
    scene = RecordingScene()
    for index in range(4):
        _add_obstacle(scene, content, index, (1, 2, 3), 0.45)
    methods = [(method, name) for method, name, _ in scene.calls]
    assert methods == [
        ("add_box", "/obstacles/box_0"),
        ("add_box", "/obstacles/box_1"),
        ("add_mesh_simple", "/obstacles/cylinder_2"),
        ("add_icosphere", "/obstacles/sphere_3"),
    ]
    aligned, turned, cylinder, sphere = (keywords for _, _, keywords in scene.calls)
    np.testing.assert_allclose(aligned["dimensions"], [2, 4, 6])
    np.testing.assert_allclose(aligned["position"], [2, 3, 4])
    assert "wxyz" not in aligned and aligned["opacity"] == 0.45
    np.testing.assert_allclose(turned["dimensions"], [2, 4, 6])
    rotation = workspace.obstacle_rotations[1]
    np.testing.assert_allclose(quaternion_matrix(turned["wxyz"]), rotation, atol=1e-9)
    # The cylinder's mesh, placed by its pose, lies on the cylinder.
    vertices, faces = cylinder["args"]
    world = vertices @ quaternion_matrix(cylinder["wxyz"]).T + cylinder["position"]
    local = (world - [15, 5, 5]) @ workspace.obstacle_rotations[2]
    np.testing.assert_allclose(np.linalg.norm(local[:, :2], axis=1), 1.5)
    np.testing.assert_allclose(np.abs(local[:, 2]), 2.0)
    assert faces.max() < len(vertices)
    assert sphere["radius"] == 2.0
    np.testing.assert_allclose(sphere["position"], [5, 15, 15])
