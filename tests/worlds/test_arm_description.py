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
            "encoding: {resolution: 65}\n",  # accepted up to 128; the env refused it at reset
            "encoding.resolution",
        ),
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


def test_an_undeclared_namespace_prefix_is_read_as_pybullet_reads_it(tmp_path):
    # airo-models' UR3e carries drake:acceleration without declaring xmlns:drake; pybullet,
    # RViz and MoveIt load it, and this reader refused it as invalid XML.
    limit = '<limit lower="-1" upper="1" drake:acceleration="3.1"/>'
    urdf = _TREE_HEAD + _TREE.replace('<limit lower="-1" upper="1"/>', limit, 1) + "</robot>"
    assert limit in urdf
    (tmp_path / "r.urdf").write_text(urdf)
    text = "name: r\nurdf: r.urdf\nbase_link: base\ntip_link: l2\n"
    assert load_arm(_description(tmp_path, text), require_derived=False).joint_names == (
        "j1",
        "j2",
    )
    # An undeclared xacro prefix is still a xacro file; broken XML is still refused. (The same
    # description with its URDF edited in this process: the URDF is read again, not cached.)
    (tmp_path / "r.urdf").write_text(urdf.replace("<link name=\"l2\">", '<xacro:macro name="m"/>'
                                                 '<link name="l2">'))  # fmt: skip
    with pytest.raises(UrdfError, match=r"a xacro file"):
        load_arm(tmp_path / "robot.yaml", require_derived=False)
    (tmp_path / "r.urdf").write_text(urdf.replace("</robot>", ""))
    with pytest.raises(UrdfError, match=r"r.urdf: not valid XML \(no element found"):
        load_arm(tmp_path / "robot.yaml", require_derived=False)


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
    # A link above the base (world) rides on the base.
    assert chain.link_bodies["world"] == 0 and chain.above_base == ("world",)
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


_TREE_HEAD = """<?xml version="1.0"?><robot name="r">
<link name="base"><collision><geometry><box size="0.2 0.2 0.1"/></geometry></collision></link>
<link name="l1"><collision><geometry><box size="0.05 0.05 0.5"/></geometry></collision></link>
<link name="l2"><collision><geometry><box size="0.05 0.05 0.2"/></geometry></collision></link>
"""


def _joint(name, parent, child, kind="revolute", inner=""):
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<axis xyz="0 0 1"/><limit lower="-1" upper="1"/>{inner}</joint>')  # fmt: skip


_TREE = _joint("j1", "base", "l1") + _joint("j2", "l1", "l2")


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (_joint("jc", "l2", "base", "fixed"), r"the joints close a loop through link"),
        ('<link name="l2"/>', r"link 'l2' is defined twice"),
        ('<link name="l3"/>' + _joint("j2", "l2", "l3"), r"joint 'j2' is defined twice"),
        ('<link name="l3"/>' + _joint("ja", "l2", "l3") + _joint("jb", "l1", "l3"),
         r"link 'l3' is the child of two joints, 'ja' and 'jb'"),
        ('<link name="l3"/>' + _joint("jx", "ghost", "l3"),
         r"joint 'jx': its parent link 'ghost' is not a link"),
        ("<link/>", r"a <link> without a name"),
    ],
)  # fmt: skip
def test_a_urdf_whose_links_are_no_tree_is_refused_in_one_line(tmp_path, extra, message):
    # A loop hung the walk of the tree; a repeated link silently lost its geometry.
    (tmp_path / "r.urdf").write_text(_TREE_HEAD + _TREE + extra + "</robot>")
    path = _description(tmp_path, "name: r\nurdf: r.urdf\nbase_link: base\ntip_link: l2\n")
    with pytest.raises(UrdfError, match=message):
        load_arm(path, require_derived=False)


_MIMIC_OF_J1 = _joint("j1", "base", "l1") + _joint("j2", "l1", "l2", inner='<mimic joint="j1"/>')


@pytest.mark.parametrize(
    ("joints", "tip", "message"),
    [
        # In the chain, j2 would be planned as a joint of its own though it follows j1.
        (_MIMIC_OF_J1, "l2", r"joint 'j2': a mimic joint \(of 'j1'\) in the chain"),
        # Off the chain, following a joint of the chain: its link would not be rigid.
        (_MIMIC_OF_J1, "l1", r"joint 'j2': mimics 'j1', a joint of the chain"),
        (_MIMIC_OF_J1.replace('joint="j1"', 'joint="jz"'), "l1",
         r"joint 'j2': mimics 'jz', which is not a joint"),
    ],
)  # fmt: skip
def test_a_mimic_joint_the_arm_cannot_model_is_refused(tmp_path, joints, tip, message):
    (tmp_path / "r.urdf").write_text(_TREE_HEAD + joints + "</robot>")
    text = f"name: r\nurdf: r.urdf\nbase_link: base\ntip_link: {tip}\n"
    with pytest.raises(UrdfError, match=message):
        load_arm(_description(tmp_path, text), require_derived=False)


def test_a_mimic_of_the_chain_held_by_the_description_is_accepted(tmp_path):
    (tmp_path / "r.urdf").write_text(_TREE_HEAD + _MIMIC_OF_J1 + "</robot>")
    text = "name: r\nurdf: r.urdf\nbase_link: base\ntip_link: l1\nfixed_joints: {j2: 0.5}\n"
    assert load_arm(_description(tmp_path, text), require_derived=False).chain.fixed_values == {
        "j2": 0.5
    }


