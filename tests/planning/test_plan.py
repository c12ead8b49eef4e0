import json
import math

import numpy as np
import pytest

from temp_gym.planning import PLANNERS, PlanResult, plan
from temp_gym.worlds.checkers import certify_path

OURS = ["rrt_star", "informed_rrt_star"]


def assert_valid_solution(problem, result):
    assert result.success
    path = result.path
    assert path.ndim == 2 and path.shape[1] == problem.dim
    np.testing.assert_array_equal(path[0], problem.start)
    assert np.linalg.norm(path[-1] - problem.goal) <= problem.goal_radius + 1e-12
    assert certify_path(problem, path)
    length = float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
    assert result.cost == pytest.approx(length, abs=1e-9)


@pytest.mark.parametrize("planner", OURS)
@pytest.mark.parametrize("which", ["problem_2d", "problem_3d"])
def test_solutions_are_certified_and_reach_the_goal(planner, which, request):
    problem = request.getfixturevalue(which)
    result = plan(problem, planner=planner, seed=1, max_nodes=1500)
    assert isinstance(result, PlanResult)
    assert_valid_solution(problem, result)
    assert result.nodes == 1500
    assert result.samples == result.nodes - 1 + result.sampling_failures
    assert result.collision_checks >= result.samples - 1
    assert result.time_to_first_solution is not None
    assert result.nodes_to_first_solution <= result.nodes
    costs = result.history["best_cost"]
    assert len(costs) >= 1 and np.all(np.diff(costs) < 0)
    assert costs[-1] == pytest.approx(result.cost)
    assert result.cost_at(result.nodes) == pytest.approx(result.cost)
    json.dumps(result.to_dict())


@pytest.mark.parametrize("planner", OURS)
def test_same_seed_same_result(problem_2d, planner):
    a = plan(problem_2d, planner=planner, seed=5, max_nodes=800)
    b = plan(problem_2d, planner=planner, seed=5, max_nodes=800)
    c = plan(problem_2d, planner=planner, seed=6, max_nodes=800)
    np.testing.assert_array_equal(a.path, b.path)
    for field in ("cost", "nodes", "samples", "sampling_failures", "collision_checks"):
        assert getattr(a, field) == getattr(b, field)
    np.testing.assert_array_equal(a.history["nodes"], b.history["nodes"])
    np.testing.assert_array_equal(a.history["best_cost"], b.history["best_cost"])
    assert a.cost != c.cost


def test_stop_rules(problem_2d):
    first = plan(problem_2d, planner="rrt_star", seed=2, stop_at_first=True)
    assert first.success and first.nodes == first.nodes_to_first_solution
    target = plan(problem_2d, "rrt_star", seed=2, target_cost=first.cost + 2.0, max_nodes=4000)
    assert target.cost <= first.cost + 2.0 and target.nodes == first.nodes
    timed = plan(problem_2d, "rrt_star", seed=2, time_limit=0.0)
    assert timed.nodes == 1 and not timed.success and timed.path is None
    assert math.isinf(timed.cost) and timed.to_dict()["cost"] is None
    capped = plan(problem_2d, "rrt_star", seed=2, max_nodes=5000, max_samples=50)
    assert capped.samples == 50


def test_informed_is_no_worse_on_average(problem_2d):
    ours = [plan(problem_2d, planner=p, seed=s, max_nodes=2000).cost for p in OURS for s in (1, 2)]
    assert np.mean(ours[2:]) <= np.mean(ours[:2]) * 1.02


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"planner": "rrt_sharp"}, "planner"),
        ({"max_nodes": 0}, "max_nodes"),
        ({"max_nodes": 2.5}, "max_nodes"),
        ({"time_limit": -1.0}, "time_limit"),
        ({"seed": -1}, "seed"),
        ({"seed": 1.5}, "seed"),
        ({"step_size": 0.0}, "step_size"),
        ({"step_size": math.inf}, "step_size"),
        ({"goal_bias": 1.5}, "goal_bias"),
        ({"target_cost": math.nan}, "target_cost"),
        ({"max_samples": 0}, "max_samples"),
        ({"stop_at_first": "no"}, "stop_at_first"),  # was truthy: stopped at the first
        ({"stop_at_first": None}, "stop_at_first"),
        ({"planner": ["temp"]}, "planner"),  # was a TypeError (unhashable)
        ({"attention_follow_fallback": 2.0}, "attention_follow_fallback"),
    ],
)
def test_bad_arguments_raise(problem_2d, kwargs, match):
    with pytest.raises(ValueError, match=match):
        plan(problem_2d, **kwargs)


