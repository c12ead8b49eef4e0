import math

import numpy as np
import pytest
from tree_checks import assert_is_tree

from temp_gym.planning import GoalBiasedSampler, Tree, UniformSampler


def test_rewiring_lowers_costs_and_descendants_follow(empty_2d):
    tree = Tree(empty_2d, step_size=10.0, max_radius=3.0)
    a = tree.extend(np.array([3.0, 2.0])).node
    b = tree.extend(np.array([1.5, 4.0])).node
    d = tree.extend(np.array([1.5, 6.5])).node
    assert tree.parents[b] == a and tree.parents[d] == b
    cost_b, cost_d = tree.costs[b], tree.costs[d]
    result = tree.extend(np.array([1.2, 2.6]))
    c = result.node
    assert tree.parents[c] == 0  # chose the root over the nearest node b
    assert result.rewired >= 1
    assert tree.parents[b] == c  # b was rewired through c
    assert tree.costs[b] < cost_b - 1.0
    expected_b = tree.costs[c] + math.dist((1.2, 2.6), (1.5, 4.0))
    assert tree.costs[b] == pytest.approx(expected_b, abs=1e-12)
    # the descendant's cost followed by the same amount
    assert tree.costs[d] == pytest.approx(cost_d - (cost_b - tree.costs[b]), abs=1e-12)
    assert_is_tree(tree)


def test_rewiring_updates_best_solution(empty_2d):
    tree = Tree(empty_2d, step_size=30.0, max_radius=3.0)
    # a detour into the goal region, then a shortcut that must be rewired in
    tree.extend(np.array([1.0, 3.5]))
    tree.extend(np.array([1.0, 6.0]))
    assert tree.best_node == -1
    for y in np.arange(8.5, 20.0, 2.5):
        tree.extend(np.array([1.0, y]))
    for x in np.arange(3.5, 19.0, 2.5):
        tree.extend(np.array([x, 19.0]))
    tree.extend(np.array([19.0, 19.0]))
    assert tree.best_node >= 0 and tree.in_goal(tree.positions[tree.best_node])
    detour = tree.best_cost
    chain = [np.array([1.0 + k * 1.9, 1.0 + k * 1.9]) for k in range(1, 10)]
    improved = [tree.extend(x).improved for x in chain]
    assert any(improved)
    assert tree.best_cost < detour - 5.0
    np.testing.assert_allclose(
        tree.best_cost, np.sum(np.linalg.norm(np.diff(tree.best_path(), axis=0), axis=1))
    )
    assert_is_tree(tree)


@pytest.mark.parametrize("neighbourhood", ["radius", "k_nearest"])
def test_tree_stays_a_tree_after_many_extensions(problem_3d, neighbourhood):
    tree = Tree(problem_3d, neighbourhood=neighbourhood, capacity=16)  # forces doubling
    rng = np.random.default_rng(3)
    sampler = GoalBiasedSampler(UniformSampler(problem_3d.bounds), problem_3d.goal, 0.05)
    for _ in range(1500):
        tree.extend(sampler.sample(rng))
    assert tree.num_nodes > 1000 and tree.capacity >= tree.num_nodes
    assert_is_tree(tree)
    assert tree.best_node >= 0
    assert tree.in_goal(tree.positions[tree.best_node])
    best = min(tree.costs[g] for g in tree.goal_nodes)
    assert tree.best_cost == best


def test_counters_and_results(problem_2d):
    tree = Tree(problem_2d)
    # a sample straight through the wall collides and leaves the tree unchanged
    result = tree.extend(np.array([10.0, 3.5]))
    wall = tree.extend(np.array([9.0, 10.0]))
    assert wall.node == -1 or result.node >= 0
    n = tree.num_nodes
    blocked = Tree(problem_2d, step_size=30.0).extend(np.array([18.0, 10.0]))
    assert blocked.node == -1 and blocked.collided and blocked.failures == 1
    assert blocked.collision_checks == 1
    assert tree.samples == 2 and tree.num_nodes == n
    np.testing.assert_array_equal(tree.path_so_far()[0], problem_2d.start)
    np.testing.assert_array_equal(tree.path_so_far()[-1], tree.positions[tree.newest])


def test_extend_with_fallback_retries_until_a_node_is_added(problem_2d):
    tree = Tree(problem_2d, step_size=30.0)
    rng = np.random.default_rng(0)
    sampler = UniformSampler(problem_2d.bounds)
    result = tree.extend_with_fallback(np.array([18.0, 10.0]), sampler, rng)
    assert result.node == 1
    assert result.failures >= 1 and result.samples == result.failures + 1
    assert tree.sampling_failures == result.failures
    assert tree.samples == result.samples
    # bounded: a walled-in retry budget of zero gives up after the first sample
    again = tree.extend_with_fallback(np.array([18.0, 10.0]), sampler, rng, max_tries=0)
    assert again.samples == 1


