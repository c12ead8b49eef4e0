"""Kinematics and sphere model of the KUKA iiwa 14."""

from __future__ import annotations

import numpy as np
import pybullet
import pytest
from pybullet_utils.bullet_client import BulletClient

from temp_gym.worlds.iiwa14.kinematics import (
    forward_kinematics,
    forward_kinematics_reference,
    joint_limits,
    link_meshes,
    motion_radii,
    read_stl,
    urdf_path,
)
from temp_gym.worlds.iiwa14.sphere_fit import load_mesh_radii, load_sphere_model, subdivide


@pytest.fixture(scope="module")
def configs() -> np.ndarray:
    limits = joint_limits()
    return np.random.default_rng(0).uniform(limits[0], limits[1], size=(200, 7))


def test_joint_limits_match_urdf():
    limits = joint_limits()
    assert limits.shape == (2, 7)
    np.testing.assert_allclose(limits[1, :2], [2.96705972839, 2.09439510239])
    np.testing.assert_allclose(limits[0], -limits[1])
    limits[0, 0] = 99.0  # a fresh copy each call
    assert joint_limits()[0, 0] != 99.0


def test_numba_fk_matches_numpy_reference(configs):
    poses = forward_kinematics(configs)
    assert poses.shape == (len(configs), 8, 4, 4)
    for q, pose in zip(configs, poses):
        np.testing.assert_allclose(pose, forward_kinematics_reference(q), atol=1e-12)
    np.testing.assert_allclose(poses[:, 0], np.broadcast_to(np.eye(4), (len(configs), 4, 4)))


def test_fk_stretched_arm_height():
    poses = forward_kinematics(np.zeros(7))
    np.testing.assert_allclose(poses[0, 7, :3, 3], [0.0, 0.0, 1.261], atol=1e-9)


def test_fk_matches_pybullet(configs):
    client = BulletClient(connection_mode=pybullet.DIRECT)
    try:
        robot = client.loadURDF(str(urdf_path()), [0, 0, 0], useFixedBase=True)
        assert client.getNumJoints(robot) == 7
        for q in configs[:100]:
            for j in range(7):
                client.resetJointState(robot, j, q[j])
            poses = forward_kinematics_reference(q)
            for j in range(7):
                state = client.getLinkState(robot, j, computeForwardKinematics=True)
                position = np.array(state[4])  # worldLinkFramePosition, not the inertial frame
                rotation = np.array(client.getMatrixFromQuaternion(state[5])).reshape(3, 3)
                np.testing.assert_allclose(position, poses[j + 1, :3, 3], atol=1e-6)
                np.testing.assert_allclose(rotation, poses[j + 1, :3, :3], atol=1e-6)
    finally:
        client.disconnect()


def test_fk_rejects_bad_shapes():
    with pytest.raises(ValueError, match="configs"):
        forward_kinematics(np.zeros((3, 6)))
    with pytest.raises(ValueError, match="configs"):
        forward_kinematics(np.zeros((2, 3, 7)))


def test_stl_reader_reads_every_link():
    meshes = link_meshes()
    assert len(meshes) == 8
    for vertices, faces in meshes:
        assert vertices.shape[1] == 3 and faces.shape[1] == 3
        assert faces.min() == 0 and faces.max() == len(vertices) - 1
    with pytest.raises(ValueError, match="binary STL"):
        read_stl(urdf_path())


def _surface_samples(vertices, faces, per_triangle, rng):
    triangles = vertices[faces]
    u = rng.random((len(triangles), per_triangle, 2))
    flip = u.sum(axis=2) > 1
    u[flip] = 1 - u[flip]
    a, b, c = triangles[:, None, 0], triangles[:, None, 1], triangles[:, None, 2]
    points = a + u[..., :1] * (b - a) + u[..., 1:] * (c - a)
    return points.reshape(-1, 3)


def test_spheres_cover_every_link_mesh():
    rng = np.random.default_rng(1)
    spheres = load_sphere_model()
    assert len(spheres) == 8
    for j, ((vertices, faces), (centers, radii)) in enumerate(zip(link_meshes(), spheres)):
        assert 3 <= len(radii) <= 8 or j == 0
        fine = subdivide(vertices, faces, 0.01).reshape(-1, 3)  # corners of small triangles
        points = np.concatenate([vertices, fine, _surface_samples(vertices, faces, 30, rng)])
        inside = np.zeros(len(points), dtype=bool)
        for center, radius in zip(centers, radii):
            inside |= np.linalg.norm(points - center, axis=1) <= radius
        assert inside.all(), f"link_{j}: {np.sum(~inside)} surface points outside every sphere"


def test_motion_radii_bound_real_motion(configs):
    radii = motion_radii(load_mesh_radii())
    vertices = [v for v, _ in link_meshes()]
    rng = np.random.default_rng(2)
    for q in configs[:50]:
        dq = rng.normal(0.0, 0.2, size=7)
        before, after = forward_kinematics(np.stack([q, q + dq]))
        bound = np.abs(dq) @ radii
        for j in range(1, 8):
            moved = (vertices[j] @ after[j, :3, :3].T + after[j, :3, 3]) - (
                vertices[j] @ before[j, :3, :3].T + before[j, :3, 3]
            )
            # A straight line is shorter than the arc, so the chord bound holds too.
            assert np.linalg.norm(moved, axis=1).max() <= bound[j] + 1e-12
