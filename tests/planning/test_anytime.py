import math

import numpy as np
import pytest

from temp_gym.planning import anytime, plan
from temp_gym.planning.anytime import finished, grow_anytime
from temp_gym.planning.result import AnytimeLog
from temp_gym.planning.settings import PlanSettings
from temp_gym.planning.temp_settings import TEMPSettings
from temp_gym.planning.tree import Tree


def test_each_stop_rule_ends_the_loop(problem_2d):
    def grown(**changes):
        tree, log = Tree(problem_2d), AnytimeLog()
        grow_anytime(tree, PlanSettings(**changes), np.random.default_rng(0), log, informed=True)
        return tree, log

    tree, log = grown(max_nodes=40)
    assert tree.num_nodes == 40
    tree, log = grown(max_nodes=10_000, max_samples=25)
    assert tree.samples == 25
    tree, log = grown(max_nodes=10_000, stop_at_first=True)
    assert tree.best_node >= 0 and len(log.nodes) == 1 and log.first_nodes == tree.num_nodes
    first_cost = log.costs[0]
    tree, log = grown(max_nodes=10_000, target_cost=0.97 * first_cost)
    assert tree.best_cost <= 0.97 * first_cost and log.costs[-1] == tree.best_cost
    tree, log = grown(max_nodes=10**9, time_limit=0.0)
    assert tree.num_nodes == 1  # out of time before the first extension


def test_improvements_are_logged_in_order_and_the_first_is_the_first_solution(problem_2d):
    result = plan(problem_2d, "informed_rrt_star", seed=3, max_nodes=1500)
    history = result.history
    assert len(history["nodes"]) >= 2
    assert np.all(np.diff(history["best_cost"]) < 0) and np.all(np.diff(history["nodes"]) > 0)
    assert result.nodes_to_first_solution == history["nodes"][0]
    assert result.time_to_first_solution == history["time"][0]


def test_no_sampler_is_built_when_the_loop_would_not_run(problem_2d, monkeypatch):
    built = []
    monkeypatch.setattr(anytime, "InformedSampler", lambda *a: built.append(a))
    tree = Tree(problem_2d.replace(goal=problem_2d.start.tolist()))  # solved at the root
    settings = PlanSettings(stop_at_first=True)
    assert finished(tree, settings, math.inf)
    grow_anytime(tree, settings, np.random.default_rng(0), AnytimeLog(), informed=True)
    assert built == [] and tree.samples == 0


def test_temp_classical_phase_is_the_same_loop(problem_2d):
    # Attention budget 1 and no goal tree: the classical phase (Informed RRT* on the same
    # tree) does all the work, so TEMP's tree is Informed RRT*'s from the same generator state.
    class Never:
        def reset(self, problem, seed=None):
            pass

        def __call__(self, observation):
            raise AssertionError("the attention phase should not run")

    temp = plan(problem_2d, "temp", seed=5, max_nodes=600, policy=Never(), attention_nodes=1,
                goal_tree=False)  # fmt: skip
    informed = plan(problem_2d, "informed_rrt_star", seed=5, max_nodes=600)
    assert temp.attention["nodes"] == 1 and temp.nodes == informed.nodes == 600
    np.testing.assert_array_equal(temp.path, informed.path)
    np.testing.assert_array_equal(temp.history["best_cost"], informed.history["best_cost"])


@pytest.mark.parametrize(
    "changes, match",
    [
        ({"seed": True}, "seed"),
        ({"max_nodes": np.float64(3.0)}, "max_nodes"),
        ({"time_limit": -0.5}, "time_limit"),
        ({"goal_bias": -0.1}, "goal_bias"),
        ({"attention_patience": -1}, "attention_patience"),
        ({"attention_uniform": 2.0}, "attention_uniform"),
        ({"policy": object()}, "policy"),
    ],
)
def test_plan_settings_check_themselves(changes, match):
    with pytest.raises(ValueError, match=f"^{match}"):
        TEMPSettings(**changes)


def test_plan_settings_normalize_numbers():
    settings = PlanSettings(seed=np.int64(4), max_nodes=np.int32(9), goal_bias=1, time_limit=2)
    assert type(settings.seed) is int and type(settings.max_nodes) is int
    assert type(settings.goal_bias) is float and type(settings.time_limit) is float
    assert TEMPSettings(attention_patience=np.int64(0)).attention_patience == 0


