"""MotionBenchMaker's Panda problems: files in its format, written here, read back."""

from __future__ import annotations

import copy
import io
import math
import tarfile
from pathlib import Path

import numpy as np
import pytest
import yaml

from temp_gym.benchmarks.motionbenchmaker import invalid, load
from temp_gym.problem.obstacles import BOX, CYLINDER, SPHERE
from temp_gym.worlds.robots import robot_spec

JOINTS = [f"panda_joint{i}" for i in range(1, 8)]
FINGERS = ["panda_finger_joint1", "panda_finger_joint2"]
HOME = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]
"""The Panda's ready pose: its hand is near (0.31, 0, 0.5)."""
IDENTITY = [0, 0, 0, 1]
Z_TURN = [0, 0, math.sin(0.3), math.cos(0.3)]
"""A turn of 0.6 rad about z."""
TILT = [math.sin(0.2) / math.sqrt(2), math.sin(0.2) / math.sqrt(2), 0, math.cos(0.2)]
"""A turn of 0.4 rad about (1, 1, 0) / sqrt(2)."""


def primitive(kind, dimensions, position, orientation=IDENTITY) -> dict:
    """One collision object of one primitive, as MotionBenchMaker writes it."""
    return {"id": f"{kind}{position}", "primitives": [{"type": kind, "dimensions": dimensions}],
            "primitive_poses": [{"position": position, "orientation": orientation}]}  # fmt: skip


def scene(*objects: dict) -> dict:
    """A planning scene in MotionBenchMaker's layout (its robot state, frames and matrix)."""
    return {
        "robot_state": {
            "joint_state": {"position": [0] * 9, "name": JOINTS + FINGERS},
            "multi_dof_joint_state": {"transforms": [{"translation": [0, 0, 0],
                                                      "rotation": IDENTITY}],
                                      "wrench": [], "joint_names": ["virtual_joint"],
                                      "twist": []},
        },
        "robot_model_name": "panda",
        "allowed_collision_matrix": {"entry_names": ["panda_hand", "panda_link7"],
                                     "entry_values": [[False, True], [True, False]]},
        "fixed_frame_transforms": [{"transform": {"rotation": IDENTITY,
                                                  "translation": [0, 0, 0]},
                                    "child_frame_id": "world"}],
        "name": "",
        "world": {"collision_objects": list(objects)},
    }  # fmt: skip


def request(start=HOME, goal=HOME, fingers=(0.065, 0.065)) -> dict:
    """A motion-plan request in MotionBenchMaker's layout (goal joints listed shuffled)."""
    constraints = [{"joint_name": name, "position": value} for name, value in zip(JOINTS, goal)]
    return {
        "workspace_parameters": {"max_corner": [1, 1, 1], "min_corner": [-1, -1, -1],
                                 "header": {"frame_id": ""}},
        "planner_id": "BKPIECEGood", "group_name": "panda_arm", "num_planning_attempts": 2,
        "allowed_planning_time": 60, "max_velocity_scaling_factor": 0,
        "max_acceleration_scaling_factor": 0,
        "goal_constraints": [{"joint_constraints": constraints[::-1]}],
        "start_state": {
            "joint_state": {"position": list(start) + list(fingers), "name": JOINTS + FINGERS},
            "multi_dof_joint_state": {"transforms": [{"rotation": IDENTITY,
                                                      "translation": [0, 0, 0]}],
                                      "twist": [], "wrench": [],
                                      "joint_names": ["virtual_joint"]},
        },
    }  # fmt: skip


GOAL = [0.5, -0.3, 0.2, -2.0, 0.1, 1.8, 0.5]
SHELF = scene(
    primitive("box", [0.4, 0.6, 0.04], [0.6, 0.0, 0.3]),
    primitive("cylinder", [0.2, 0.05], [0.5, 0.4, 0.5], Z_TURN),
    primitive("box", [0.1, 0.2, 0.3], [0.5, -0.4, 0.4], Z_TURN),
    primitive("box", [0.3, 0.1, 0.02], [0.4, 0.2, 0.9], TILT),
)
"""A box, a cylinder, a z-rotated box and a tilted box."""
TABLE = scene(primitive("box", [1.0, 1.0, 0.1], [0.7, 0.0, -0.1]),
              primitive("sphere", [0.05], [0.5, 0.3, 0.7]))  # fmt: skip