def test_bad_problem_raises():
    with pytest.raises(ValueError, match="problem"):
        plan({"robot": "point2d"})


def test_registry_lists_all_planners():
    assert {"rrt_star", "informed_rrt_star", "ompl_rrt_star", "ompl_informed_rrt_star"} <= set(
        PLANNERS
    )


@pytest.mark.parametrize("planner", ["rrt_star", "informed_rrt_star", "temp"])
def test_start_in_goal_region_is_a_two_state_path_of_cost_zero(problem_2d, planner):
    # A path is at least one motion, as OMPL's are: [start, start].
    problem = problem_2d.replace(goal=[2.2, 2.2])
    result = plan(problem, planner, seed=0, max_nodes=50)
    assert result.success and result.cost == 0.0 and result.nodes_to_first_solution == 1
    assert result.path.tolist() == [problem.start.tolist()] * 2


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"max_nodes": 10**400}, "max_nodes"),
        ({"max_samples": 10**400}, "max_samples"),
        ({"attention_nodes": 2**60}, "attention_nodes"),
        ({"time_limit": 10**400}, "time_limit"),
        ({"step_size": 10**400}, "step_size"),
        ({"target_cost": 10**400}, "target_cost"),
        ({"target_cost": float("nan")}, "target_cost"),
        ({"goal_bias": 10**400}, "goal_bias"),
    ],
)
def test_huge_numbers_are_value_errors_naming_the_argument(problem_2d, kwargs, match):
    with pytest.raises(ValueError, match=f"^{match}"):
        plan(problem_2d, "rrt_star", **kwargs)


@pytest.mark.parametrize(
    "kwargs",
    [{"step_size": 1e-17}, {"step_size": 5e-324}, {"attention_near_goal_factor": 1e30},
     {"attention_patience": 2**53, "attention_near_goal_factor": 2000}],
)  # fmt: skip
def test_a_patience_beyond_any_tree_means_never_stall_not_an_overflow(problem_2d, kwargs):
    # Each of these made the stall patience (or its near-goal multiple) overflow an int64. The
    # shipped 2D policy declares its own patience: this one follows the default rule.
    from temp_gym import load_policy

    policy = load_policy("TEMP-2D-v0").fresh(attention_patience=None)
    result = plan(problem_2d, planner="temp", max_nodes=60, policy=policy, **kwargs)
    assert result.nodes <= 60 and result.attention["stop"] != "stalled"


@pytest.mark.parametrize("planner", ["rrt_star", "rrt_connect"])
def test_a_plan_that_never_leaves_its_start_says_so(planner):
    from temp_gym import Problem

    # Four walls around the start, a millimetre from it on every side, meeting at the corners.
    walls = [{"center": c, "half_extents": h} for c, h in [
        ([2.0, 2.2505], [0.25, 0.2495]), ([2.0, 1.7495], [0.25, 0.2495]),
        ([1.7495, 2.0], [0.2495, 0.25]), ([2.2505, 2.0], [0.2495, 0.25])]]  # fmt: skip
    problem = Problem.from_dict({"robot": "point2d", "bounds": [[0, 0], [20, 20]],
                                 "obstacles": walls, "start": [2, 2], "goal": [18, 18],
                                 "goal_radius": 0.5})  # fmt: skip
    result = plan(problem, planner=planner, seed=0, max_nodes=200, time_limit=0.5)
    assert not result.success
    assert "no motion out of the start was certified" in result.summary()
    opened = Problem.from_dict({**problem.to_dict(), "obstacles": walls[1:3]})  # a corner
    assert (
        "no motion out of the start"
        not in plan(opened, planner=planner, seed=0, max_nodes=200).summary()
    )
