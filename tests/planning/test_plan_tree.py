import numpy as np
import pytest

from temp_gym import plan
from temp_gym.problem import Problem


@pytest.mark.parametrize("planner", ["rrt_star", "informed_rrt_star", "temp"])
def test_a_result_carries_its_planner_tree(wall, planner):
    problem = Problem.from_dict(wall)
    result = plan(problem, planner=planner, seed=2, max_nodes=300)
    tree = result.tree
    assert tree is not None and len(tree.positions) == len(tree.parents)
    assert len(tree.positions) <= result.nodes  # temp counts its goal tree's nodes too
    np.testing.assert_array_equal(tree.positions[0], problem.start)
    assert tree.parents[0] == -1 and np.all(tree.parents[1:] >= 0)
    depth = np.zeros(len(tree.parents), dtype=int)  # every node reaches the root: a tree
    node = np.arange(len(tree.parents))
    for _ in range(len(tree.parents)):
        moving = node > 0
        node[moving] = tree.parents[node[moving]]
        depth += moving
    assert np.all(node == 0)
    assert not tree.positions.flags.writeable and not tree.parents.flags.writeable
    # The path's states are tree nodes (the path is the tree's branch to a goal node).
    if result.success and planner != "temp":
        for state in result.path:
            assert np.any(np.all(tree.positions == state, axis=1))
    assert "tree" not in result.to_dict() and "tree=" not in repr(result)
