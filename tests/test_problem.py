import json
import re
from pathlib import Path

import numpy as np
import pytest

from temp_gym import Problem
from temp_gym.problem import Workspace

EXAMPLE = {
    "robot": "point2d",
    "bounds": [[0, 0], [20, 20]],
    "obstacles": [{"center": [10, 10], "half_extents": [1, 3]}],
    "start": [2, 2],
    "goal": [18, 18],
    "goal_radius": 0.5,
}


def example(**changes):
    data = json.loads(json.dumps(EXAMPLE))
    data.update(changes)
    return data


def test_json_round_trip_is_exact(tmp_path):
    data = example(
        start=[0.1 + 0.2, 1 / 3],
        obstacles=[{"center": [10.123456789012345, 10], "half_extents": [1e-3, 3]}],
    )
    problem = Problem.from_dict(data)
    path = tmp_path / "p.json"
    problem.save(path)
    loaded = Problem.load(path)
    assert loaded == problem
    assert loaded.to_dict() == problem.to_dict()
    assert loaded.start.tolist() == [0.1 + 0.2, 1 / 3]
    assert Problem.from_dict(loaded.to_dict()).to_dict() == loaded.to_dict()


def test_example_file_in_repo_loads():
    problem = Problem.load("examples/point2d.json")
    assert problem.robot == "point2d" and problem.workspace.num_obstacles >= 1


def test_point3d_and_arrays_are_read_only():
    problem = Problem.from_dict(
        {
            "robot": "point3d",
            "bounds": [[0, 0, 0], [20, 20, 20]],
            "obstacles": [{"center": [10, 10, 10], "half_extents": [1, 1, 1]}],
            "start": [1, 1, 1],
            "goal": [19, 19, 19],
            "goal_radius": 1,
        }
    )
    assert problem.dim == 3
    with pytest.raises(ValueError):
        problem.start[0] = 5.0


@pytest.mark.parametrize(
    "changes, field, reason",
    [
        ({"robot": "unicycle"}, "robot", "unknown robot"),
        ({"bounds": [[0, 0, 0], [20, 20, 20]]}, "bounds[0]", "expected 2 numbers"),
        ({"bounds": [[0, 0], [20, float("nan")]]}, "bounds[1]", "NaN or inf"),
        ({"bounds": [[0, 30], [20, 20]]}, "bounds", "lower must be below upper"),
        ({"start": [2, 2, 2]}, "start", "expected 2 numbers"),
        ({"start": [2, float("inf")]}, "start", "NaN or inf"),
        ({"goal": ["a", 1]}, "goal", "expected numbers"),
        ({"start": [-1, 2]}, "start", "outside the bounds"),
        ({"goal": [18, 25]}, "goal", "outside the bounds"),
        ({"start": [10, 10]}, "start", "in collision"),
        ({"goal": [10.5, 12.9]}, "goal", "in collision"),
        ({"goal_radius": 0}, "goal_radius", "positive"),
        ({"goal_radius": -1}, "goal_radius", "positive"),
        ({"goal_radius": float("nan")}, "goal_radius", "positive"),
        (
            {"obstacles": [{"center": [1, 1], "half_extents": [0, 1]}]},
            "obstacles[0].half_extents",
            "positive",
        ),
        (
            {"obstacles": [{"center": [1, 1], "half_extents": [-1, 1]}]},
            "obstacles[0].half_extents",
            "positive",
        ),
        (
            {"obstacles": [{"center": [1, 1, 1], "half_extents": [1, 1]}]},
            "obstacles[0].center",
            "expected 2 numbers",
        ),
        (
            {"obstacles": [{"center": [1, 1], "half_extents": [1, 1], "color": "red"}]},
            "obstacles[0].color",
            "unknown key",
        ),
        (
            {"obstacles": [{"center": [1, 1]}]},
            "obstacles[0]",
            "a box needs center and half_extents",
        ),
        ({"obstacles": {"center": [1, 1]}}, "obstacles", "expected a list"),
        ({"speed": 3}, "speed", "unknown key"),
    ],
)
def test_validation_errors_name_field_and_reason(changes, field, reason):
    with pytest.raises(ValueError) as error:
        Problem.from_dict(example(**changes))
    message = str(error.value)
    assert message.startswith(field), message
    assert reason in message, message


