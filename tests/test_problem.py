import json

import numpy as np
import pytest

from temp_gym import Problem

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
    assert problem.robot == "point2d" and problem.num_obstacles >= 1


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
        ({"obstacles": [{"center": [1, 1]}]}, "obstacles[0]", "needs both"),
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


IIWA = {
    "robot": "kuka_iiwa14",
    "obstacles": [{"center": [0.8, 0, 0.5], "half_extents": [0.05, 0.5, 0.5]}],
    "start": [0, 0, 0, 0, 0, 0, 0],
    "goal": [0.5, 0.3, 0, -0.4, 0, 0.5, 0],
    "goal_radius": 0.1,
}


@pytest.mark.parametrize("field", ["start", "goal"])
def test_iiwa_start_or_goal_in_self_collision_names_the_links(field):
    folded = [0, 0, 0, 0, 0, 2.08, 0]  # joint 6 at its limit: link_7 against link_5
    with pytest.raises(ValueError) as error:
        Problem.from_dict({**IIWA, field: folded})
    message = str(error.value)
    assert message.startswith(f"{field}: "), message
    assert "self-collision between link_5 and link_7" in message, message
    into_the_base = [0, 2.0, 0, -2.0, 0, 0, 0]  # shoulder and elbow folded down
    with pytest.raises(ValueError, match=f"^{field}: .* self-collision between link_0 and link_5"):
        Problem.from_dict({**IIWA, field: into_the_base})


def test_iiwa_box_collision_keeps_its_message():
    with pytest.raises(ValueError, match=r"^goal: .* is in collision \(iiwa sphere model"):
        Problem.from_dict({**IIWA, "goal": [0, 1.2, 0, 0, 0, 0, 0]})


def test_iiwa_bounds_must_lie_within_the_joint_limits():
    from temp_gym.worlds.robots.iiwa14 import joint_limits

    limits = joint_limits()
    inside = Problem.from_dict({**IIWA, "bounds": (limits * 0.9).tolist()})
    np.testing.assert_array_equal(inside.bounds, limits * 0.9)
    np.testing.assert_array_equal(Problem.from_dict(IIWA).bounds, limits)
    wide = limits.copy()
    wide[1, 3] += 0.31
    with pytest.raises(ValueError, match="^bounds: wider than the kuka_iiwa14 joint limits at j"):
        Problem.from_dict({**IIWA, "bounds": wide.tolist()})
