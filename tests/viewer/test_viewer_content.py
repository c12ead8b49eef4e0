import numpy as np
import pytest
from viewer_cases import random_tree, reference_body_poses, straight_path

from temp_gym.planning.result import PlanTree
from temp_gym.viewer.content import FLAT_HEIGHT_SHARE, plan_content, resample_path


def test_resample_path_spaces_states_evenly_by_length():
    path = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 1.0]])
    frames = resample_path(path, 5)
    np.testing.assert_allclose(frames[[0, -1]], path[[0, -1]])
    np.testing.assert_allclose(np.linalg.norm(np.diff(frames, axis=0), axis=1), 1.0)
    np.testing.assert_allclose(resample_path(path[:1], 4), path[[0, 0]])  # one state: still


def test_a_2d_plan_lies_flat_in_the_plane(point2d):
    tree = random_tree(point2d, 40)
    content = plan_content(point2d, path=straight_path(point2d), tree=tree, frames=30)
    assert content.flat and content.arm is None and content.frames == 30
    np.testing.assert_allclose(content.region, [[0, 0, 0], [20, 20, 0]])
    np.testing.assert_allclose(content.start, [2, 2, 0])
    np.testing.assert_allclose(content.goal, [18, 18, 0])
    assert content.goal_radius == point2d.goal_radius
    assert content.tree_segments.shape == (39, 2, 3)  # one edge per node but the root
    np.testing.assert_allclose(content.tree_segments[..., 2], 0.0)
    np.testing.assert_allclose(content.tree_segments[:, 0, :2], tree.positions[1:])
    np.testing.assert_allclose(content.tree_segments[:, 1, :2], tree.positions[tree.parents[1:]])
    np.testing.assert_allclose(content.box_lower, [[8, 4, 0]])
    np.testing.assert_allclose(content.box_upper, [[12, 16, FLAT_HEIGHT_SHARE * 20]])
    np.testing.assert_allclose(content.frame_positions[[0, -1]], [[2, 2, 0], [18, 18, 0]])


def test_a_3d_plan_without_a_tree_or_path(point3d):
    content = plan_content(point3d)
    assert not content.flat and content.path_trace is None
    assert content.tree_segments.shape == (0, 2, 3)
    assert content.frames == 1  # the robot stands at the start
    np.testing.assert_allclose(content.frame_positions[0], point3d.start)
    np.testing.assert_allclose(content.box_upper, [[12, 16, 14]])


def test_an_arm_plan_is_drawn_at_its_hand(iiwa):
    path = straight_path(iiwa, 3)
    content = plan_content(iiwa, path=path, tree=random_tree(iiwa, 10), frames=7)
    start_links = reference_body_poses(iiwa.robot, iiwa.start)
    goal_links = reference_body_poses(iiwa.robot, iiwa.goal)
    np.testing.assert_allclose(content.start, start_links[-1, :3, 3], atol=1e-9)
    np.testing.assert_allclose(content.goal, goal_links[-1, :3, 3], atol=1e-9)
    np.testing.assert_allclose(content.arm.start_poses, start_links, atol=1e-9)
    np.testing.assert_allclose(content.arm.goal_poses, goal_links, atol=1e-9)
    assert content.arm.frame_poses.shape == (7, 8, 4, 4)
    middle = reference_body_poses(iiwa.robot, path[1])  # frame 3 of 7 is the path's midpoint
    np.testing.assert_allclose(content.arm.frame_poses[3], middle, atol=1e-9)
    np.testing.assert_allclose(content.path_trace, content.frame_positions)
    assert content.tree_segments.shape == (9, 2, 3) and content.goal_radius is None
    assert content.box_is_floor.tolist() == [True, False]
    np.testing.assert_allclose(content.region, [[-1.4, -1.4, -0.2], [1.4, 1.4, 1.6]])


def test_bad_paths_and_trees_are_named(point2d):
    with pytest.raises(ValueError, match=r"path: expected shape \(K, 2\)"):
        plan_content(point2d, path=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="path: expected finite"):
        plan_content(point2d, path=np.array([[0.0, 0.0], [np.nan, 1.0]]))
    with pytest.raises(ValueError, match="tree: expected positions"):
        plan_content(point2d, tree=PlanTree(np.zeros((4, 2)), np.zeros(3, int)))
    with pytest.raises(ValueError, match="tree: a parent index"):
        plan_content(point2d, tree=PlanTree(np.zeros((2, 2)), np.array([-1, 5])))