TABLE["world"]["octomap"] = {"header": {"frame_id": "world"},
                             "origin": {"position": [0, 0, 0], "orientation": IDENTITY},
                             "octomap": {"binary": True, "id": "OcTree", "resolution": 0.02,
                                         "data": []}}  # fmt: skip
"""A box and a sphere, and an empty octomap as MoveIt writes it in a whole scene."""
FIXTURE = {
    "shelf_panda": {"0001": (SHELF, request(goal=GOAL)), "0002": (SHELF, request())},
    "table_panda": {"0001": (TABLE, request(start=GOAL)), "0010": (TABLE, request(goal=GOAL))},
}
"""Two scenes of two problems each (numbered 1, 2 and 1, 10: 10 sorts after 2)."""
NAMES = ["shelf/0001", "shelf/0002", "table/0001", "table/0010"]


def write_folder(root: Path, problems: dict = FIXTURE) -> Path:
    """``problems`` in MotionBenchMaker's layout under ``root/problems``; returns that folder."""
    folder = root / "problems"
    for scene_name, numbered in problems.items():
        (folder / scene_name).mkdir(parents=True)
        for number, (scene_data, request_data) in numbered.items():
            for kind, data in (("scene", scene_data), ("request", request_data)):
                text = yaml.safe_dump(data, default_flow_style=None)
                (folder / scene_name / f"{kind}{number}.yaml").write_text(text)
    return folder


def write_archive(root: Path, problems: dict = FIXTURE) -> Path:
    """``problems`` as ``root/problems.tar.bz2``, members under ``problems/`` as MBM packs it."""
    folder = write_folder(root / "unpacked", problems)
    archive = root / "problems.tar.bz2"
    with tarfile.open(archive, "w:bz2") as tar:
        tar.add(folder, arcname="problems")
    return archive


def only(scene_data: dict, request_data: dict | None = None) -> dict:
    """A fixture of one problem."""
    return {"one_panda": {"0001": (scene_data, request_data or request())}}


def test_archive_and_folders_load_the_same_problems_in_order(tmp_path):
    archive = write_archive(tmp_path)
    from_archive = load(archive)
    assert [name for name, _ in from_archive] == NAMES
    for path in (tmp_path / "unpacked", tmp_path / "unpacked" / "problems"):
        from_folder = load(path)
        assert [name for name, _ in from_folder] == NAMES
        for (_, a), (_, b) in zip(from_archive, from_folder):
            assert a.workspace == b.workspace
            assert a.start.tolist() == b.start.tolist() and a.goal.tolist() == b.goal.tolist()


def test_start_goal_in_joint_order_and_goal_radius(tmp_path):
    write_folder(tmp_path)
    problems = dict(load(tmp_path))
    assert problems["shelf/0001"].start.tolist() == HOME
    assert problems["shelf/0001"].goal.tolist() == GOAL
    assert problems["table/0001"].start.tolist() == GOAL
    assert problems["shelf/0001"].goal_radius == robot_spec("franka_panda").goal_radius
    assert problems["shelf/0001"].robot == "franka_panda"
    assert dict(load(tmp_path, goal_radius=0.25))["table/0010"].goal_radius == 0.25


def test_geometry_of_each_primitive(tmp_path):
    write_folder(tmp_path)
    workspace = dict(load(tmp_path))["shelf/0001"].workspace
    assert workspace.obstacle_kinds.tolist() == [BOX, CYLINDER, BOX, BOX]
    expected_centers = [[0.6, 0.0, 0.3], [0.5, 0.4, 0.5], [0.5, -0.4, 0.4], [0.4, 0.2, 0.9]]
    assert workspace.obstacle_centers.tolist() == expected_centers
    halves = workspace.obstacle_half_extents
    assert halves[0].tolist() == [0.2, 0.3, 0.02]  # a box's dimensions are full edges
    assert halves[1].tolist() == [0.05, 0.05, 0.1]  # a cylinder's are [height, radius]
    assert halves[2].tolist() == [0.05, 0.1, 0.15]
    assert halves[3].tolist() == [0.15, 0.05, 0.01]
    assert workspace.unrotated.tolist() == [True, False, False, False]
    orientations = workspace.obstacle_orientations
    assert orientations[1].tolist() == Z_TURN and orientations[2].tolist() == Z_TURN
    assert orientations[3].tolist() == TILT
    table = dict(load(tmp_path))["table/0001"].workspace
    assert table.obstacle_kinds.tolist() == [BOX, SPHERE]
    assert table.obstacle_half_extents[1].tolist() == [0.05] * 3
    assert table.axis_aligned is False and table.unrotated.tolist() == [True, True]