def _grown(problem, seed, informed, compiled_loop, **settings):
    tree, log, rng = Tree(problem, capacity=16), AnytimeLog(), np.random.default_rng(seed)
    grow_anytime(tree, PlanSettings(**settings), rng, log, informed, compiled_loop=compiled_loop)
    return tree, log, rng.random()


@pytest.mark.parametrize("robot", ["point2d", "point3d", "kuka_iiwa14"])
@pytest.mark.parametrize("informed", [False, True])
def test_compiled_loop_grows_the_python_loops_tree(robot, informed):
    """Node for node, the same tree, log and generator state; the arrays grown on the way."""
    from temp_gym.worlds.generators import generate_problem

    rng = np.random.default_rng(5)
    nodes = 500 if robot == "kuka_iiwa14" else 1200
    rules = [{}, {"stop_at_first": True}, {"max_samples": 700}, {"goal_bias": 0.0}]
    for index, rule in enumerate(rules):
        problem = generate_problem(robot, rng, "challenging" if index % 2 else "easy")
        (tree_c, log_c, rng_c), (tree_p, log_p, rng_p) = (
            _grown(problem, index, informed, compiled_loop, max_nodes=nodes, **rule)
            for compiled_loop in (True, False)
        )
        n = tree_c.num_nodes
        assert n == tree_p.num_nodes and n > 16
        np.testing.assert_array_equal(tree_c.positions[:n], tree_p.positions[:n])
        np.testing.assert_array_equal(tree_c.costs[:n], tree_p.costs[:n])
        np.testing.assert_array_equal(tree_c.links[:n], tree_p.links[:n])
        assert (tree_c.samples, tree_c.sampling_failures, tree_c.best_node, tree_c.best_cost) == (
            tree_p.samples, tree_p.sampling_failures, tree_p.best_node, tree_p.best_cost,
        )  # fmt: skip
        assert (log_c.nodes, log_c.costs) == (log_p.nodes, log_p.costs)
        assert rng_c == rng_p  # both drew the same random numbers


def test_compiled_loop_continues_a_tree_with_a_target_cost(problem_2d):
    """The classical phase's case: a tree with a solution, grown on to a target cost."""
    trees = []
    for compiled_loop in (True, False):
        tree, log, rng = Tree(problem_2d), AnytimeLog(), np.random.default_rng(2)
        first = PlanSettings(max_nodes=5000, stop_at_first=True)
        grow_anytime(tree, first, rng, log, informed=True, compiled_loop=compiled_loop)
        target = PlanSettings(max_nodes=5000, target_cost=0.9 * tree.best_cost)
        grow_anytime(tree, target, rng, log, informed=True, compiled_loop=compiled_loop)
        trees.append((tree.num_nodes, tree.best_cost, log.nodes, log.costs, rng.random()))
    assert trees[0] == trees[1]
    assert len(trees[0][2]) >= 2


def test_compiled_loop_cannot_be_forced_on_a_checker_without_a_compiled_path(problem_2d):
    from temp_gym.worlds.checkers import make_checker

    class PythonOnly(type(make_checker(problem_2d))):
        def compiled_context(self):
            return None  # the contract's "no compiled path"

    workspace = problem_2d.workspace
    checker = PythonOnly(workspace.bounds, workspace.obstacle_lower, workspace.obstacle_upper)
    tree = Tree(problem_2d, checker=checker)
    settings = PlanSettings(max_nodes=50)
    with pytest.raises(ValueError, match="compiled path"):
        grow_anytime(tree, settings, np.random.default_rng(0), AnytimeLog(), True, True)
    grow_anytime(tree, settings, np.random.default_rng(0), AnytimeLog(), True)  # Python loop
    assert tree.num_nodes == 50