def test_missing_keys():
    data = example()
    del data["goal"]
    with pytest.raises(ValueError, match="^goal: missing"):
        Problem.from_dict(data)
    data = example()
    del data["bounds"]
    with pytest.raises(ValueError, match="^bounds: missing"):
        Problem.from_dict(data)


def test_malformed_json(tmp_path):
    path = tmp_path / "bad.json"
    path.write_text('{"robot": "point2d", ')
    with pytest.raises(ValueError, match="malformed JSON"):
        Problem.load(path)
    path.write_text("[1, 2]")
    with pytest.raises(ValueError, match="expected a JSON object"):
        Problem.load(path)


def test_replace_validates():
    problem = Problem.from_dict(example())
    assert problem.replace(goal_radius=1.0).goal_radius == 1.0
    with pytest.raises(ValueError, match="goal_radius"):
        problem.replace(goal_radius=-1.0)
    assert np.array_equal(problem.replace().start, problem.start)


HUGE = 10**400  # beyond float range: float(HUGE) raises OverflowError


@pytest.mark.parametrize(
    "changes, field",
    [
        ({"start": [HUGE, 2]}, "start[0]"),
        ({"goal_radius": HUGE}, "goal_radius"),
        ({"goal_radius": 1e308}, "goal_radius"),  # its square overflows
        ({"bounds": [[-1e308, -1e308], [1e308, 1e308]]}, "bounds[0][0]"),
        ({"bounds": [[0, 0], [20, HUGE]]}, "bounds[1][1]"),
        ({"obstacles": [{"center": [HUGE, 1], "half_extents": [1, 1]}]}, "obstacles[0].center"),
        ({"goal_radius": 1e-200}, "goal_radius"),  # its square underflows to 0
        ({"bounds": [[0, 0], [1e-40, 20]], "start": [0, 2], "goal": [0, 18]}, "bounds"),
        ({"goal_radius": 1j}, "goal_radius"),
    ],
)
def test_numbers_that_overflow_or_underflow_are_rejected_by_name(changes, field):
    with pytest.raises(ValueError, match="^" + re.escape(field)):
        Problem.from_dict(example(**changes))


def test_huge_integers_never_raise_overflow_error_from_the_api():
    with pytest.raises(ValueError, match="too large"):
        Workspace("point2d", [[0, 0], [20, HUGE]], np.zeros((0, 2)), np.zeros((0, 2)))
    workspace = Workspace("point2d", [[0, 0], [20, 20]], np.zeros((0, 2)), np.zeros((0, 2)))
    with pytest.raises(ValueError, match="too large"):
        Problem(workspace, [2, HUGE], [3, 3], 1)


def test_a_tiny_world_is_planned_correctly_not_solved_by_underflow():
    # Scale 1e-9: the start is 1.8e-8 from the goal, whose radius is 5e-10.
    scale = 1e-9
    data = example(
        bounds=[[0, 0], [20 * scale, 20 * scale]],
        obstacles=[{"center": [10 * scale, 10 * scale], "half_extents": [scale, 3 * scale]}],
        start=[2 * scale, 2 * scale],
        goal=[18 * scale, 18 * scale],
        goal_radius=0.5 * scale,
    )
    from temp_gym import plan

    result = plan(Problem.from_dict(data), "rrt_star", seed=0, max_nodes=1500)
    assert result.success and result.cost > 16 * np.sqrt(2) * scale
    assert len(result.path) > 2


def write(tmp_path, content: bytes):
    path = tmp_path / "problem.json"
    path.write_bytes(content)
    return path


def test_duplicate_keys_are_rejected(tmp_path):
    text = json.dumps(example()).replace(
        '"robot": "point2d"', '"robot": "kuka_iiwa14", "robot": "point2d"'
    )
    with pytest.raises(ValueError, match=r"problem\.json: robot: duplicate key"):
        Problem.load(write(tmp_path, text.encode()))
    box = '{"center": [10, 10], "center": [3, 3], "half_extents": [1, 1]}'
    text = json.dumps(example()).replace(json.dumps(EXAMPLE["obstacles"][0]), box)
    with pytest.raises(ValueError, match="center: duplicate key"):
        Problem.load(write(tmp_path, text.encode()))


