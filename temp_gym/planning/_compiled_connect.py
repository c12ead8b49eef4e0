"""RRT-Connect's iterations as one compiled loop over two trees: no Python round trip per node.

`temp_gym.planning.rrt_connect` grows a tree from the start and one from the goal. With a checker
that has a compiled path (`temp_gym.worlds.collision.compiled`) it hands the iterations to
`connect_slice`, which returns to Python only when the trees are joined, the start tree reached
the goal region, a stop rule fired, a tree's arrays are full, or the slice ended (the caller
looks at the clock).

One iteration is OMPL's (``RRTConnect::solve``): a uniform sample, one step of the tree whose
turn it is towards it (`grow_towards`: EXTEND), then steps of the other tree towards the new node
until it reaches it or is trapped (CONNECT); the trees then swap roles. The trees are
`temp_gym.planning.tree.Tree` arrays (`Tree.compiled_state`), grown with the tree core's kernels
(nearest, steer, insert) and no rewiring: RRT-Connect is plain RRT on both sides.

The samples are the rows of `temp_gym.planning._compiled_tree.fallback_sample`, which draws what
`temp_gym.planning.samplers.UniformSampler` draws from the same generator, so the Python loop
of `rrt_connect` grows the same trees, node for node (tested).
"""

from __future__ import annotations

import numba

from temp_gym.planning._compiled_tree import (
    BEST_NODE,
    CHECKS,
    FAILURES,
    GOAL_RADIUS_SQ,
    NUM_NODES,
    SAMPLES,
    STEP,
    _count_new_node,
    fallback_sample,
)
from temp_gym.planning._generator import generator_at
from temp_gym.planning._kernels import insert_node, nearest_and_steer
from temp_gym.worlds.collision.compiled import motion_free

TRAPPED, ADVANCED, REACHED = range(3)
"""What one step of a tree towards a state did (OMPL's ``GrowState``): nothing (the motion
collided), a node one range away, or a node at the state itself."""

STATE = ("turn", "connecting", "added")
"""The loop's int64 state, kept between calls: the tree that extends next (0: the start tree,
1: the goal tree), whether a CONNECT is under way (1) and the node it connects to, in the tree
that extended (its state is also in the caller's ``target``)."""
TURN, CONNECTING, ADDED = range(len(STATE))
LIMITS = ("max_nodes", "sample_limit")
"""The int64 stop rules: nodes of both trees together, samples of both together."""
MAX_NODES, SAMPLE_LIMIT = range(len(LIMITS))
LINK = ("start_node", "goal_node")
"""The int64 record of a join: the start tree's node and the goal tree's, at one state."""
START_NODE, GOAL_NODE = range(len(LINK))

RUNNING, DONE, CONNECTED, SOLVED, FULL_START, FULL_GOAL = range(6)
"""Statuses: the slice ended; a stop rule fired; the trees are joined (``link``); the start tree
reached the goal region by itself; the start (goal) tree's arrays are full (grow them and call
again: the loop resumes where it stopped)."""


@numba.njit(cache=True, nogil=True)
def grow_towards(tree, goal, context, target, forward):
    """One step of ``tree`` towards ``target`` (OMPL's ``growTree``): ``(outcome, node)``.

    ``tree`` is ``Tree.compiled_state()``, with room for one more node. From the nearest node,
    a step of at most the tree's step size (its range); within range, the new node is
    ``target`` itself, bit for bit, so that the two trees meet at one state. The motion is
    checked from the nearest node when ``forward`` (the start tree), else towards it (the goal
    tree's motions run towards the goal): always the way the joined path runs. ``node`` is the
    node added (`ADVANCED`, `REACHED`), or the nearest node (`TRAPPED`, or `REACHED` without a
    new node when ``target`` is already a node). ``goal`` is the tree's goal (the start tree's:
    the problem's goal), for its goal-region count.
    """
    arrays, counters, best_cost, params = tree
    positions, costs, links, goal_nodes, near_idx, near_dist, cand_idx, _, new, grid = arrays
    count = counters[NUM_NODES]
    step = params[STEP]
    nearest, distance = nearest_and_steer(positions, count, target, step, new, grid, near_idx)
    if not distance > 0.0:
        return REACHED, nearest
    reached = distance <= step
    if reached:
        for k in range(new.shape[0]):
            new[k] = target[k]
    counters[CHECKS] += 1
    if forward:
        free = motion_free(context, positions[nearest], new)
    else:
        free = motion_free(context, new, positions[nearest])
    if not free:
        return TRAPPED, nearest
    cost, reached_goal, _ = insert_node(
        positions, costs, links, count, new, nearest, goal, params[GOAL_RADIUS_SQ], near_idx,
        near_dist, 0, cand_idx,
    )  # fmt: skip
    _count_new_node(counters, goal_nodes, best_cost, count, cost, reached_goal)
    return (REACHED if reached else ADVANCED), count