def test_a_mesh_is_read_in_the_unit_its_file_declares_and_a_zero_scale_is_refused(tmp_path):
    from temp_gym.worlds.arm.meshes import body_geometry

    cube = (
        "<float_array id='p' count='24'>"
        + " ".join(f"{x} {y} {z}" for x in (-5, 5) for y in (-5, 5) for z in (-5, 5))
        + "</float_array>"
    )
    triangles = "0 1 2 1 3 2 4 6 5 5 6 7 0 4 1 1 4 5 2 3 6 3 7 6 0 2 4 2 6 4 1 5 3 3 5 7"
    dae = f"""<?xml version="1.0"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
<asset><unit meter="0.01" name="centimeter"/><up_axis>Z_UP</up_axis></asset>
<library_geometries><geometry id="g"><mesh>
<source id="s">{cube}<technique_common><accessor source="#p" count="8" stride="3">
<param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
</accessor></technique_common></source>
<vertices id="v"><input semantic="POSITION" source="#s"/></vertices>
<triangles count="12"><input semantic="VERTEX" source="#v" offset="0"/><p>{triangles}</p>
</triangles></mesh></geometry></library_geometries>
<library_visual_scenes><visual_scene id="scene"><node id="n"><instance_geometry url="#g"/>
</node></visual_scene></library_visual_scenes><scene><instance_visual_scene url="#scene"/>
</scene></COLLADA>"""  # fmt: skip
    (tmp_path / "cube.dae").write_text(dae)
    mesh = '<mesh filename="cube.dae" scale="{}"/>'
    urdf = ('<?xml version="1.0"?><robot name="r"><link name="base"/><link name="l1"><collision>'
            f"<geometry>{mesh}</geometry></collision></link>"
            + _joint("j1", "base", "l1") + "</robot>")  # fmt: skip
    path = _description(tmp_path, "name: r\nurdf: r.urdf\nbase_link: base\ntip_link: l1\n")
    (tmp_path / "r.urdf").write_text(urdf.format("1 1 1"))
    arm = load_arm(path, require_derived=False)
    vertices = body_geometry(arm.chain.elements[1], arm.chain.urdf).meshes[0][0]
    # 10 units of a centimetre: 0.1 m, as pybullet, RViz and MoveIt read it (not 10 m).
    np.testing.assert_allclose(np.ptp(vertices, axis=0), [0.1, 0.1, 0.1])
    (tmp_path / "flat.urdf").write_text(urdf.format("0 1 1"))
    flat = tmp_path / "flat.yaml"
    flat.write_text(path.read_text().replace("r.urdf", "flat.urdf"))
    with pytest.raises(UrdfError, match=r"link 'l1' collision 0: <mesh> scale must be nonzero"):
        load_arm(flat, require_derived=False)


def test_a_built_in_robots_name_is_refused_before_the_build(tmp_path, capsys):
    from temp_gym.worlds.arm.build import main

    text = ("name: point2d\nurdf: pybullet_data://kuka_iiwa/model.urdf\n"
            "base_link: lbr_iiwa_link_0\ntip_link: lbr_iiwa_link_7\n")  # fmt: skip
    path = _description(tmp_path, text)
    assert main(["build", str(path)]) == 2
    assert not path.with_name("robot.derived.json").exists()  # refused before any work
    capsys.readouterr()
    # `check` gives the refusal `build` would give, not "run temp-robot build".
    assert main(["check", str(path)]) == 2
    assert "name: 'point2d' is taken by the built-in robot" in capsys.readouterr().err
    with pytest.raises(DescriptionError, match=r"name: 'point2d' is taken by the built-in robot"):
        from temp_gym.worlds.arm.build import build

        build(path)


def test_a_mimic_above_the_base_is_not_followed(tmp_path):
    above = '<link name="world"/>' + _joint("jw", "world", "base", inner='<mimic joint="jz"/>')
    (tmp_path / "r.urdf").write_text(_TREE_HEAD + above + _TREE + "</robot>")
    text = "name: r\nurdf: r.urdf\nbase_link: base\ntip_link: l2\n"
    assert load_arm(_description(tmp_path, text), require_derived=False).joint_names == (
        "j1",
        "j2",
    )


def test_the_robot_digest_follows_every_source_of_the_arm_and_not_its_comments(tmp_path):
    from temp_gym.worlds.arm.spec import robot_digest

    path = write_test_arm(tmp_path)
    first = robot_digest(path)
    path.write_text("# a comment changes nothing\n" + path.read_text())
    assert robot_digest(path) == first
    digests = {first}
    mesh = tmp_path / "test_arm" / "meshes" / "link.obj"
    mesh.write_text(mesh.read_text().replace("v ", "v  ", 1) + "\n")  # the same mesh, new bytes
    digests.add(robot_digest(path))
    urdf = tmp_path / "test_arm" / "robot.urdf"
    urdf.write_text(urdf.read_text().replace('radius="0.04"', 'radius="0.05"'))
    digests.add(robot_digest(path))
    path.write_text(path.read_text().replace("finger_a: 0.03", "finger_a: 0.02"))
    digests.add(robot_digest(path))
    path.write_text(path.read_text() + "planning: {goal_radius: 0.2}\n")  # no geometry, yet its own
    digests.add(robot_digest(path))
    assert len(digests) == 5
