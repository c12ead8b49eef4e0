"""Assertions on a grown `Tree` that several test modules share.

A module of its own rather than ``conftest``: ``from conftest import ...`` resolves to whichever
``conftest`` module pytest imported first, which is another directory's when several test
directories run together.
"""

import numpy as np


def assert_is_tree(tree) -> None:
    """Parent links, child lists, costs and edges are consistent with one rooted tree."""
    n = tree.num_nodes
    parents = tree.parents
    assert parents[0] == -1
    assert np.all((parents[1:] >= 0) & (parents[1:] < n))
    # every node reaches the root in fewer than n steps (no cycles)
    for node in range(n):
        steps, current = 0, node
        while current != 0:
            current = parents[current]
            steps += 1
            assert steps < n
    # the child lists hold exactly the nodes whose parent link points back
    links = tree.links
    seen = np.zeros(n, dtype=int)
    for node in range(n):
        child = links[node, 1]
        while child != -1:
            assert parents[child] == node
            seen[child] += 1
            child = links[child, 2]
    assert seen[0] == 0 and np.all(seen[1:] == 1)
    # a node's cost is the sum of its edge lengths along its root path
    pos = tree.positions[:n]
    edge = np.linalg.norm(pos[1:] - pos[parents[1:]], axis=1)
    expected = np.zeros(n)
    for node in range(1, n):
        path = tree.path_indices(node)
        expected[node] = np.sum(np.linalg.norm(np.diff(pos[path], axis=0), axis=1))
    np.testing.assert_allclose(tree.costs[:n], expected, rtol=0, atol=1e-9)
    if tree.neighbourhood == "radius":  # edges come from steering or from the near radius
        assert np.all(edge <= max(tree.step_size, tree.max_radius) + 1e-9)
    assert np.all(tree.checker.edges_free(pos[parents[1:]], pos[1:]))