def test_object_pose_composes_with_primitive_poses(tmp_path):
    quarter = [0, 0, math.sqrt(0.5), math.sqrt(0.5)]  # a quarter turn about z
    entry = primitive("box", [0.2, 0.1, 0.1], [0.1, 0.0, 0.0], Z_TURN)
    entry["pose"] = {"position": [0.5, 0.0, 0.4], "orientation": quarter}
    entry["header"] = {"frame_id": "panda_link0"}
    write_folder(tmp_path, only(scene(entry)))
    workspace = load(tmp_path)[0][1].workspace
    np.testing.assert_allclose(workspace.obstacle_centers[0], [0.5, 0.1, 0.4], atol=1e-15)
    angle = math.pi / 2 + 0.6  # the two turns about z add up
    np.testing.assert_allclose(
        workspace.obstacle_orientations[0], [0, 0, math.sin(angle / 2), math.cos(angle / 2)],
        atol=1e-15,
    )  # fmt: skip


def _as_fields(data):
    """``data`` with every point and quaternion written as a mapping, as ROS tools write them."""
    if isinstance(data, dict):
        out = {}
        for key, value in data.items():
            if key in ("position", "translation") and isinstance(value, list):
                out[key] = dict(zip("xyz", value))
            elif key in ("orientation", "rotation") and isinstance(value, list):
                out[key] = dict(zip("xyzw", value))
            else:
                out[key] = _as_fields(value)
        return out
    return [_as_fields(item) for item in data] if isinstance(data, list) else data


def test_points_and_quaternions_may_be_mappings_of_their_fields(tmp_path):
    listed = load(write_folder(tmp_path / "lists", only(SHELF)))
    fields = _as_fields(SHELF)
    assert fields["world"]["collision_objects"][1]["primitive_poses"][0]["orientation"]["w"]
    assert load(write_folder(tmp_path / "fields", only(fields))) == listed
    del fields["world"]["collision_objects"][0]["primitive_poses"][0]["position"]["z"]
    with pytest.raises(ValueError, match=r"primitive_poses\[0\].position.z: missing$"):
        load(write_folder(tmp_path / "short", only(fields)))


def test_invalid_names_problems_whose_start_collides(tmp_path):
    near_hand = primitive("box", [0.06, 0.06, 0.06], [0.31, 0.0, 0.55])
    far = primitive("box", [0.1, 0.1, 0.1], [-0.6, -0.6, 0.1])
    turned = [1.5] + HOME[1:]  # the hand swings to +y, away from the box
    problems = {"desk_panda": {"0001": (scene(near_hand), request(goal=turned)),
                               "0002": (scene(far), request(goal=turned))}}  # fmt: skip
    write_folder(tmp_path, problems)
    loaded = load(tmp_path)
    assert all(p.workspace.axis_aligned for _, p in loaded)
    reasons = invalid(loaded)
    assert list(reasons) == ["desk/0001"]
    assert reasons["desk/0001"].startswith("start: collision: panda_")
    assert "touches box 0" in reasons["desk/0001"] and "goal" not in reasons["desk/0001"]


def _changed(path: list, value) -> dict:
    """A copy of `SHELF` with the entry at ``path`` (keys and indices) set to ``value``."""
    data = copy.deepcopy(SHELF)
    target = data
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    return data


