"""`Tree.extend(action, normalized=True)`: the env's extension, denormalized in the core."""

import numpy as np
import pytest
from tree_checks import assert_is_tree

from temp_gym.planning import Tree, UniformSampler
from temp_gym.worlds.normalization import denormalize


def grow_both(problem, actions):
    by_action, by_sample = Tree(problem), Tree(problem)
    for action in actions:
        a = by_action.extend(action, normalized=True)
        b = by_sample.extend(denormalize(np.clip(action, -1.0, 1.0), problem.bounds))
        assert a == b
    return by_action, by_sample


@pytest.mark.parametrize("fixture", ["problem_2d", "problem_3d"])
def test_normalized_extension_grows_the_denormalized_tree(fixture, request):
    problem = request.getfixturevalue(fixture)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1.3, 1.3, size=(600, problem.dim))  # some out of range: clipped
    by_action, by_sample = grow_both(problem, actions)
    n = by_sample.num_nodes
    assert by_action.num_nodes == n and by_action.samples == by_sample.samples == 600
    assert by_action.sampling_failures == by_sample.sampling_failures > 0
    np.testing.assert_array_equal(by_action.positions[:n], by_sample.positions[:n])
    np.testing.assert_array_equal(by_action.links[:n], by_sample.links[:n])
    np.testing.assert_array_equal(by_action.costs[:n], by_sample.costs[:n])
    assert_is_tree(by_action)


def test_float32_and_list_actions_are_the_same_action(problem_2d):
    actions = np.random.default_rng(1).uniform(-1, 1, size=(50, 2)).astype(np.float32)
    trees = [Tree(problem_2d) for _ in range(3)]
    for action in actions:
        results = [
            trees[0].extend(action, normalized=True),
            trees[1].extend(action.astype(np.float64), normalized=True),
            trees[2].extend(action.tolist(), normalized=True),
        ]
        assert results[0] == results[1] == results[2]
    n = trees[0].num_nodes
    for tree in trees[1:]:
        np.testing.assert_array_equal(tree.positions[:n], trees[0].positions[:n])


def test_bad_action_raises_and_leaves_the_tree_unchanged(problem_2d):
    tree = Tree(problem_2d)
    tree.extend(np.array([0.1, 0.2]), normalized=True)
    state = (tree.num_nodes, tree.samples, tree.sampling_failures, tree.collision_checks)
    positions = tree.positions[: tree.num_nodes].copy()
    for bad in ([np.nan, 0.0], [0.0, np.inf], [-np.inf, 0.5]):
        with pytest.raises(ValueError, match="action: must be finite"):
            tree.extend(np.array(bad), normalized=True)
    with pytest.raises(ValueError, match=r"action: expected shape \(2,\)"):
        tree.extend(np.zeros(3), normalized=True)
    sampler, rng = UniformSampler(problem_2d.bounds), np.random.default_rng(0)
    with pytest.raises(ValueError, match="finite"):
        tree.extend_with_fallback(np.array([np.nan, 0.0]), sampler, rng, normalized=True)
    assert (tree.num_nodes, tree.samples, tree.sampling_failures, tree.collision_checks) == state
    np.testing.assert_array_equal(tree.positions[: tree.num_nodes], positions)


def test_fallback_retries_after_a_normalized_action(problem_2d):
    tree = Tree(problem_2d, step_size=30.0)
    sampler, rng = UniformSampler(problem_2d.bounds), np.random.default_rng(0)
    wall = np.array([0.8, 0.0])  # (18, 10): the straight edge from the start hits the wall
    result = tree.extend_with_fallback(wall, sampler, rng, normalized=True)
    assert result.node == 1 and result.failures >= 1
    assert result.samples == result.failures + 1 == tree.samples
