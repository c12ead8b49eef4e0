"""The generic arm's kinematics against pybullet's, and the motion bounds the checkers use."""

from __future__ import annotations

import numpy as np
import pytest
from arm_fixtures import random_configs, write_test_arm

from temp_gym.quiet import native_output_silenced
from temp_gym.worlds.arm.bullet import load_bullet_arm, set_configuration
from temp_gym.worlds.arm.model import load_arm
from temp_gym.worlds.robots import robot_spec

XARM = """name: xarm6_model_test
urdf: pybullet_data://xarm/xarm6_robot.urdf
base_link: link_base
tip_link: link6
"""

MOBILE_URDF = """<?xml version="1.0"?><robot name="mobile">
<link name="cart"><collision><origin xyz="0 0 0.1"/><geometry><box size="0.6 0.5 0.2"/></geometry>
</collision></link>
<link name="wheel"><collision><origin rpy="1.5708 0 0"/><geometry><cylinder radius="0.1"
length="0.05"/></geometry></collision></link>
<link name="torso"><collision><geometry><box size="0.2 0.2 0.4"/></geometry></collision></link>
<link name="head"><collision><origin xyz="0.1 0 0"/><geometry><sphere radius="0.08"/></geometry>
</collision></link>
<link name="mount"/>
<link name="l1"><collision><origin xyz="0 0 0.15"/><geometry><box size="0.06 0.06 0.3"/>
</geometry></collision></link>
<link name="l2"><collision><origin xyz="0.15 0 0"/><geometry><box size="0.3 0.05 0.05"/>
</geometry></collision></link>
<joint name="wheel_joint" type="continuous"><parent link="cart"/><child link="wheel"/>
<origin xyz="0.2 0.3 0.1"/><axis xyz="0 1 0"/></joint>
<joint name="lift" type="prismatic"><parent link="cart"/><child link="torso"/>
<origin xyz="-0.1 0 0.5" rpy="0 0 0.3"/><axis xyz="0 0 1"/><limit lower="0" upper="0.3"/></joint>
<joint name="pan" type="revolute"><parent link="torso"/><child link="head"/>
<origin xyz="0 0 0.3"/><axis xyz="0 0 1"/><limit lower="-1" upper="1"/></joint>
<joint name="mount_joint" type="fixed"><parent link="torso"/><child link="mount"/>
<origin xyz="0.12 0 0.1" rpy="0.2 0 0"/></joint>
<joint name="j1" type="revolute"><parent link="mount"/><child link="l1"/>
<axis xyz="0 0 1"/><limit lower="-3" upper="3"/></joint>
<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
<origin xyz="0 0 0.3"/><axis xyz="0 1 0"/><limit lower="-2" upper="2"/></joint>
</robot>"""
"""A mobile manipulator whose arm starts at a mount on a lifted torso: a cart with a wheel
below it, a head beside it."""

MOBILE = """name: mobile_model_test
urdf: mobile.urdf
base_link: mount
tip_link: l2
fixed_joints: {lift: 0.2, pan: 0.5, wheel_joint: 0.7}
"""


@pytest.fixture(scope="module")
def arms(tmp_path_factory):
    folder = tmp_path_factory.mktemp("arms")
    (folder / "xarm6.yaml").write_text(XARM)
    (folder / "mobile.urdf").write_text(MOBILE_URDF)
    (folder / "mobile.yaml").write_text(MOBILE)
    return {
        "test_arm": load_arm(write_test_arm(folder), require_derived=False),
        "xarm6": load_arm(folder / "xarm6.yaml", require_derived=False),
        "mobile": load_arm(folder / "mobile.yaml", require_derived=False),
        "kuka_iiwa14": load_arm(robot_spec("kuka_iiwa14").description, require_derived=False),
        "franka_panda": load_arm(robot_spec("franka_panda").description, require_derived=False),
    }


@pytest.mark.parametrize("name", ["test_arm", "xarm6", "mobile", "kuka_iiwa14", "franka_panda"])
def test_every_link_frame_matches_pybullet(arms, name):
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    arm = arms[name]
    with native_output_silenced():
        client = BulletClient(connection_mode=pybullet.DIRECT)
        loaded = load_bullet_arm(client, arm)
    try:
        for config in random_configs(arm, 20, seed=1):
            set_configuration(client, loaded, config)
            ours = arm.link_poses(config[None])[0]
            for k, link in enumerate(arm.chain.link_bodies):
                index = loaded.links[link]
                if index == -1:
                    continue
                state = client.getLinkState(loaded.body, index, computeForwardKinematics=True)
                rotation = np.array(client.getMatrixFromQuaternion(state[5])).reshape(3, 3)
                assert np.allclose(ours[k, :3, 3], state[4], atol=1e-6), (name, link)
                assert np.allclose(ours[k, :3, :3], rotation, atol=1e-6), (name, link)
    finally:
        client.disconnect()