OBJECT = ["world", "collision_objects", 0]
REFUSED_SCENES = [
    # A string is no flag: "false" used to be read as true.
    ({**SHELF, "is_diff": "false"}, r"scene0001.yaml: is_diff: expected true or false"),
    (_changed(OBJECT + ["meshes"], [{"vertices": [[0, 0, 0]], "triangles": [[0, 0, 0]]}]),
     r"scene0001.yaml: world.collision_objects\[0\] \('.*'\).meshes: meshes are not supported"),
    (_changed(OBJECT + ["planes"], [{"coef": [0, 0, 1, 0]}]), r"\.planes: planes are not"),
    (_changed(OBJECT + ["primitives", 0, "type"], "cone"),
     r"primitives\[0\].type: 'cone' is not supported \(box, cylinder or sphere only\)"),
    (_changed(OBJECT + ["primitives", 0, "dimensions"], [0.4, 0.6]),
     r"primitives\[0\].dimensions: expected 3 numbers, got 2"),
    (_changed(OBJECT + ["header"], {"frame_id": "camera"}),
     r"header.frame_id: unknown frame 'camera' \(known: panda_link0, world\)"),
    (_changed(["world", "octomap"], {"octomap": {"resolution": 0.02, "data": [1, 2, 3]}}),
     r"world.octomap: octomaps are not supported"),
    (_changed(["robot_state", "attached_collision_objects"], [{"link_name": "panda_hand"}]),
     r"robot_state.attached_collision_objects: attached collision objects are not"),
    (_changed(["robot_state", "multi_dof_joint_state", "transforms", 0, "translation"],
              [0, 0, 0.5]),
     r"transforms\[0\] \(the robot base\): translation \[0.0, 0.0, 0.5\].*only frames at the"),
    (_changed(["fixed_frame_transforms", 0, "transform", "rotation"], Z_TURN),
     r"fixed_frame_transforms\[0\].transform: .* only frames at the robot base"),
    (_changed(["robot_model_name"], "fetch"), r"robot_model_name: 'fetch' is not the 'panda'"),
    (_changed(["link_padding"], [{"link_name": "panda_hand", "padding": 0.01}]),
     r"link_padding\[0\]: a link padding other than 0 is not supported"),
    (_changed(["allowed_collision_matrix"],
              {"entry_names": ["panda_hand", "box[0.6, 0.0, 0.3]"],
               "entry_values": [[False, True], [True, False]]}),
     r"allowed_collision_matrix: object 'box\[0.6, 0.0, 0.3\]' is allowed to touch the robot"),
    (_changed(["world", "surface"], []), r"world.surface: unknown key"),
    # Values of the wrong type where a name or number goes: refused, never a TypeError.
    (_changed(OBJECT + ["primitives", 0, "type"], ["box"]),
     r"primitives\[0\].type: \['box'\] is not supported"),
    (_changed(OBJECT + ["primitives", 0, "type"], True),
     r"primitives\[0\].type: True is not supported"),
    (_changed(OBJECT + ["primitive_poses", 0, "position"], [10**400, 0, 0]),
     r"primitive_poses\[0\].position\[0\]: 1000000000\.\.\.\(401 digits\) is too large"),
    (_changed(OBJECT + ["primitive_poses", 0, "position"], [float("inf"), 0, 0]),
     r"primitive_poses\[0\].position\[0\]: must be finite, got inf"),
    (_changed(["allowed_collision_matrix"], {"entry_names": [["panda_hand"]],
                                             "entry_values": [[False]]}),
     r"allowed_collision_matrix.entry_names\[0\]: expected a name, got \['panda_hand'\]"),
]  # fmt: skip


@pytest.mark.parametrize("scene_data, message", REFUSED_SCENES)
def test_unsupported_scene_content_is_refused_in_one_line(tmp_path, scene_data, message):
    write_folder(tmp_path, only(scene_data))
    with pytest.raises(ValueError, match=message) as error:
        load(tmp_path)
    assert "\n" not in str(error.value)
    assert str(error.value).startswith("one_panda/scene0001.yaml: ")


def _request_changed(path: list, value) -> dict:
    data = request()
    target = data
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    return data