@pytest.mark.parametrize("encoding", ["utf-16", "latin-1"])
def test_files_that_are_not_utf8_name_the_file(tmp_path, encoding):
    text = json.dumps(example(robot="pointé2d"), ensure_ascii=False)
    with pytest.raises(ValueError, match=r"problem\.json is not UTF-8 text.*save it as UTF-8"):
        Problem.load(write(tmp_path, text.encode(encoding)))


def test_a_utf8_bom_is_accepted(tmp_path):
    assert Problem.load(write(tmp_path, json.dumps(EXAMPLE).encode("utf-8-sig"))).dim == 2


def test_deep_nesting_is_a_value_error_not_a_recursion_error(tmp_path):
    with pytest.raises(ValueError, match="nests JSON too deeply"):
        Problem.load(write(tmp_path, b"[" * 200_000 + b"]" * 200_000))


IIWA = {
    "robot": "kuka_iiwa14",
    "obstacles": [{"center": [0.8, 0, 0.5], "half_extents": [0.05, 0.5, 0.5]}],
    "start": [0, 0, 0, 0, 0, 0, 0],
    "goal": [0.5, 0.3, 0, -0.4, 0, 0.5, 0],
    "goal_radius": 0.1,
}


@pytest.mark.parametrize("field", ["start", "goal"])
def test_iiwa_start_or_goal_in_self_collision_names_the_links(field):
    folded = [0, 0, 0, 0, 0, 2.08, 0]  # joint 6 at its limit: link 7 against link 5
    with pytest.raises(ValueError) as error:
        Problem.from_dict({**IIWA, field: folded})
    message = str(error.value)
    assert message.startswith(f"{field}: "), message
    assert "self-collision between lbr_iiwa_link_5 and lbr_iiwa_link_7" in message, message
    into_the_base = [0, 2.0, 0, -2.0, 0, 0, 0]  # shoulder and elbow folded down
    with pytest.raises(
        ValueError, match=f"^{field}: .* self-collision between lbr_iiwa_link_0 and lbr_iiwa_link_5"
    ):
        Problem.from_dict({**IIWA, field: into_the_base})


def test_iiwa_box_collision_names_the_link_the_box_and_the_depth():
    with pytest.raises(ValueError) as error:
        Problem.from_dict({**IIWA, "goal": [0, 1.2, 0, 0, 0, 0, 0]})  # the hand in the wall
    message = str(error.value)
    assert re.match(
        r"^goal: .* is in collision: lbr_iiwa_link_7 touches box 0, "
        r"penetration \d+\.\d mm \(fcl on the kuka_iiwa14",
        message,
    ), message
    assert "\n" not in message


def test_iiwa_bounds_must_lie_within_the_joint_limits():
    from temp_gym.worlds.arm_world import arm_of

    limits = arm_of("kuka_iiwa14").joint_limits()
    inside = Problem.from_dict({**IIWA, "bounds": (limits * 0.9).tolist()})
    np.testing.assert_array_equal(inside.bounds, limits * 0.9)
    np.testing.assert_array_equal(Problem.from_dict(IIWA).bounds, limits)
    wide = limits.copy()
    wide[1, 3] += 0.31
    with pytest.raises(ValueError, match="^bounds: wider than the kuka_iiwa14 joint limits at j"):
        Problem.from_dict({**IIWA, "bounds": wide.tolist()})


def test_numpy_bounds_are_read_like_lists():
    raw = json.loads(Path("examples/point2d.json").read_text())
    as_arrays = {**raw, "bounds": np.array(raw["bounds"])}
    assert Problem.from_dict(as_arrays) == Problem.from_dict(raw)


def test_a_file_too_large_to_be_a_problem_is_refused_unread(monkeypatch):
    from temp_gym.problem import query

    monkeypatch.setattr(query, "MAX_PROBLEM_BYTES", 100)  # the example file is larger
    with pytest.raises(ValueError, match="too large to be a problem"):
        Problem.load("examples/point2d.json")


