import numpy as np
import pytest
from viewer_cases import reference_body_poses

from temp_gym.viewer.arm_geometry import (
    arm_link_meshes,
    arm_link_poses,
    has_arm_geometry,
    is_point_robot,
)
from temp_gym.worlds.robots import robot_spec


def test_point_robots_need_no_arm_geometry():
    for name in ("point2d", "point3d"):
        spec = robot_spec(name)
        assert is_point_robot(spec) and not has_arm_geometry(spec)
        with pytest.raises(ValueError, match=f"robot: '{name}' has no arm geometry"):
            arm_link_meshes(spec)


@pytest.mark.parametrize("robot", ["kuka_iiwa14", "franka_panda"])
def test_the_arm_has_a_mesh_per_link_and_poses_from_its_kinematics(robot):
    spec = robot_spec(robot)
    assert not is_point_robot(spec) and has_arm_geometry(spec)
    meshes = arm_link_meshes(spec)
    configs = np.random.default_rng(0).uniform(-1, 1, size=(3, spec.dim))
    poses = arm_link_poses(spec, configs)
    assert poses.shape == (3, len(meshes), 4, 4)
    for config, pose in zip(configs, poses):
        np.testing.assert_allclose(pose, reference_body_poses(spec.name, config), atol=1e-9)
    for vertices, faces in meshes:
        assert vertices.shape[1] == 3 and faces.shape[1] == 3
        assert faces.min() >= 0 and faces.max() < len(vertices)
    # Each link's mesh lies near its own frame's origin (in its frame): no link is placed twice.
    assert all(np.linalg.norm(v.mean(axis=0)) < 0.3 for v, _ in meshes)


def test_arm_link_poses_rejects_misshaped_configurations():
    with pytest.raises(ValueError, match=r"configs: expected shape \(N, 7\)"):
        arm_link_poses(robot_spec("kuka_iiwa14"), np.zeros((2, 6)))