GOAL_ENTRY = ["goal_constraints", 0]
REFUSED_REQUESTS = [
    (request(fingers=(0.04, 0.04)),
     r"start_state.joint_state \(panda_finger_joint1\): 0.04, but the robot holds this joint "
     r"at 0.065"),
    (_request_changed(["start_state", "joint_state", "name", 0], "shoulder"),
     r"start_state.joint_state: unknown joint 'shoulder'"),
    (_request_changed(GOAL_ENTRY + ["joint_constraints"], []),
     r"goal_constraints\[0\].joint_constraints: joint panda_joint1 is missing"),
    (_request_changed(GOAL_ENTRY + ["position_constraints"], [{"link_name": "panda_hand"}]),
     r"goal_constraints\[0\].position_constraints: position goals are not supported"),
    (_request_changed(GOAL_ENTRY + ["orientation_constraints"], [{"link_name": "panda_hand"}]),
     r"goal_constraints\[0\].orientation_constraints: orientation goals are not supported"),
    (_request_changed(["goal_constraints"], request()["goal_constraints"] * 2),
     r"goal_constraints: expected one goal, got 2"),
    (_request_changed(["path_constraints"], {"joint_constraints": [{"joint_name": "a"}]}),
     r"path_constraints: path constraints are not supported"),
    (request(start=[3.5] + HOME[1:]),
     r"request0001.yaml: start: outside the bounds: joint 1 = 3.5 is above its limit 2.9671"),
    (_request_changed(["start_state", "joint_state", "name", 0], ["panda_joint1"]),
     r"start_state.joint_state\[0\] name: expected a name, got \['panda_joint1'\]"),
    (_request_changed(GOAL_ENTRY + ["joint_constraints", 0, "joint_name"], ["panda_joint1"]),
     r"joint_constraints\[0\] name: expected a name"),
    (_request_changed(["start_state", "joint_state", "position", 0], 10**400),
     r"start_state.joint_state \(panda_joint1\): 1000000000\.\.\.\(401 digits\) is too large"),
    (_request_changed(["start_state", "joint_state", "position", 0], float("nan")),
     r"start_state.joint_state \(panda_joint1\): must be finite, got nan"),
]  # fmt: skip


@pytest.mark.parametrize("request_data, message", REFUSED_REQUESTS)
def test_unsupported_request_content_is_refused_in_one_line(tmp_path, request_data, message):
    write_folder(tmp_path, only(SHELF, request_data))
    with pytest.raises(ValueError, match=message) as error:
        load(tmp_path)
    assert "\n" not in str(error.value)
    assert str(error.value).startswith("one_panda/request0001.yaml: ")


def test_bad_paths_and_sets_are_refused(tmp_path):
    with pytest.raises(ValueError, match=r"^path: .*missing does not exist$"):
        load(tmp_path / "missing")
    (tmp_path / "notes.txt").write_text("not an archive")
    with pytest.raises(ValueError, match=r"^path: .*notes.txt is neither a folder nor a readable"):
        load(tmp_path / "notes.txt")
    with pytest.raises(ValueError, match=r"^path: no MotionBenchMaker problems in "):
        load(tmp_path)
    write_folder(tmp_path / "fetch", {"box_fetch": {"0001": (SHELF, request())}})
    with pytest.raises(ValueError, match=r"box_fetch/\w+0001.yaml: not a Panda problem"):
        load(tmp_path / "fetch")
    folder = write_folder(tmp_path / "half", only(SHELF))
    (folder / "one_panda" / "scene0001.yaml").unlink()
    with pytest.raises(ValueError, match=r"request0001.yaml: no scene0001.yaml beside it"):
        load(folder)
    with pytest.raises(ValueError, match=r"; pass the folder that holds one_panda$"):
        load(write_folder(tmp_path / "scene", only(SHELF)) / "one_panda")
    for radius in (-1, 0, float("nan"), "0.1"):
        with pytest.raises(ValueError, match=r"^goal_radius: "):
            load(tmp_path / "scene", goal_radius=radius)
    folder = write_folder(tmp_path / "broken", only(SHELF))
    (folder / "one_panda" / "scene0001.yaml").write_text("world: [unclosed\n")
    with pytest.raises(ValueError, match=r"one_panda/scene0001.yaml: not valid YAML at line"):
        load(folder)


@pytest.mark.parametrize(
    "text, message",
    [
        ("world: &a {collision_objects: [], octomap: *a}\n", r"an alias makes a value contain"),
        # Nine levels of eight aliases each: 8 ** 9 values when expanded.
        (
            "a0: &a0 [0, 0, 0, 0, 0, 0, 0, 0]\n"
            + "".join(f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 8)}]\n" for i in range(1, 10)),
            r"expands to more than",
        ),
    ],
)
def test_aliases_that_never_end_are_refused(tmp_path, text, message):
    folder = write_folder(tmp_path, only(SHELF))
    (folder / "one_panda" / "scene0001.yaml").write_text(text)
    with pytest.raises(ValueError, match=r"^one_panda/scene0001.yaml: " + message):
        load(folder)