def test_negative_zero_makes_no_other_problem_or_workspace():
    data = Problem.load("examples/point2d.json").to_dict()
    positive = Problem.from_dict({**data, "bounds": [[0.0, 0.0], [20.0, 20.0]]})
    negative = Problem.from_dict({**data, "bounds": [[-0.0, 0.0], [20.0, 20.0]]})
    assert positive == negative and hash(positive) == hash(negative)
    assert positive.workspace == negative.workspace
    assert hash(positive.workspace) == hash(negative.workspace)
    assert len({positive, negative}) == 1 and len({positive.workspace, negative.workspace}) == 1
    assert not np.signbit(negative.bounds).any()
    moved = Problem.from_dict({**data, "bounds": [[-1.0, 0.0], [20.0, 20.0]], "start": [-0.0, 1.0]})
    assert not np.signbit(moved.start).any() and moved.start.tolist() == [0.0, 1.0]


def test_swapped_exchanges_start_and_goal_as_a_checked_problem_would():
    problem = Problem.from_dict(example())
    swapped = problem.swapped()
    checked = problem.replace(start=problem.goal.tolist(), goal=problem.start.tolist())
    assert swapped == checked and hash(swapped) == hash(checked)
    for name in ("start", "goal"):
        np.testing.assert_array_equal(getattr(swapped, name), getattr(checked, name))
        assert not getattr(swapped, name).flags.writeable
    assert swapped.workspace is problem.workspace and swapped.goal_radius == problem.goal_radius
    assert swapped.swapped() == problem


def test_unchecked_keeps_a_start_in_collision_and_checks_the_rest():
    workspace = Problem.from_dict(EXAMPLE).workspace
    with pytest.raises(ValueError, match=r"start: \[10.0, 10.0\] is in collision"):
        Problem(workspace, [10, 10], [18, 18], 0.5)
    problem = Problem.unchecked(workspace, [10, 10], [18, 18], 0.5)
    assert problem.start.tolist() == [10.0, 10.0] and problem.goal_radius == 0.5
    assert not problem.start.flags.writeable
    with pytest.raises(ValueError, match=r"^goal: outside the bounds"):
        Problem.unchecked(workspace, [10, 10], [21, 18], 0.5)
    with pytest.raises(ValueError, match=r"^goal_radius: must be positive"):
        Problem.unchecked(workspace, [10, 10], [18, 18], 0.0)
    with pytest.raises(ValueError, match=r"^start: expected"):
        Problem.unchecked(workspace, [10, 10, 10], [18, 18], 0.5)


def test_a_coordinate_a_hair_outside_is_printed_with_every_digit():
    from temp_gym.problem.query import outside_bounds

    bounds = np.array([[-2.96706, 0.0], [2.96706, 1.0]])
    assert outside_bounds(np.array([-2.96706 - 1e-12, 3.2]), bounds, joints=True) == (
        "outside the bounds: joint 1 = -2.967060000001 is below its limit -2.96706; "
        "joint 2 = 3.2 is above its limit 1"
    )


def test_a_path_is_told_whether_it_joins_the_start_to_the_goal_region():
    problem = Problem.from_dict({"robot": "point2d", "bounds": [[0, 0], [10, 10]],
                                 "obstacles": [], "start": [1, 1], "goal": [9, 9],
                                 "goal_radius": 0.5})  # fmt: skip
    assert problem.path_ends_error([[1, 1], [5, 5], [9.3, 9.3]]) is None
    assert problem.path_ends_error([[1, 1 + 1e-10], [9, 9.5]]) is None  # rounding, the ball's edge
    for path, words in [
        ([[1, 1]], "at least 2 states"),
        ([[1, 1, 1], [9, 9, 9]], "at least 2 states of 2 numbers"),
        ([["a", 1], [9, 9]], "no array of numbers"),
        ([[1.1, 1], [9, 9]], "not at the problem's start"),
        ([[1, 1], [9, 9.6]], "outside the goal region"),
        ([[1, 1], [float("nan"), 9]], "outside the goal region"),
    ]:
        assert words in problem.path_ends_error(path), path