@numba.njit(cache=True, nogil=True, inline="always")
def _full(tree) -> bool:
    return tree[1][NUM_NODES] >= tree[0][0].shape[0]


@numba.njit(cache=True, nogil=True, inline="always")
def _extend_counted(tree, goal, context, sample, forward):
    """EXTEND ``tree`` towards ``sample``: ``(node, added)``, counted on the tree's counters."""
    counters = tree[1]
    before = counters[NUM_NODES]
    _, node = grow_towards(tree, goal, context, sample, forward)
    added = counters[NUM_NODES] > before
    counters[SAMPLES] += 1
    if not added:
        counters[FAILURES] += 1
    return node, added


@numba.njit(cache=True, nogil=True)
def connect_slice(
    start_tree, goal_tree, goal, start, bounds, context, rng_address, buffer, cursor, target,
    state, limits, link, max_iterations,
):  # fmt: skip
    """Run up to ``max_iterations`` RRT-Connect iterations; return a status.

    The arguments, in groups:

        start_tree, goal_tree: the two trees (`Tree.compiled_state`), rooted at the start and at
            the goal.
        goal, start: the problem's goal and start, each the other tree's goal.
        bounds: the ``(2, d)`` bounds the samples are drawn in.
        context: the checker's compiled context.
        rng_address, buffer, cursor: the planner's generator (its `_generator.address`) and the
            batch of samples `fallback_sample` serves.
        target, state, limits, link: the state a CONNECT goes towards, the loop's state
            (`STATE`), its stop rules (`LIMITS`) and the record of a join (`LINK`).

    The stop rules are checked before every step that could add a node, so the trees never
    hold more than ``limits[MAX_NODES]`` nodes together.
    """
    rng = generator_at(rng_address)
    starts, goals = start_tree[1], goal_tree[1]
    for _ in range(max_iterations):
        if state[CONNECTING] == 0:
            if starts[NUM_NODES] + goals[NUM_NODES] >= limits[MAX_NODES]:
                return DONE
            if starts[SAMPLES] + goals[SAMPLES] >= limits[SAMPLE_LIMIT]:
                return DONE
            grown = state[TURN]
            if grown == 0 and _full(start_tree):
                return FULL_START
            if grown == 1 and _full(goal_tree):
                return FULL_GOAL
            sample = fallback_sample(rng, bounds[0], bounds[1], buffer, cursor)
            if grown == 0:
                node, added = _extend_counted(start_tree, goal, context, sample, True)
            else:
                node, added = _extend_counted(goal_tree, start, context, sample, False)
            state[TURN] = 1 - grown
            if not added:
                continue
            if starts[BEST_NODE] >= 0:
                return SOLVED
            positions = start_tree[0][0] if grown == 0 else goal_tree[0][0]
            for k in range(target.shape[0]):
                target[k] = positions[node, k]
            state[ADDED] = node
            state[CONNECTING] = 1
        while True:  # CONNECT: the tree that extends next goes towards the new node
            if starts[NUM_NODES] + goals[NUM_NODES] >= limits[MAX_NODES]:
                state[CONNECTING] = 0
                return DONE
            other = state[TURN]
            if other == 0:
                if _full(start_tree):
                    return FULL_START
                outcome, node = grow_towards(start_tree, goal, context, target, True)
            else:
                if _full(goal_tree):
                    return FULL_GOAL
                outcome, node = grow_towards(goal_tree, start, context, target, False)
            if starts[BEST_NODE] >= 0:
                state[CONNECTING] = 0
                return SOLVED
            if outcome == REACHED:
                state[CONNECTING] = 0
                link[START_NODE] = node if other == 0 else state[ADDED]
                link[GOAL_NODE] = state[ADDED] if other == 0 else node
                return CONNECTED
            if outcome == TRAPPED:
                state[CONNECTING] = 0
                break
    return RUNNING


__all__ = ["CONNECTED", "DONE", "FULL_GOAL", "FULL_START", "RUNNING", "SOLVED", "connect_slice"]