def test_a_damaged_archive_is_refused_in_one_line(tmp_path):
    data = write_archive(tmp_path, FIXTURE).read_bytes()
    for name, damaged in [("cut.tar.bz2", data[:-10]), ("half.tar.bz2", data[: len(data) // 2]),
                          ("empty.tar.bz2", b"")]:  # fmt: skip
        path = tmp_path / name
        path.write_bytes(damaged)
        with pytest.raises(ValueError, match=r"^path: .* is neither a folder nor a readable tar "
                           r"archive \(.+\)$") as error:  # fmt: skip
            load(path)
        assert "\n" not in str(error.value)


def test_an_archives_linked_members_load_as_its_folder_does(tmp_path):
    # tar stores a hard-linked file's second name as a link member: it used to be dropped.
    import os

    folder = write_folder(tmp_path / "src", {"shelf_panda": {"0001": (SHELF, request())}})
    for kind in ("scene", "request"):
        os.link(folder / "shelf_panda" / f"{kind}0001.yaml",
                folder / "shelf_panda" / f"{kind}0002.yaml")  # fmt: skip
    archive = tmp_path / "linked.tar.bz2"
    with tarfile.open(archive, "w:bz2") as tar:
        tar.add(folder, arcname="problems")
    with tarfile.open(archive) as tar:
        assert any(member.islnk() for member in tar)
    assert (
        [name for name, _ in load(archive)]
        == [name for name, _ in load(folder)]
        == [
            "shelf/0001",
            "shelf/0002",
        ]
    )


def _archive_of(tmp_path: Path, members: dict[str, dict]) -> Path:
    archive = tmp_path / "made.tar"
    with tarfile.open(archive, "w") as tar:
        for name, data in members.items():
            text = yaml.safe_dump(data, default_flow_style=None).encode()
            info = tarfile.TarInfo(name)
            info.size = len(text)
            tar.addfile(info, io.BytesIO(text))
    return archive


@pytest.mark.parametrize(
    ("members", "message"),
    [
        # One problem, numbered two ways: which pair is meant would be left to chance.
        ({"p/shelf_panda/scene1.yaml": SHELF, "p/shelf_panda/request0001.yaml": request()},
         r"request0001.yaml: problem 1 is numbered 1 in shelf_panda/scene1.yaml"),
        # A scene and a request of two folders of one name: never paired.
        ({"a/shelf_panda/scene0001.yaml": SHELF, "b/c/shelf_panda/request0001.yaml": request()},
         r"found in two folders named shelf_panda .*\(a and b/c\)"),
        ({"../shelf_panda/scene0001.yaml": SHELF},
         r"\.\./shelf_panda/scene0001.yaml: an archive member outside the archive"),
        ({"/abs/shelf_panda/scene0001.yaml": SHELF}, r"an archive member outside the archive"),
    ],
)  # fmt: skip
def test_an_archive_that_pairs_files_by_chance_is_refused(tmp_path, members, message):
    with pytest.raises(ValueError, match=message):
        load(_archive_of(tmp_path, members))


def test_digits_other_than_ascii_name_no_problem(tmp_path):
    members = {"p/shelf_panda/scene0001.yaml": SHELF, "p/shelf_panda/request0001.yaml": request(),
               "p/shelf_panda/scene\uff10\uff12.yaml": SHELF}  # fmt: skip
    assert [name for name, _ in load(_archive_of(tmp_path, members))] == ["shelf/0001"]


def test_an_empty_file_and_a_device_are_named_in_one_line(tmp_path):
    folder = write_folder(tmp_path, only(SHELF))
    (folder / "one_panda" / "scene0001.yaml").write_text("\n")
    with pytest.raises(ValueError, match=r"^one_panda/scene0001.yaml: the file is empty$"):
        load(folder)
    with pytest.raises(ValueError, match=r"^path: /dev/null is neither a folder nor a tar"):
        load("/dev/null")