def test_bad_arguments(problem_2d):
    with pytest.raises(ValueError, match="neighbourhood"):
        Tree(problem_2d, neighbourhood="grid")
    with pytest.raises(ValueError, match="step_size"):
        Tree(problem_2d, step_size=0.0)
    with pytest.raises(ValueError, match="sample"):
        Tree(problem_2d).extend(np.zeros(3))


def _count_calls(monkeypatch, name):
    """Empty the tree module's free-volume caches; count calls of its function ``name``."""
    from temp_gym.planning import tree as tree_module

    for cache in ("_FREE_VOLUME_CACHE", "_FREE_VOLUME_FLOOR_CACHE"):
        monkeypatch.setattr(tree_module, cache, type(getattr(tree_module, cache))())
    calls = []
    compute = getattr(tree_module, name)

    def counting(problem, checker):
        calls.append(problem)
        return compute(problem, checker)

    monkeypatch.setattr(tree_module, name, counting)
    return calls


def test_free_volume_is_estimated_once_per_workspace(problem_2d, monkeypatch):
    from dataclasses import replace

    from temp_gym.problem import Workspace
    from temp_gym.worlds.checkers import make_checker

    calls = _count_calls(monkeypatch, "estimate_free_volume")
    first = Tree(problem_2d)
    assert first.gamma > 0 and len(calls) == 1
    other_query = replace(problem_2d, start=problem_2d.goal, goal=problem_2d.start)
    assert Tree(other_query).gamma == first.gamma and len(calls) == 1  # same workspace
    space = problem_2d.workspace
    empty = Workspace(
        space.robot, space.bounds, space.obstacle_centers[:0], space.obstacle_half_extents[:0]
    )
    no_boxes = replace(problem_2d, workspace=empty)
    assert Tree(no_boxes).gamma > first.gamma and len(calls) == 2  # more free space
    Tree(problem_2d, checker=make_checker(problem_2d))  # a caller's checker: not cached
    assert len(calls) == 3


def test_the_free_volume_floor_is_computed_once_per_workspace(problem_2d, monkeypatch):
    from dataclasses import replace

    calls = _count_calls(monkeypatch, "free_volume_floor")
    first = Tree(problem_2d)
    other_query = replace(problem_2d, start=problem_2d.goal, goal=problem_2d.start)
    second = Tree(other_query)
    assert len(calls) == 1 and first._gamma_floor == second._gamma_floor is not None
    assert first._gamma_in_use == second._gamma_in_use


def test_a_tree_from_the_goal_shares_the_checker_and_grows_as_one_with_its_own(
    problem_2d, monkeypatch
):
    from dataclasses import replace

    from temp_gym.planning import tree as tree_module
    from temp_gym.problem import Workspace

    made, make = [], tree_module.make_checker
    monkeypatch.setattr(tree_module, "make_checker", lambda p: made.append(p) or make(p))
    first = Tree(problem_2d)
    shared = Tree(problem_2d.swapped(), checker_of=first)
    assert shared.checker is first.checker and len(made) == 1
    own = Tree(problem_2d.swapped())
    assert len(made) == 2 and own.checker is not first.checker
    for tree in (shared, own):
        sampler = UniformSampler(problem_2d.bounds)
        rng = np.random.default_rng(4)
        for _ in range(300):
            tree.extend(sampler.sample(rng))
    n = own.num_nodes
    assert shared.num_nodes == n > 100 and shared._gamma_in_use == own._gamma_in_use
    np.testing.assert_array_equal(shared.positions[:n], own.positions[:n])
    np.testing.assert_array_equal(shared.links[:n], own.links[:n])
    space = problem_2d.workspace
    empty = Workspace(
        space.robot, space.bounds, space.obstacle_centers[:0], space.obstacle_half_extents[:0]
    )
    with pytest.raises(ValueError, match="checker_of: expected a tree on this problem's"):
        Tree(replace(problem_2d, workspace=empty), checker_of=first)
    with pytest.raises(ValueError, match="checker_of: .* and no checker"):
        Tree(problem_2d, checker=first.checker, checker_of=first)


