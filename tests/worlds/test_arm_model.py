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


@pytest.fixture(scope="module")
def arms(tmp_path_factory):
    folder = tmp_path_factory.mktemp("arms")
    (folder / "xarm6.yaml").write_text(XARM)
    return {
        "test_arm": load_arm(write_test_arm(folder), require_derived=False),
        "xarm6": load_arm(folder / "xarm6.yaml", require_derived=False),
        "kuka_iiwa14": load_arm(robot_spec("kuka_iiwa14").description, require_derived=False),
        "franka_panda": load_arm(robot_spec("franka_panda").description, require_derived=False),
    }


@pytest.mark.parametrize("name", ["test_arm", "xarm6", "kuka_iiwa14", "franka_panda"])
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
