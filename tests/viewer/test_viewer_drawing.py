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
