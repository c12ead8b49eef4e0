import math

import numpy as np
import pytest

from temp_gym import Problem, plan
from temp_gym.evaluation import (
    aggregate_rows,
    cost_curve,
    markdown_table,
    paired_ratios,
    reach_tolerance,
    success_curve,
    tolerance_target,
)


def test_tolerance_on_a_known_history():
    history = {"nodes": [100, 250, 400], "time": [0.1, 0.3, 0.5], "best_cost": [30.0, 21.5, 20.2]}
    target = tolerance_target(20.0)  # 21.0
    assert target == pytest.approx(21.0)
    assert reach_tolerance(history, target) == {
        "success": True,
        "time": 0.5,
        "nodes": 400,
        "cost": 20.2,
    }
    assert reach_tolerance(history, 21.5)["nodes"] == 250
    assert reach_tolerance(history, 19.0)["success"] is False
    with pytest.raises(ValueError):
        tolerance_target(math.inf)


def test_protocol_end_to_end_on_a_toy_problem_whose_answer_is_known():
    # Empty world: TEMP with a goal-seeking policy walks the straight line in unit steps and the
    # last step lands on the goal: J = 16 exactly. A baseline within 5% must reach <= 16.8.
    problem = Problem.from_dict(
        {
            "robot": "point2d",
            "bounds": [[0, 0], [20, 20]],
            "obstacles": [],
            "start": [2, 10],
            "goal": [18, 10],
            "goal_radius": 0.5,
        }
    )

    class TowardsGoal:
        def reset(self, problem, seed=None):
            pass

        def __call__(self, observation):
            return observation["goal"]

    temp = plan(problem, planner="temp", policy=TowardsGoal(), stop_at_first=True)
    assert temp.attention["cost"] == pytest.approx(16.0)
    target = tolerance_target(temp.attention["cost"])
    baseline = plan(problem, planner="rrt_star", seed=0, target_cost=target, max_nodes=20000)
    reached = reach_tolerance(baseline.history, target)
    assert reached["success"] and reached["cost"] <= 16.8 + 1e-12
    assert reached["nodes"] == baseline.nodes  # the run stopped where tolerance was reached
    # Everything before that entry was above tolerance.
    earlier = np.asarray(baseline.history["best_cost"])[:-1]
    assert np.all(earlier > target)


def records():
    return [
        {"planner": "temp", "success": True, "time": 0.1, "nodes": 50, "sampling_failures": 2},
        {"planner": "temp", "success": True, "time": 0.3, "nodes": 70, "sampling_failures": 4},
        {
            "planner": "rrt_star",
            "success": True,
            "time": 1.0,
            "nodes": 500,
            "sampling_failures": 40,
        },
        {
            "planner": "rrt_star",
            "success": False,
            "time": None,
            "nodes": None,
            "sampling_failures": 60,
        },
    ]


def test_aggregate_rows_and_success_curve():
    rows = aggregate_rows(records())
    assert rows["temp"] == {
        "tasks": 2,
        "success_rate": 1.0,
        "time": pytest.approx(0.2),
        "nodes": 60.0,
        "sampling_failures": 3.0,
    }
    assert rows["rrt_star"]["success_rate"] == 0.5 and rows["rrt_star"]["nodes"] == 500
    assert rows["rrt_star"]["sampling_failures"] == 50.0
    curves = success_curve(records(), np.array([0.05, 0.2, 0.5, 2.0]))
    np.testing.assert_allclose(curves["temp"], [0.0, 0.5, 1.0, 1.0])
    np.testing.assert_allclose(curves["rrt_star"], [0.0, 0.0, 0.0, 0.5])
    table = markdown_table({"2D easy": rows}, ["temp", "rrt_star"])
    assert "| 2D easy | 0.200 | 60 | 100% | 1.000 | 500 | 50% |" in table


def test_cost_curve_charges_unsolved_tasks_one_and_a_half_times_the_task_maximum():
    histories = {
        "task0": {
            "temp": {"nodes": [10, 100], "best_cost": [12.0, 10.0]},
            "rrt_star": {"nodes": [300], "best_cost": [11.0]},
        },
    }
    curve = cost_curve(histories, np.array([5, 10, 150, 300]))
    np.testing.assert_allclose(curve["temp"], [18.0, 12.0, 10.0, 10.0])  # 1.5 * max(12, 11)
    np.testing.assert_allclose(curve["rrt_star"], [18.0, 18.0, 18.0, 11.0])


def test_cost_curve_charges_a_planner_that_never_solved_the_task():
    histories = {
        0: {
            "temp": {"nodes": [10], "best_cost": [4.0]},
            "rrt_star": {"nodes": [], "best_cost": []},
        }
    }
    curves = cost_curve(histories, np.array([5, 20]))
    np.testing.assert_allclose(curves["rrt_star"], [6.0, 6.0])  # 1.5 x the task's maximum
    np.testing.assert_allclose(curves["temp"], [6.0, 4.0])


def test_paired_ratios_compare_the_same_tasks():
    def record(temp, baseline):
        return {"planners": {"temp": temp, "rrt_star": baseline}}

    solved = lambda t, n: {"success": True, "time": t, "nodes": n}  # noqa: E731
    failed = {"success": False, "time": None, "nodes": None}
    records = [
        record(solved(1.0, 10), solved(4.0, 100)),
        record(solved(3.0, 30), solved(4.0, 100)),
        record(solved(9.0, 90), failed),  # the baseline failed: not a pair
        record(failed, solved(0.1, 5)),  # TEMP failed: not a pair
    ]
    ratios = paired_ratios(records, "temp", "rrt_star")
    assert ratios == {"time": pytest.approx(0.5), "nodes": pytest.approx(0.2), "tasks": 2}
    assert paired_ratios([record(failed, solved(1.0, 1))], "temp", "rrt_star") is None