def test_a_forgotten_workspace_pays_its_set_up_again_and_gets_the_same_tree(
    problem_2d, monkeypatch
):
    from temp_gym.planning.tree import forget_workspace

    floors = _count_calls(monkeypatch, "free_volume_floor")
    first = Tree(problem_2d)
    Tree(problem_2d)
    assert len(floors) == 1  # remembered
    forget_workspace(problem_2d.workspace)
    again = Tree(problem_2d)
    assert len(floors) == 2  # paid again, as on a new workspace
    assert again.gamma == first.gamma
    forget_workspace(problem_2d.workspace)
    forget_workspace(problem_2d.workspace)  # forgetting what is not remembered is no error


@pytest.mark.parametrize("robot", ["point2d", "point3d", "kuka_iiwa14"])
def test_the_exact_free_volume_waits_until_it_can_change_a_radius(robot, monkeypatch):
    """A tree on the volume's lower bound grows as the tree on the exact volume, node for node."""
    from temp_gym.planning import tree as tree_module
    from temp_gym.worlds.checkers import make_checker
    from temp_gym.worlds.generators import generate_problem

    problem = generate_problem(robot, np.random.default_rng(2), "challenging")
    monkeypatch.setattr(tree_module, "_FREE_VOLUME_CACHE", type(tree_module._FREE_VOLUME_CACHE)())
    lazy = Tree(problem, capacity=64)
    eager = Tree(problem, checker=make_checker(problem), capacity=64)  # exact from the start
    assert lazy._gamma is None and eager._gamma is not None
    sampler = UniformSampler(problem.bounds)
    rng_lazy, rng_eager = np.random.default_rng(5), np.random.default_rng(5)
    below_cap = set()
    nodes = {"point2d": 6000, "point3d": 3000, "kuka_iiwa14": 1500}[robot]
    while lazy.num_nodes < nodes:
        lazy.extend_with_fallback(sampler.sample(rng_lazy), sampler, rng_lazy, 1000)
        eager.extend_with_fallback(sampler.sample(rng_eager), sampler, rng_eager, 1000)
        below_cap.add(eager.near_radius() < eager.max_radius)
    n = lazy.num_nodes
    assert n == eager.num_nodes
    np.testing.assert_array_equal(lazy.positions[:n], eager.positions[:n])
    np.testing.assert_array_equal(lazy.links[:n], eager.links[:n])
    np.testing.assert_array_equal(lazy.costs[:n], eager.costs[:n])
    if robot == "point2d":  # past the point where the cap binds: the exact volume was needed
        assert True in below_cap and lazy._gamma == eager.gamma
    else:  # the cap binds throughout: the exact volume was never computed
        assert below_cap == {False} and lazy._gamma is None
        assert len(tree_module._FREE_VOLUME_CACHE) == 0


def test_a_checker_without_a_floor_of_its_own_gets_the_sliver(problem_2d):
    """The iiwa's checker measures no free volume; its floor is the least estimate there is."""
    from temp_gym.planning import tree as tree_module
    from temp_gym.worlds.checkers import make_checker
    from temp_gym.worlds.generators import generate_problem

    problem = generate_problem("kuka_iiwa14", np.random.default_rng(4), "easy")
    checker = make_checker(problem)
    assert not hasattr(checker, "free_volume_floor")
    low, high = problem.bounds
    sliver = float(np.prod(high - low)) / tree_module._FREE_VOLUME_SAMPLES
    floor = tree_module.free_volume_floor(problem, checker)
    assert floor == pytest.approx(sliver)
    assert floor <= tree_module.estimate_free_volume(problem, checker)
    point = make_checker(problem_2d)  # a floor of its own: at most its exact volume
    assert tree_module.free_volume_floor(problem_2d, point) <= point.free_volume()


