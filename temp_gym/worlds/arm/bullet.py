"""An arm in a pybullet client: loaded from its URDF, fixed joints set, base at the origin.

The renderer (`temp_gym.worlds.rendering.arm`) and the independent referee
(`temp_gym.worlds.collision.pybullet_reference`) both load arms this way. pybullet reads the
URDF itself and poses it with its own kinematics; only the joint names and the fixed values
come from the description.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from temp_gym.worlds.arm.model import ArmModel


@dataclass(frozen=True)
class BulletArm:
    """One arm loaded into pybullet.

    Its body id, the pybullet index of each chain joint, the base pose (of the root's centre of
    mass, as pybullet takes it) that puts ``base_link`` at the world origin, and the pybullet
    index of each URDF link.
    """

    body: int
    joints: tuple[int, ...]
    base_position: tuple[float, float, float]
    base_orientation: tuple[float, float, float, float]
    links: dict[str, int]


def load_bullet_arm(client, arm: ArmModel, position=(0.0, 0.0, 0.0)) -> BulletArm:
    """Load ``arm`` into ``client`` (a `BulletClient`) with a fixed base (module docstring)."""
    body = client.loadURDF(str(arm.chain.urdf), basePosition=position, useFixedBase=True)
    names = {}
    links = {client.getBodyInfo(body)[0].decode(): -1}
    for j in range(client.getNumJoints(body)):
        info = client.getJointInfo(body, j)
        names[info[1].decode()] = j
        links[info[12].decode()] = j
    for joint, value in arm.chain.fixed_values.items():
        client.resetJointState(body, names[joint], float(value))
    joints = tuple(names[name] for name in arm.joint_names)
    # pybullet poses a body by its base's centre of mass: keep the pose that puts the URDF
    # root's frame where it was loaded, then move it so that the chain's base link is there.
    com_position, com_orientation = client.getBasePositionAndOrientation(body)
    base_position, base_orientation = tuple(com_position), tuple(com_orientation)
    base_link = arm.body_names[0]
    if links.get(base_link, -1) != -1:
        state = client.getLinkState(body, links[base_link], computeForwardKinematics=True)
        inverse = client.invertTransform(state[4], state[5])
        moved = client.multiplyTransforms(inverse[0], inverse[1], com_position, com_orientation)
        base_position, base_orientation = tuple(moved[0]), tuple(moved[1])
        client.resetBasePositionAndOrientation(body, base_position, base_orientation)
    return BulletArm(body, joints, base_position, base_orientation, links)


def set_configuration(client, loaded: BulletArm, config: np.ndarray) -> None:
    """Put the chain joints of ``loaded`` at ``config``."""
    for joint, value in zip(loaded.joints, np.asarray(config, dtype=np.float64)):
        client.resetJointState(loaded.body, joint, float(value))


__all__ = ["BulletArm", "load_bullet_arm", "set_configuration"]
