"""Robot descriptions and URDF chains: what is read, and one-line errors for what is wrong."""

from __future__ import annotations

import numpy as np
import pytest
from arm_fixtures import write_test_arm

from temp_gym.worlds.arm.description import (
    DescriptionError,
    default_env_id,
    default_seed_code,
    load_description,
)
from temp_gym.worlds.arm.model import load_arm
from temp_gym.worlds.arm.urdf import PRISMATIC, REVOLUTE, UrdfError, axis_frame


@pytest.fixture(scope="module")
def test_arm_path(tmp_path_factory):
    return write_test_arm(tmp_path_factory.mktemp("arm"))


def _description(tmp_path, text):
    path = tmp_path / "robot.yaml"
    path.write_text(text)
    return path


def test_defaults_come_from_the_name(test_arm_path):
    description = load_description(test_arm_path)
    assert description.env_id == "TEMP-TestArm-v0"
    assert default_env_id("my_arm") == "TEMP-MyArm-v0"
    assert default_seed_code("my_arm") == default_seed_code("my_arm") >= 1000
    assert description.derived_path.name == "test_arm.derived.json"


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("urdf: x.urdf\nbase_link: a\ntip_link: b\n", "name"),
        ("name: a\nurdf: x.urdf\nbase_link: a\ntip_link: b\ncolour: red\n", "colour"),
        ("name: 1abc\nurdf: x.urdf\nbase_link: a\ntip_link: b\n", "name"),
        ("name: a\nurdf: missing.urdf\nbase_link: a\ntip_link: b\n", "urdf"),
        (
            "name: a\nurdf: pybullet_data://kuka_iiwa/model.urdf\nbase_link: a\ntip_link: b\n"
            "joint_limits: {j: [1, 0]}\n",
            "joint_limits.j",
        ),
        (
            "name: a\nurdf: pybullet_data://kuka_iiwa/model.urdf\nbase_link: a\ntip_link: b\n"
            "planning: {step: 1}\n",
            "planning.step",
        ),
        (
            "name: a\nurdf: pybullet_data://kuka_iiwa/model.urdf\nbase_link: a\ntip_link: b\n"
            "spheres: {tolerance: 0.5}\n",
            "spheres.tolerance",
        ),
        ("&a name: a\n", "anchors"),
        (
            "name: a\nurdf: pybullet_data://kuka_iiwa/model.urdf\nbase_link: a\ntip_link: b\n"
            f"joint_limits: {{j: [-1, {10**400}]}}\n",
            "joint_limits.j",
        ),
        (
            "name: a\nurdf: pybullet_data://kuka_iiwa/model.urdf\nbase_link: a\ntip_link: b\n"
            "fixed_joints: {f: true}\n",
            "fixed_joints.f",
        ),
    ],
)
def test_a_bad_key_or_value_is_named_in_one_line(tmp_path, text, field):
    with pytest.raises(DescriptionError) as caught:
        load_description(_description(tmp_path, text))
    message = str(caught.value)
    assert field in message and "\n" not in message


@pytest.mark.parametrize(
    ("extra", "fragment"),
    [
        ("base_link: nowhere\ntip_link: lbr_iiwa_link_7\n", "no link 'nowhere'"),
        ("base_link: lbr_iiwa_link_7\ntip_link: lbr_iiwa_link_0\n", "is not below"),
        (
            "base_link: lbr_iiwa_link_0\ntip_link: lbr_iiwa_link_7\n"
            "fixed_joints: {lbr_iiwa_joint_2: 0.1}\n",
            "joint of the chain",
        ),
        (
            "base_link: lbr_iiwa_link_0\ntip_link: lbr_iiwa_link_7\n"
            "joint_limits: {no_such_joint: [0, 1]}\n",
            "no joint 'no_such_joint'",
        ),
        (
            "base_link: lbr_iiwa_link_0\ntip_link: lbr_iiwa_link_7\n"
            "joint_limits: {lbr_iiwa_joint_4: [0.5, 0.5]}\n",
            "leave a joint of the chain no motion",
        ),
    ],
)
def test_a_chain_the_urdf_cannot_give_is_refused_in_one_line(tmp_path, extra, fragment):
    path = _description(tmp_path, "name: a\nurdf: pybullet_data://kuka_iiwa/model.urdf\n" + extra)
    with pytest.raises(UrdfError, match=fragment):
        load_arm(path, require_derived=False)