@pytest.mark.parametrize("robot", ["point2d", "point3d"])
@pytest.mark.parametrize("planner", ["rrt_star", "informed_rrt_star", "temp"])
def test_the_grid_grows_the_scans_trees(monkeypatch, robot, planner):
    """Nearest and near queries through the grid (`temp_gym.planning._grid`) give every
    planner the tree it grows by scanning, node for node, compiled loops and Python alike."""
    from temp_gym import plan
    from temp_gym.planning import _grid
    from temp_gym.worlds.generators import generate_problem

    problem = generate_problem(robot, np.random.default_rng(21), "challenging")
    results = []
    for min_nodes in (0, 10**9):  # every query through the grid; none
        monkeypatch.setattr(_grid, "GRID_MIN_NODES", min_nodes)
        results.append(plan(problem, planner=planner, seed=3, max_nodes=1500))
        tree = Tree(problem, capacity=16)  # the Python extension, growing its arrays
        rng = np.random.default_rng(4)
        for _ in range(700):
            tree.extend(rng.uniform(problem.bounds[0] - 1.0, problem.bounds[1] + 1.0))
        results.append(tree)
    with_grid, scanned, grid_tree, scan_tree = results[0], results[2], results[1], results[3]
    assert with_grid.nodes == scanned.nodes == 1500
    assert with_grid.cost == scanned.cost
    for key in ("nodes", "best_cost"):  # the history's times differ, of course
        np.testing.assert_array_equal(with_grid.history[key], scanned.history[key])
    np.testing.assert_array_equal(with_grid.path, scanned.path)
    n = grid_tree.num_nodes
    assert n == scan_tree.num_nodes > 300
    np.testing.assert_array_equal(grid_tree.positions[:n], scan_tree.positions[:n])
    np.testing.assert_array_equal(grid_tree.links[:n], scan_tree.links[:n])
    np.testing.assert_array_equal(grid_tree.costs[:n], scan_tree.costs[:n])


def _robot_problem(robot):
    from temp_gym.evaluation.runner import evaluation_problem

    return evaluation_problem(robot, "any" if robot == "kuka_iiwa14" else "challenging", 0)


@pytest.mark.parametrize(
    "robot, neighbourhood, chunk",
    [
        ("point2d", "radius", 8),
        ("point2d", "radius", 1),
        ("point2d", "k_nearest", 3),
        ("point3d", "radius", 8),
        ("kuka_iiwa14", "radius", 2),
    ],
)
def test_compiled_extend_gives_the_reference_results_and_tree(robot, neighbourhood, chunk):
    """Tree.extend in one compiled call: every ExtendResult, counter and array as the Python
    path that drives the kernels and the checker (compiled_extend=False) gives them."""
    if robot == "kuka_iiwa14":
        pytest.importorskip("pybullet")
    problem = _robot_problem(robot)
    settings = dict(neighbourhood=neighbourhood, parent_check_chunk=chunk, capacity=64)
    compiled = Tree(problem, compiled_extend=True, **settings)
    reference = Tree(problem, compiled_extend=False, **settings)
    rng = np.random.default_rng(7)
    low, high = problem.bounds
    count = 1500
    samples = rng.uniform(low, high, (count, problem.dim))
    samples[::7] = problem.goal  # the goal, over and over: zero-length steps once it is reached
    actions = rng.uniform(-1.2, 1.2, (count, problem.dim))  # normalized, some out of the box
    for index in range(count):
        normalized = index % 3 == 0
        sample = actions[index] if normalized else samples[index]
        assert compiled.extend(sample, normalized) == reference.extend(sample, normalized), index
    for name in ("num_nodes", "num_goal_nodes", "newest", "best_node", "best_cost", "samples",
                 "sampling_failures", "collision_checks"):  # fmt: skip
        assert getattr(compiled, name) == getattr(reference, name), name
    n = compiled.num_nodes
    assert n > 100 and compiled.capacity > 64  # grown on the way
    np.testing.assert_array_equal(compiled.positions[:n], reference.positions[:n])
    np.testing.assert_array_equal(compiled.costs[:n], reference.costs[:n])
    np.testing.assert_array_equal(compiled.links[:n], reference.links[:n])
    assert_is_tree(compiled)
    with pytest.raises(ValueError, match="action: must be finite"):
        compiled.extend(np.full(problem.dim, np.nan), normalized=True)
    assert compiled.num_nodes == n and compiled.samples == reference.samples  # unchanged


def test_compiled_extend_is_checked(problem_2d):
    class PythonOnly:  # a checker of the user's, without a compiled path
        def __init__(self, checker):
            self.checker = checker

        def states_free(self, states):
            return self.checker.states_free(states)

        def edge_free(self, start, end):
            return self.checker.edge_free(start, end)

        def edges_free(self, starts, ends):
            return self.checker.edges_free(starts, ends)

    from temp_gym.worlds.checkers import make_checker

    checker = PythonOnly(make_checker(problem_2d))
    tree = Tree(problem_2d, checker=checker)  # the default: the Python path, silently
    assert tree.extend(np.array([5.0, 5.0])).node == 1
    with pytest.raises(ValueError, match="compiled_extend: the tree's checker"):
        Tree(problem_2d, checker=checker, compiled_extend=True).extend(np.array([5.0, 5.0]))
    with pytest.raises(ValueError, match="compiled_extend: expected"):
        Tree(problem_2d, compiled_extend="yes")
