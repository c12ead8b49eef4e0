import time
from pathlib import Path

import numpy as np
import pytest

from temp_gym.planning import PLANNERS, RRTConnectSettings, plan
from temp_gym.planning.result import AnytimeLog
from temp_gym.planning.rrt_connect import connect_trees
from temp_gym.planning.settings import PlanSettings
from temp_gym.planning.tree import Tree, default_step_size
from temp_gym.problem import Problem
from temp_gym.worlds.checkers import certify_path

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def load(request: pytest.FixtureRequest, name: str) -> Problem:
    """A problem of ``examples/`` (a file name) or of a fixture (its name)."""
    if name.endswith(".json"):
        return Problem.load(EXAMPLES / name)
    return request.getfixturevalue(name)


def assert_solves(problem: Problem, result, max_nodes: int) -> None:
    assert result.success and result.planner == "rrt_connect"
    assert certify_path(problem, result.path)
    np.testing.assert_array_equal(result.path[0], problem.start)
    assert np.linalg.norm(result.path[-1] - problem.goal) <= problem.goal_radius
    lengths = np.linalg.norm(np.diff(result.path, axis=0), axis=1)
    assert result.cost == pytest.approx(lengths.sum())
    assert 2 < result.nodes <= max_nodes
    # not anytime: one solution, the first, found with every node the run grew
    assert result.history["nodes"].tolist() == [result.nodes] == [result.nodes_to_first_solution]
    assert result.history["best_cost"].tolist() == [result.cost]


@pytest.mark.parametrize(
    "name", ["problem_2d", "problem_3d", "point2d.json", "point3d.json", "kuka_iiwa14.json"]
)
def test_solves_point_and_arm_problems_with_certified_paths(request, name):
    problem = load(request, name)
    for seed, query in enumerate((problem, problem.swapped())):
        result = plan(query, planner="rrt_connect", seed=seed, max_nodes=3000)
        assert_solves(query, result, 3000)


def test_solves_the_fixtures_with_edges_no_longer_than_the_range(problem_2d, problem_3d):
    for problem in (problem_2d, problem_3d):
        result = plan(problem, planner="rrt_connect", seed=0, max_nodes=3000)
        assert_solves(problem, result, 3000)
        lengths = np.linalg.norm(np.diff(result.path, axis=0), axis=1)
        assert lengths.max() <= default_step_size(problem) * (1 + 1e-12)
    short = plan(problem_2d, settings=RRTConnectSettings(seed=0, max_nodes=5000, range=0.4))
    assert_solves(problem_2d, short, 5000)
    assert np.linalg.norm(np.diff(short.path, axis=0), axis=1).max() <= 0.4 * (1 + 1e-12)
    # range wins over step_size, which stands in when range is None
    stepped = plan(problem_2d, "rrt_connect", seed=0, max_nodes=5000, step_size=0.4)
    np.testing.assert_array_equal(stepped.path, short.path)


def test_same_seed_same_result_and_another_seed_another(problem_2d):
    first, again, other = (
        plan(problem_2d, "rrt_connect", seed=seed, max_nodes=3000) for seed in (4, 4, 5)
    )
    np.testing.assert_array_equal(first.path, again.path)
    figures = ("nodes", "samples", "sampling_failures", "collision_checks", "cost")
    assert [getattr(first, name) for name in figures] == [getattr(again, name) for name in figures]
    np.testing.assert_array_equal(first.tree.positions, again.tree.positions)
    assert first.cost != other.cost


def grown(problem: Problem, seed: int, compiled_loop: bool, **settings):
    """Both trees after `connect_trees`, its outcome and the generator's next number."""
    tree = Tree(problem, capacity=2)  # the arrays grow on the way
    goal_tree = Tree(problem.swapped(), capacity=2)
    goal_tree.checker = tree.checker
    rng = np.random.default_rng(seed)
    outcome = connect_trees(
        tree, goal_tree, PlanSettings(**settings), rng, AnytimeLog().started, compiled_loop
    )
    return tree, goal_tree, outcome, rng.random()


@pytest.mark.parametrize(
    "name", ["problem_2d", "problem_3d", "enclosed_goal_2d", "kuka_iiwa14.json"]
)
def test_compiled_loop_grows_the_python_loops_trees(request, name):
    """Node for node, the same two trees, outcome and generator state; arrays grown on the way."""
    problem = load(request, name)
    budgets = [{"max_nodes": 3000}, {"max_nodes": 3000, "max_samples": 40}, {"max_nodes": 25}]
    for index, budget in enumerate(budgets):
        compiled, python = (grown(problem, index, loop, **budget) for loop in (True, False))
        assert compiled[2:] == python[2:]
        for ours, theirs in zip(compiled[:2], python[:2]):
            n = ours.num_nodes
            assert n == theirs.num_nodes
            np.testing.assert_array_equal(ours.positions[:n], theirs.positions[:n])
            np.testing.assert_array_equal(ours.links[:n], theirs.links[:n])
            assert (ours.samples, ours.sampling_failures, ours.collision_checks) == (
                theirs.samples, theirs.sampling_failures, theirs.collision_checks,
            )  # fmt: skip
        assert min(compiled[0].num_nodes, compiled[1].num_nodes) > 2  # both trees grew
        (status, link) = compiled[2]
        if link is not None:  # joined at one state, bit for bit
            np.testing.assert_array_equal(
                compiled[0].positions[link[0]], compiled[1].positions[link[1]]
            )


