"""A small arm written by the tests themselves: every URDF feature the generic arm reads.

Four movable joints between ``base`` and ``tip``: revolute about z, revolute about a tilted
axis, prismatic along x, continuous about -y; a fixed joint in the chain; a fixed camera
mount off the chain; two fingers (a prismatic joint and its mimic) below the tip. Collision
geometry: a box, a cylinder, a sphere, and meshes in STL, OBJ and DAE (trimesh writes them),
one named by ``package://``, one with a scale.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

URDF = """<?xml version="1.0"?>
<robot name="test_arm">
  <link name="world"/>
  <joint name="mount" type="fixed"><parent link="world"/><child link="base"/>
    <origin xyz="5 5 5"/></joint>
  <link name="base">
    <collision><origin xyz="0 0 0.05"/><geometry><box size="0.2 0.2 0.1"/></geometry></collision>
  </link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-2.5" upper="2.5"/></joint>
  <link name="l1">
    <collision><origin xyz="0 0 0.15"/>
      <geometry><cylinder radius="0.04" length="0.3"/></geometry></collision>
  </link>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0 0.3" rpy="0.3 0 0.2"/><axis xyz="0.6 0.8 0"/>
    <limit lower="-2.8" upper="2.8"/></joint>
  <link name="l2">
    <collision><origin xyz="0 0 0.1" rpy="0 0.2 0"/>
      <geometry><mesh filename="package://test_arm/meshes/link.stl"/></geometry></collision>
  </link>
  <joint name="j2_fixed" type="fixed"><parent link="l2"/><child link="l2b"/>
    <origin xyz="0 0 0.2"/></joint>
  <link name="l2b">
    <collision><geometry><mesh filename="meshes/link.obj" scale="1 1 0.5"/></geometry></collision>
  </link>
  <joint name="camera_mount" type="fixed"><parent link="l2"/><child link="camera"/>
    <origin xyz="0.05 0 0.1"/></joint>
  <link name="camera">
    <collision><geometry><sphere radius="0.02"/></geometry></collision>
  </link>
  <joint name="j3" type="prismatic"><parent link="l2b"/><child link="l3"/>
    <origin xyz="0 0 0.05"/><axis xyz="1 0 0"/><limit lower="-0.1" upper="0.1"/></joint>
  <link name="l3">
    <collision><geometry><mesh filename="meshes/link.dae"/></geometry></collision>
  </link>
  <joint name="j4" type="continuous"><parent link="l3"/><child link="tip"/>
    <origin xyz="0 0 0.15"/><axis xyz="0 -1 0"/></joint>
  <link name="tip">
    <collision><geometry><box size="0.06 0.12 0.04"/></geometry></collision>
  </link>
  <joint name="finger_a" type="prismatic"><parent link="tip"/><child link="finger_left"/>
    <origin xyz="0 0 0.04"/><axis xyz="0 1 0"/><limit lower="0" upper="0.04"/></joint>
  <link name="finger_left">
    <collision><origin xyz="0 0 0.03"/><geometry><box size="0.01 0.01 0.06"/></geometry></collision>
  </link>
  <joint name="finger_b" type="prismatic"><parent link="tip"/><child link="finger_right"/>
    <origin xyz="0 0 0.04"/><axis xyz="0 -1 0"/><limit lower="0" upper="0.04"/>
    <mimic joint="finger_a"/></joint>
  <link name="finger_right">
    <collision><origin xyz="0 0 0.03"/><geometry><box size="0.01 0.01 0.06"/></geometry></collision>
  </link>
</robot>
"""

DESCRIPTION = """name: test_arm
urdf: test_arm/robot.urdf
base_link: base
tip_link: tip
fixed_joints: {finger_a: 0.03}
env_id: TEMP-TestArm-v0
seed_code: 90001
spheres: {tolerance: 0.006}
"""


def write_test_arm(folder: Path) -> Path:
    """Write the arm's URDF, meshes and description under ``folder``; return the description."""
    import trimesh

    package = folder / "test_arm"
    (package / "meshes").mkdir(parents=True, exist_ok=True)
    capsule = trimesh.creation.capsule(height=0.12, radius=0.035, count=[12, 12])
    capsule.export(package / "meshes" / "link.stl")
    capsule.export(package / "meshes" / "link.obj")
    trimesh.creation.box(extents=[0.07, 0.07, 0.12]).export(package / "meshes" / "link.dae")
    (package / "robot.urdf").write_text(URDF)
    path = folder / "test_arm.yaml"
    path.write_text(DESCRIPTION)
    return path


def random_configs(arm, count: int, seed: int = 0) -> np.ndarray:
    """``(count, dim)`` configurations drawn uniformly in the arm's limits."""
    limits = arm.joint_limits()
    return np.random.default_rng(seed).uniform(limits[0], limits[1], size=(count, arm.dim))


def motions_from(arm, starts: np.ndarray, rng: np.random.Generator, lengths) -> np.ndarray:
    """Ends of straight motions from ``starts`` in random directions, ``lengths`` long (one
    number, or one per start) and clipped to the arm's limits."""
    direction = rng.normal(size=starts.shape)
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    limits = arm.joint_limits()
    return np.clip(starts + np.reshape(lengths, (-1, 1)) * direction, limits[0], limits[1])