def test_a_xacro_file_is_refused_with_the_command_that_expands_it(tmp_path):
    urdf = tmp_path / "arm.urdf.xacro"
    urdf.write_text(
        '<robot name="a" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:property name="l" value="0.3"/><link name="base"/></robot>'
    )
    path = _description(tmp_path, "name: a\nurdf: arm.urdf.xacro\nbase_link: base\ntip_link: b\n")
    with pytest.raises(UrdfError, match=r"a xacro file .*xacro arm.urdf.xacro > robot.urdf"):
        load_arm(path, require_derived=False)


def test_an_exponent_without_a_dot_is_a_number(tmp_path):
    text = ("name: a\nurdf: pybullet_data://kuka_iiwa/model.urdf\nbase_link: lbr_iiwa_link_0\n"
            "tip_link: lbr_iiwa_link_7\nspheres: {tolerance: 6e-3}\n")  # fmt: skip
    assert load_description(_description(tmp_path, text)).sphere_tolerance == 0.006


def test_an_ampersand_that_is_no_anchor_is_read_as_text(tmp_path):
    text = ("name: a  # R&D &b\nurdf: pybullet_data://kuka_iiwa/model.urdf\n"
            "base_link: lbr_iiwa_link_0\ntip_link: lbr_iiwa_link_7\n"
            "env_id: 'TEMP-A-v0'  # &c\n")  # fmt: skip
    assert load_description(_description(tmp_path, text)).name == "a"
    with pytest.raises(DescriptionError, match=r"anchors and aliases .*\(&l / \*l\)"):
        load_description(_description(tmp_path, text.replace("urdf:", "urdf: &l")))


@pytest.mark.parametrize(
    ("fixed", "limits", "message"),
    [
        ("{finger_a: 0.03, j2_fixed: 0.1}", "", "fixed_joints: 'j2_fixed' is a fixed joint"),
        ("{finger_a: 0.03}", "joint_limits: {mount: [0, 1]}\n",
         "joint_limits: 'mount' is a fixed joint"),
    ],
)  # fmt: skip
def test_a_joint_the_urdf_fixes_cannot_be_set_or_limited(test_arm_path, fixed, limits, message):
    text = test_arm_path.read_text().replace(
        "fixed_joints: {finger_a: 0.03}\n", f"fixed_joints: {fixed}\n{limits}"
    )
    path = test_arm_path.parent / "fixed_named.yaml"
    path.write_text(text)
    with pytest.raises(UrdfError, match=message):
        load_arm(path, require_derived=False)


def test_the_chain_folds_fixed_joints_and_holds_joints_off_it(test_arm_path):
    arm = load_arm(test_arm_path, require_derived=False)
    chain = arm.chain
    assert chain.joint_names == ("j1", "j2", "j3", "j4")
    assert chain.joint_types.tolist() == [REVOLUTE, REVOLUTE, PRISMATIC, REVOLUTE]
    assert arm.body_names == ("base", "l1", "l2", "l3", "tip")
    # A continuous joint without an override is planned in [-pi, pi].
    assert np.allclose(chain.joint_limits[:, 3], [-np.pi, np.pi])
    # The fingers ride on the tip, the second mimicking the first's fixed value.
    assert chain.fixed_values == {"finger_a": 0.03, "finger_b": 0.03}
    assert chain.link_bodies["finger_left"] == chain.link_bodies["tip"] == 4
    # Fixed joints in and off the chain fold their links into the body above them.
    assert chain.link_bodies["l2b"] == chain.link_bodies["camera"] == 2
    # Links above the base (world) are not part of the arm.
    assert "world" not in chain.link_bodies
    kinds = [[element.kind for element in body] for body in chain.elements]
    assert kinds == [["box"], ["cylinder"], ["mesh", "mesh", "sphere"], ["mesh"],
                     ["box", "box", "box"]]  # fmt: skip


@pytest.mark.parametrize("axis", [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, -1, 0], [0.6, 0.8, 0],
                                  [1, 2, 3]])  # fmt: skip
def test_axis_frames_turn_z_onto_the_axis(axis):
    axis = np.array(axis, float) / np.linalg.norm(axis)
    frame = axis_frame(axis)
    assert np.allclose(frame @ [0, 0, 1], axis)
    assert np.allclose(frame.T @ frame, np.eye(3)) and np.isclose(np.linalg.det(frame), 1.0)