@pytest.mark.parametrize("max_nodes", [1, 2, 30, 31])
def test_the_node_budget_counts_both_trees(problem_2d, max_nodes):
    result = plan(problem_2d, "rrt_connect", seed=0, max_nodes=max_nodes)
    assert not result.success and result.path is None
    assert result.nodes == max_nodes  # a CONNECT stops at the budget too
    assert result.tree.positions.shape[0] < max_nodes or max_nodes == 1


def test_a_goal_enclosed_in_boxes_ends_without_a_path_within_the_budget(enclosed_goal_2d):
    problem = enclosed_goal_2d
    result = plan(problem, "rrt_connect", seed=0, max_nodes=3000)
    assert not result.success and result.path is None and result.cost == np.inf
    assert result.nodes == 3000 and result.nodes_to_first_solution is None
    assert result.history["nodes"].size == 0
    few = plan(problem, "rrt_connect", seed=0, max_nodes=3000, max_samples=500)
    assert not few.success and few.samples == 500 and few.nodes < 3000


def test_the_time_limit_is_honoured(enclosed_goal_2d):
    problem = enclosed_goal_2d
    plan(problem, "rrt_connect", seed=0, max_nodes=50)  # compiled before the clock starts
    none = plan(problem, "rrt_connect", seed=0, time_limit=0.0)
    assert not none.success and none.nodes == 2 and none.samples == 0
    began = time.perf_counter()
    result = plan(problem, "rrt_connect", seed=0, max_nodes=10**9, time_limit=0.25)
    assert time.perf_counter() - began < 2.0 and 0.25 <= result.wall_time < 1.0
    assert not result.success and 1000 < result.nodes < 10**9


def test_a_start_in_the_goal_region_is_a_solution_of_cost_zero(empty_2d):
    problem = empty_2d.replace(goal=[1.2, 1.2])
    result = plan(problem, "rrt_connect", seed=0)
    assert result.success and result.cost == 0.0 and result.nodes == 1
    np.testing.assert_array_equal(result.path, [problem.start, problem.start])


def test_registered_with_its_own_settings_class(problem_2d):
    entry = PLANNERS["rrt_connect"]
    assert entry.settings is RRTConnectSettings
    result = plan(problem_2d, settings=RRTConnectSettings(seed=1, max_nodes=3000))
    assert result.planner == "rrt_connect" and result.success


@pytest.mark.parametrize(
    ("call", "message"),
    [
        ({"range": 0.0}, "range: expected a positive number or None, got 0.0"),
        ({"range": float("nan")}, "range: expected a positive number or None, got nan"),
        ({"range": True}, "range: expected a positive number or None, got True"),
        ({"max_nodes": 0}, "max_nodes: expected an integer in [1, 2**53], got 0"),
        ({"attention_patience": 3}, "attention_patience: only the temp planner takes it, not "
         "rrt_connect"),
        ({"k_nearest": True}, "k_nearest: only the "),
        ({"rang": 1.0}, "rang: not a setting of the rrt_connect planner (did you mean range?)"),
    ],
)  # fmt: skip
def test_bad_settings_are_one_line_naming_the_field(problem_2d, call, message):
    with pytest.raises(ValueError) as error:
        plan(problem_2d, "rrt_connect", **call)
    assert str(error.value).startswith(message) and "\n" not in str(error.value)


def test_ompls_rrt_connect_refuses_a_budget_below_its_two_roots():
    # OMPL makes both roots first: with max_nodes=1 it returned 2 nodes, over the budget (ours
    # stops at its start's root, `test_the_node_budget_counts_both_trees`).
    problem = Problem.from_dict(
        {"robot": "point2d", "bounds": [[0, 0], [20, 20]], "start": [2, 2], "goal": [12, 2],
         "goal_radius": 0.5, "obstacles": []}
    )  # fmt: skip
    with pytest.raises(ValueError, match=r"^max_nodes: at least 2 for OMPL's RRTConnect"):
        plan(problem, planner="ompl_rrt_connect", max_nodes=1)
    with pytest.raises(ValueError, match=r"^max_nodes: at least 2"):
        plan(problem, planner="ompl_rrt_connect", settings=PlanSettings(max_nodes=1))
    assert plan(problem, planner="ompl_rrt_connect", max_nodes=2).nodes == 2
    assert plan(problem, planner="rrt_connect", max_nodes=1).nodes == 1
