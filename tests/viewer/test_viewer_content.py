import numpy as np
import pytest
from viewer_cases import IIWA, random_tree, reference_body_poses, straight_path

from temp_gym.planning.result import PlanTree
from temp_gym.problem import Problem, Workspace
from temp_gym.problem.obstacles import BOX, CYLINDER, SPHERE, Box, Cylinder, Sphere
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


TURN = (0.0, 0.0, np.sin(0.3), np.cos(0.3))  # 0.6 rad about z


def test_a_3d_plan_lists_each_obstacle_kind_with_its_parameters():
    obstacles = [
        Box((4, 4, 4), (1, 2, 3), TURN),
        Cylinder((10, 15, 10), 1.5, 4.0, TURN),
        Sphere((15, 5, 12), 2.0),
        Box((5, 15, 15), (1, 1, 1)),
    ]
    workspace = Workspace.from_obstacles("point3d", [[0, 0, 0], [20, 20, 20]], obstacles)
    content = plan_content(Problem(workspace, start=[1, 1, 18], goal=[19, 19, 1], goal_radius=1))
    solids = content.obstacles
    assert solids.kinds.tolist() == [BOX, CYLINDER, SPHERE, BOX]
    np.testing.assert_allclose(solids.centers, [o.center for o in obstacles])
    np.testing.assert_allclose(
        solids.half_extents, [[1, 2, 3], [1.5, 1.5, 2], [2, 2, 2], [1, 1, 1]]
    )
    turned = np.array([[np.cos(0.6), -np.sin(0.6), 0], [np.sin(0.6), np.cos(0.6), 0], [0, 0, 1]])
    np.testing.assert_allclose(solids.rotations, [turned, turned, np.eye(3), np.eye(3)], atol=1e-12)
    np.testing.assert_allclose(content.box_lower, workspace.obstacle_lower)  # bounding boxes
    np.testing.assert_allclose(content.box_upper, workspace.obstacle_upper)


def test_a_2d_plans_discs_and_turned_rectangles_stand_low_on_the_plane():
    obstacles = [Box((5, 5), (3, 1), 0.6), Sphere((14, 12), 2.5)]
    workspace = Workspace.from_obstacles("point2d", [[0, 0], [20, 20]], obstacles)
    content = plan_content(Problem(workspace, start=[1, 18], goal=[19, 1], goal_radius=1))
    height = FLAT_HEIGHT_SHARE * 20
    solids = content.obstacles
    assert solids.kinds.tolist() == [BOX, CYLINDER]  # a disc is a low cylinder
    np.testing.assert_allclose(solids.centers, [[5, 5, height / 2], [14, 12, height / 2]])
    np.testing.assert_allclose(solids.half_extents, [[3, 1, height / 2], [2.5, 2.5, height / 2]])
    np.testing.assert_allclose(solids.rotations[0, :2, :2], workspace.obstacle_rotations[0])
    np.testing.assert_allclose(solids.rotations[0, 2], [0, 0, 1])
    np.testing.assert_allclose(solids.rotations[1], np.eye(3))
    np.testing.assert_allclose(content.box_lower[:, 2], 0.0)
    np.testing.assert_allclose(content.box_upper[:, 2], height)
    np.testing.assert_allclose(content.box_lower[1, :2], [11.5, 9.5])


def test_an_arm_plan_lists_each_obstacle_kind():
    far = [Sphere((1.9, 0, 0.4), 0.3), Cylinder((0, 1.9, 0.4), 0.2, 0.8), Box((-1.9, 0, 0.4),
           (0.3, 0.1, 0.3), TURN)]  # fmt: skip
    bounds = Problem.from_dict(IIWA).bounds
    workspace = Workspace.from_obstacles("kuka_iiwa14", bounds, far)
    problem = Problem(workspace, start=IIWA["start"], goal=IIWA["goal"], goal_radius=0.1)
    solids = plan_content(problem).obstacles
    assert solids.kinds.tolist() == [SPHERE, CYLINDER, BOX]
    np.testing.assert_allclose(solids.half_extents[1], [0.2, 0.2, 0.4])
    assert solids.aligned_boxes.tolist() == [False, False, False]