def test_compiled_slices_shrink_as_the_deadline_nears():
    from temp_gym.planning._compiled_tree import (
        ASSUMED_FIRST_PACE,
        FIRST_TIMED_SLICE,
        SLICE,
        slice_length,
    )

    assert slice_length(math.inf, 0.0, 0.0) == SLICE  # no time limit: whole slices
    assert slice_length(math.inf, 0.0, 1e-3) == SLICE
    # Pace unknown yet: half the time left at an assumed slow pace, at least FIRST_TIMED_SLICE.
    assert slice_length(0.1, 0.0, 0.0) == FIRST_TIMED_SLICE
    assert slice_length(10.0, 0.0, 0.0) == int(10.0 / ASSUMED_FIRST_PACE / 2)
    assert slice_length(1000.0, 999.9, 0.0) == FIRST_TIMED_SLICE  # the time left, not the limit
    assert slice_length(60.0, 0.0, 0.0) == SLICE
    assert slice_length(10.0, 0.0, 1e-6) == SLICE  # far from the deadline
    # 10 ms left at 100 us per iteration: half of them, 50.
    assert slice_length(1.0, 0.99, 1e-4) == 50
    assert slice_length(1.0, 0.99999, 1e-4) == 1  # at least one iteration
    assert slice_length(1.0, 1.5, 1e-4) == 1  # past the deadline (the caller stops)


def test_compiled_loop_stops_at_the_improvement_that_meets_the_stop_rule(problem_2d, monkeypatch):
    from temp_gym.planning import _compiled_anytime as compiled

    statuses = []
    slice_ = compiled.anytime_slice

    def recorded(*args):
        statuses.append(slice_(*args))
        return statuses[-1]

    monkeypatch.setattr(compiled, "anytime_slice", recorded)
    tree = _grown(problem_2d, 0, True, True, max_nodes=10_000, stop_at_first=True)[0]
    assert tree.best_node >= 0
    assert statuses[-1] == compiled.IMPROVED  # no further slice only to learn it is done


def test_derived_settings_equal_a_checked_replace_without_the_checks():
    import dataclasses

    settings = PlanSettings(seed=3, max_nodes=500, time_limit=2.0, target_cost=9.5)
    changes = {"max_nodes": 40, "max_samples": 700, "stop_at_first": True, "target_cost": None}
    derived = settings.derived(**changes)
    assert derived == dataclasses.replace(settings, **changes)
    assert derived.sample_limit == 700 and settings.max_nodes == 500  # the original stays
    assert settings.derived(max_nodes=10).sample_limit == 1000
    with pytest.raises(TypeError, match="unknown settings"):
        settings.derived(max_node=10)


@pytest.mark.parametrize("planner", ["rrt_star", "informed_rrt_star"])
def test_an_improvement_found_in_a_slice_that_ends_past_the_deadline_is_logged(
    planner, monkeypatch
):
    # A slice sized by the pace so far can overrun the deadline when the process is preempted;
    # its improvement used to be dropped: success with no first solution and no history.
    import time

    from temp_gym import Problem
    from temp_gym.planning import _compiled_anytime

    problem = Problem.from_dict(
        {"robot": "point2d", "bounds": [[0, 0], [20, 20]], "start": [2, 2], "goal": [18, 18],
         "goal_radius": 0.5, "obstacles": [{"center": [10, 10], "half_extents": [2, 2]}]}
    )  # fmt: skip
    plan(problem, planner=planner, max_nodes=50)  # compiled and warm before the clock runs
    real = _compiled_anytime.anytime_slice
    limit = 0.2

    def preempted(*args):
        status = real(*args)
        if status == _compiled_anytime.IMPROVED:
            time.sleep(limit)  # the slice that found it ends past the deadline
        return status

    monkeypatch.setattr(_compiled_anytime, "anytime_slice", preempted)
    result = plan(problem, planner=planner, seed=3, time_limit=limit, max_nodes=100_000)
    assert result.success
    assert result.time_to_first_solution is not None and result.nodes_to_first_solution
    assert len(result.history["best_cost"]) >= 1
    assert result.history["best_cost"][-1] == pytest.approx(result.cost)


@pytest.mark.parametrize("planner", ["rrt_star", "informed_rrt_star", "temp"])
def test_a_start_in_the_goal_region_stops_at_once(planner):
    # Cost 0 cannot improve: the planners spent their whole budget (OMPL's stop at once).
    from temp_gym import Problem

    problem = Problem.from_dict(
        {"robot": "point2d", "bounds": [[0, 0], [20, 20]], "start": [2, 2], "goal": [2.2, 2],
         "goal_radius": 0.5, "obstacles": [{"center": [10, 10], "half_extents": [2, 2]}]}
    )  # fmt: skip
    result = plan(problem, planner=planner, max_nodes=3000)
    assert result.success and result.cost == 0.0 and result.nodes == 1
    # A target below 0 is the caller's to set: no solution meets it, and the budget runs out.
    assert plan(problem, planner=planner, max_nodes=300, target_cost=-1.0).nodes == 300