def test_links_above_the_base_ride_on_it(arms):
    # A mobile manipulator planned from its mount: the cart, its wheel, the torso and the head
    # are part of the robot (held where the description says), so the arm cannot pass through
    # them. They used to be left out, and the arm planned through its own base unseen.
    chain = arms["mobile"].chain
    assert chain.above_base == ("cart", "head", "torso", "wheel")
    assert all(chain.link_bodies[link] == 0 for link in chain.above_base)
    assert chain.fixed_values == {"lift": 0.2, "pan": 0.5, "wheel_joint": 0.7}
    assert sorted(element.link for element in chain.elements[0]) == list(chain.above_base)

    def pose(xyz, rotation):
        out = np.eye(4)
        out[:3, :3], out[:3, 3] = rotation, xyz
        return out

    c, s = np.cos(0.3), np.sin(0.3)
    cart_torso = pose([-0.1, 0, 0.5 + 0.2], [[c, -s, 0], [s, c, 0], [0, 0, 1]])
    c, s = np.cos(0.2), np.sin(0.2)
    torso_mount = pose([0.12, 0, 0.1], [[1, 0, 0], [0, c, -s], [0, s, c]])
    # The root (the cart), which the pybullet comparison above cannot see, in the base frame.
    np.testing.assert_allclose(chain.link_transforms["cart"],
                               np.linalg.inv(cart_torso @ torso_mount), atol=1e-12)  # fmt: skip


@pytest.mark.parametrize("name", ["test_arm", "kuka_iiwa14", "franka_panda"])
def test_motion_radii_bound_how_far_points_move(arms, name):
    arm = arms[name]
    radii = arm.motion_radii()
    rng = np.random.default_rng(2)
    points = [np.concatenate(g.pieces) if g.pieces else np.zeros((0, 3)) for g in arm.geometry]
    for a in random_configs(arm, 30, seed=3):
        b = np.clip(a + rng.normal(0, 0.2, size=a.shape), *arm.joint_limits())
        before, after = arm.forward_kinematics(np.stack([a, b]))
        bound = np.abs(b - a) @ radii
        for j, body_points in enumerate(points):
            if len(body_points) == 0:
                continue
            moved = np.linalg.norm(
                (body_points @ after[j, :3, :3].T + after[j, :3, 3])
                - (body_points @ before[j, :3, :3].T + before[j, :3, 3]), axis=1
            )  # fmt: skip
            # A straight segment's chord is at most its swept path: the bound holds for it too.
            assert moved.max() <= bound[j] + 1e-9


def test_configs_are_checked_for_shape(arms):
    with pytest.raises(ValueError, match="expected shape"):
        arms["xarm6"].forward_kinematics(np.zeros((2, 7)))


def test_a_model_copies_and_pickles_as_its_description(arms):
    import copy
    import pickle

    arm = arms["test_arm"]
    assert copy.deepcopy(arm) is arm  # one model per description and process
    again = pickle.loads(pickle.dumps(arm))
    assert again is arm  # the process's cached model
    np.testing.assert_array_equal(again.forward_kinematics(np.zeros((1, arm.dim))),
                                  arm.forward_kinematics(np.zeros((1, arm.dim))))  # fmt: skip


@pytest.mark.parametrize("name", ["test_arm", "xarm6", "kuka_iiwa14", "franka_panda"])
def test_segment_levers_bound_how_far_points_get_from_each_axis(arms, name):
    """Along a motion, every point of a body stays within its lever arm of each joint's axis,
    so it moves at most ``sum_i |dq_i| lever[i, j]`` per unit of the motion's parameter; and
    the lever arms of one motion are often shorter than the arm's bound for all motions."""
    from temp_gym.worlds.arm.kinematics import identity_poses, segment_levers_into

    arm = arms[name]
    kind, rotation, shift = arm.kinematic_arrays()
    radii = arm.motion_radii()
    points = [np.concatenate(g.pieces) if g.pieces else np.zeros((0, 3)) for g in arm.geometry]
    # One root sphere per body with pieces, holding them all.
    counts = [1 if len(p) else 0 for p in points]
    body_start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    node_centers = np.array([p.mean(axis=0) for p in points if len(p)])
    node_radii = np.array([np.linalg.norm(p - p.mean(axis=0), axis=1).max() for p in points
                           if len(p)])  # fmt: skip
    rng = np.random.default_rng(4)
    starts = random_configs(arm, 30, seed=5)
    ends = np.clip(starts + rng.normal(0, 0.4, size=starts.shape), *arm.joint_limits())
    lever = np.empty(radii.shape)
    shorter = 0
    for e in range(len(starts)):
        segment_levers_into(starts, ends, e, kind, rotation, shift, radii, body_start,
                            node_centers, node_radii, identity_poses(arm.num_bodies),
                            np.empty(arm.dim), np.empty(arm.dim), np.empty(arm.dim),
                            lever)  # fmt: skip
        assert (lever <= radii).all()
        shorter += int((lever < radii - 1e-3).sum())
        t = np.linspace(0.0, 1.0, 101)
        poses = arm.forward_kinematics(starts[e] + t[:, None] * (ends[e] - starts[e]))
        speed = np.abs(ends[e] - starts[e]) @ lever
        for j, body_points in enumerate(points):
            if len(body_points) == 0:
                continue
            world = body_points @ poses[:, j, :3, :3].transpose(0, 2, 1) + poses[:, j, None, :3, 3]
            for i in np.flatnonzero((kind == 0) & (np.arange(arm.dim) < j)):
                offset = world - poses[:, i + 1, None, :3, 3]
                axis = poses[:, i + 1, None, :3, 2]
                away = np.linalg.norm(np.cross(offset, axis), axis=2)
                assert away.max() <= lever[i, j] + 1e-9, (name, e, i, j)
            step = np.linalg.norm(np.diff(world, axis=0), axis=2).max()
            assert step <= speed[j] * (t[1] - t[0]) + 1e-9, (name, e, j)
    assert shorter > 0, name
