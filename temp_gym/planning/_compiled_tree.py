"""`Tree.extend` and `Tree.extend_with_fallback` as numba functions, for compiled planner loops.

`temp_gym.planning.tree.Tree` drives its kernels from Python and hands collision checks to any
checker; a loop that runs many extensions in compiled code (TEMP's attention phase,
`temp_gym.planning._compiled_attention`) needs the extension itself compiled, with the motion
checks of a checker's compiled path (`temp_gym.worlds.collision.compiled.motion_free`).

These functions take the tree's arrays and counters (`Tree.compiled_state`) and grow the same
tree, node for node, as the Python methods given the same samples: the same kernels decide
nearest, steer, near set, parent candidates, insertion and rewiring (tests compare whole trees).
One difference, by design: the parent candidates are checked one at a time up to the first free
one, where `Tree.extend` checks them in chunks, so ``collision_checks`` counts fewer checks for
the same tree.

Counters (`COUNTERS`) live in one int64 array and the best cost in a float64 array of one, so
the Python `Tree` reads them back after a compiled run (`Tree.load_compiled_state`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from temp_gym.planning._kernels import (
    PARENT,
    action_nearest_and_steer,
    apply_rewires,
    insert_node,
    near_and_parent_candidates,
    nearest,
    nearest_and_steer,
)
from temp_gym.worlds.collision.compiled import motion_free

COUNTERS = ("num_nodes", "num_goal_nodes", "newest", "best_node", "samples", "failures", "checks")
"""The tree's counters, in the order of the int64 array compiled code updates."""
NUM_NODES, NUM_GOAL, NEWEST, BEST_NODE, SAMPLES, FAILURES, CHECKS = range(len(COUNTERS))
PARAMETERS = ("step_size", "gamma", "max_radius", "goal_radius_sq", "k_nearest")
"""The tree's settings, in the order of the float64 array (``k_nearest``: 1.0 or 0.0)."""
STEP, GAMMA, MAX_RADIUS, GOAL_RADIUS_SQ, K_NEAREST = range(len(PARAMETERS))

FALLBACK_BATCH = 128
"""Uniform fallback samples drawn per batch, as `temp_gym.planning.samplers.UniformSampler`."""

SLICE = 256
"""Most iterations a compiled planner loop runs between two looks at the wall clock."""
FIRST_TIMED_SLICE = 8
"""Fewest iterations of the first slice under a time limit, before the loop's pace is known."""
ASSUMED_FIRST_PACE = 0.05
"""Seconds per iteration the first timed slice assumes: slower than any iteration we measured
(a 7D extension with its collision fallbacks), so the first slice stays within half the time
left, while a generous limit (the evaluation's 60 s) gets a whole slice at once instead of an
extra round trip to measure a pace that would have allowed it anyway."""

NO_NODE = -1
BAD_ACTION = -2
"""`extend` results besides a node index: nothing added, or a NaN/inf normalized action."""


def slice_length(deadline: float, now: float, seconds_per_iteration: float) -> int:
    """Iterations of a compiled loop's next slice: `SLICE`, fewer as ``deadline`` nears.

    At the pace measured so far (``seconds_per_iteration``) a slice takes at most half the
    time left, so a loop that looks at the clock between slices overshoots a time limit by a
    fraction of it, never by a whole slice. Before the pace is known (0), the first slice
    assumes `ASSUMED_FIRST_PACE` and runs at least `FIRST_TIMED_SLICE` iterations.
    """
    if not math.isfinite(deadline):
        return SLICE
    if seconds_per_iteration <= 0.0:
        first = (deadline - now) / ASSUMED_FIRST_PACE / 2.0
        return int(min(SLICE, max(float(FIRST_TIMED_SLICE), first)))
    return int(min(SLICE, max(1.0, (deadline - now) / seconds_per_iteration / 2.0)))


@numba.njit(cache=True, nogil=True)
def squared_distance(a, b) -> float:
    """``|a - b|^2`` of two ``(d,)`` arrays, summed in coordinate order."""
    total = 0.0
    for k in range(a.shape[0]):
        diff = a[k] - b[k]
        total += diff * diff
    return total


@numba.njit(cache=True, nogil=True, inline="always")
def _count_new_node(counters, goal_nodes, best_cost, node, cost, reached_goal):
    """Count ``node``, just inserted at ``cost``, as the newest node.

    In the goal region it is also a goal node, and the best one when it is cheaper.
    """
    counters[NUM_NODES] = node + 1
    counters[NEWEST] = node
    if reached_goal:
        goal_nodes[counters[NUM_GOAL]] = node
        counters[NUM_GOAL] += 1
        if cost < best_cost[0]:
            counters[BEST_NODE] = node
            best_cost[0] = cost


@numba.njit(cache=True, nogil=True)
def extend(arrays, counters, best_cost, params, goal, bounds, context, sample, normalized):
    """`Tree.extend` on a tree's arrays: returns the new node, `NO_NODE` or `BAD_ACTION`.

    ``arrays`` is ``(positions, costs, links, goal_nodes, near_idx, near_dist, cand_idx,
    stack, new, grid)``; the caller guarantees room for one more node. Parent candidates are
    counted as checked one at a time (`extend_detailed` with a chunk of 1).
    """
    return extend_detailed(
        arrays, counters, best_cost, params, goal, bounds, context, sample, normalized, 1
    )[0]


@numba.njit(cache=True, nogil=True, inline="always")  # `extend`'s body: its copy is as fast
def extend_detailed(
    arrays, counters, best_cost, params, goal, bounds, context, sample, normalized, check_chunk
):  # fmt: skip
    """`extend`, returning ``(node, nearest, rewired)`` as `Tree.extend` reports them.

    ``nearest`` is the node the sample was steered from (-1 with `BAD_ACTION`), ``rewired``
    how many nodes were rewired through the new one. ``check_chunk``: the parent candidates
    are counted in ``collision_checks`` as `Tree.extend` checks them, in chunks of that many
    up to the chunk holding the first free one (the tree is the same either way).
    """
    positions, costs, links, goal_nodes, near_idx, near_dist, cand_idx, stack, new, grid = arrays
    count = counters[NUM_NODES]
    step = params[STEP]
    if normalized:
        nearest, distance = action_nearest_and_steer(
            positions, count, sample, bounds, step, new, grid, near_idx
        )
        if nearest < 0:
            return BAD_ACTION, -1, 0
    else:
        nearest, distance = nearest_and_steer(positions, count, sample, step, new, grid, near_idx)
    counters[SAMPLES] += 1
    if not distance > 0.0:
        counters[FAILURES] += 1
        return NO_NODE, nearest, 0
    counters[CHECKS] += 1
    if not motion_free(context, positions[nearest], new):
        counters[FAILURES] += 1
        return NO_NODE, nearest, 0
    dim = positions.shape[1]
    radius = 0.0
    k = 0
    if params[K_NEAREST] > 0.0:
        k = max(1, math.ceil(params[GAMMA] * math.log(count + 1)))
    else:
        n = count + 1
        radius = min(params[GAMMA] * (math.log(n) / n) ** (1.0 / dim), params[MAX_RADIUS])
    num_near, num_cand = near_and_parent_candidates(
        positions, costs, count, new, nearest, radius, k, near_idx, near_dist, cand_idx, grid
    )
    parent = nearest
    checked = num_cand
    for j in range(num_cand):
        if motion_free(context, positions[cand_idx[j]], new):
            parent = cand_idx[j]
            checked = min((j // check_chunk + 1) * check_chunk, num_cand)
            break
    counters[CHECKS] += checked
    node = count
    cost, reached_goal, num_rewire = insert_node(
        positions, costs, links, node, new, parent, goal, params[GOAL_RADIUS_SQ], near_idx,
        near_dist, num_near, cand_idx,
    )  # fmt: skip
    _count_new_node(counters, goal_nodes, best_cost, node, cost, reached_goal)
    rewired = 0
    if num_rewire > 0:
        free = np.empty(num_rewire, dtype=np.bool_)
        for j in range(num_rewire):
            free[j] = motion_free(context, new, positions[cand_idx[j]])
        counters[CHECKS] += num_rewire
        rewired, best = apply_rewires(
            positions, costs, links, node, cand_idx[:num_rewire], free, num_rewire, stack,
            goal_nodes, counters[NUM_GOAL], counters[BEST_NODE],
        )  # fmt: skip
        if rewired > 0 and best >= 0:
            counters[BEST_NODE] = best
            best_cost[0] = costs[best]
    return node, nearest, rewired


@numba.njit(cache=True, nogil=True)
def fallback_sample(rng, low, high, buffer, cursor):
    """The next uniform sample in ``[low, high]``: a row of ``buffer``, refilled when used up.

    Draws what `temp_gym.planning.samplers.UniformSampler` draws from the same generator
    (``rng.uniform(low, high, (FALLBACK_BATCH, d))``), so compiled and Python loops stay in
    step. ``cursor[0]`` is the next row (``FALLBACK_BATCH`` when the buffer is empty).
    """
    if cursor[0] >= buffer.shape[0]:
        draws = rng.random(buffer.shape)
        for i in range(buffer.shape[0]):
            for k in range(buffer.shape[1]):
                buffer[i, k] = low[k] + (high[k] - low[k]) * draws[i, k]
        cursor[0] = 0
    row = buffer[cursor[0]]
    cursor[0] += 1
    return row


LOCAL_HALF_WIDTH = 0.15
"""Half-width, in normalized units, of the box around a failed proposal that its first
``local_tries`` replacements come from (`near_proposal`)."""


@numba.njit(cache=True, nogil=True)
def near_proposal(proposal, uniform, bounds, out):
    """A replacement in the box of half-width `LOCAL_HALF_WIDTH` around a normalized proposal.

    ``uniform`` is a uniform draw in ``bounds`` (world units), mapped to ``[-1, 1]`` and scaled
    into the box; the result is clipped to ``[-1, 1]`` and written, normalized, into ``out``.
    `Tree.extend_with_fallback` computes the same values in numpy.
    """
    for k in range(proposal.shape[0]):
        unit = 2.0 * (uniform[k] - bounds[0, k]) / (bounds[1, k] - bounds[0, k]) - 1.0
        out[k] = min(1.0, max(-1.0, proposal[k] + LOCAL_HALF_WIDTH * unit))
    return out


@numba.njit(cache=True, nogil=True)
def extend_with_fallback(
    arrays, counters, best_cost, params, goal, bounds, context, sample, normalized, rng,
    buffer, cursor, max_tries,
):  # fmt: skip
    """`Tree.extend_with_fallback` with a uniform fallback sampler: ``(node, samples)``.

    ``node`` is the added node, `NO_NODE` when ``max_tries`` replacements all failed, or
    `BAD_ACTION`; ``samples`` is how many samples this call used. This is Algorithm 1's
    fallback; `extend_near_first` is the variant whose first replacements stay near the
    proposal.
    """
    node = extend(arrays, counters, best_cost, params, goal, bounds, context, sample, normalized)
    if node == BAD_ACTION:
        return node, 0
    samples = 1
    tries = 0
    while node < 0 and tries < max_tries:
        replacement = fallback_sample(rng, bounds[0], bounds[1], buffer, cursor)
        node = extend(arrays, counters, best_cost, params, goal, bounds, context, replacement,
                      False)  # fmt: skip
        tries += 1
        samples += 1
    return node, samples


@numba.njit(cache=True, nogil=True)
def extend_near_first(
    arrays, counters, best_cost, params, goal, bounds, context, proposal, rng, buffer, cursor,
    max_tries, local_tries, local,
):  # fmt: skip
    """`extend_with_fallback` for a normalized proposal, its first replacements near it.

    The first ``local_tries`` replacements come from `near_proposal` (written into the
    caller's ``(d,)`` scratch ``local``), the rest are uniform: ``(node, samples)``.

    A separate kernel, so that Algorithm 1's loop (``local_tries`` = 0) keeps its own
    compiled code: one extra branch and call site in it slowed every 2D plan.
    """
    node = extend(arrays, counters, best_cost, params, goal, bounds, context, proposal, True)
    if node == BAD_ACTION:
        return node, 0
    samples = 1
    tries = 0
    while node < 0 and tries < max_tries:
        replacement = fallback_sample(rng, bounds[0], bounds[1], buffer, cursor)
        near = tries < local_tries
        if near:
            replacement = near_proposal(proposal, replacement, bounds, local)
        node = extend(arrays, counters, best_cost, params, goal, bounds, context, replacement,
                      near)  # fmt: skip
        tries += 1
        samples += 1
    return node, samples


@numba.njit(cache=True, nogil=True)
def normalized_root_path(links, positions, node, bounds, out) -> int:
    """The last ``len(out)`` nodes of ``node``'s root path, normalized, oldest first.

    Writes float32 rows into ``out`` (L, d) exactly as `TreeObserver.path_so_far` holds them
    and returns their count; rows past it are left as they were.
    """
    max_length = out.shape[0]
    length = 0
    probe = node
    while probe >= 0 and length < max_length:
        length += 1
        probe = links[probe, PARENT]
    dim = positions.shape[1]
    for row in range(length - 1, -1, -1):
        for k in range(dim):
            low = bounds[0, k]
            out[row, k] = 2.0 * (positions[node, k] - low) / (bounds[1, k] - low) - 1.0
        node = links[node, PARENT]
    return length


@numba.njit(cache=True, nogil=True)
def first_link(
    positions, first, count, other_positions, other_count, other_grid, scratch, context, counters,
    towards_other,
):  # fmt: skip
    """The first node of one tree with a free straight motion to its nearest in another.

    Returns ``(i, j)``: ``i`` in ``[first, count)`` of the one tree, ``j`` of the other;
    ``(-1, -1)`` when there is none. Each node costs one nearest query on the other tree
    (``other_grid``, ``scratch`` as `temp_gym.planning._kernels.nearest` takes them) and one
    motion check, counted in ``counters`` (`COUNTERS`' ``checks``). The motion is checked
    from ``i`` to ``j`` when ``towards_other``, else from ``j`` to ``i``: always in the
    direction the joined path runs.
    """
    for i in range(first, count):
        j, _ = nearest(other_positions, other_count, positions[i], other_grid, scratch)
        counters[CHECKS] += 1
        if towards_other:
            free = motion_free(context, positions[i], other_positions[j])
        else:
            free = motion_free(context, other_positions[j], positions[i])
        if free:
            return i, j
    return -1, -1


LINK = ("planner_node", "goal_node", "checks")
"""The int64 record `link_trees` writes: the linked nodes of the planner's tree and of the goal
tree (-1 before a link), and the motion checks made (they count in the planner's tree)."""
PLANNER_NODE, GOAL_NODE, LINK_CHECKS = range(len(LINK))


@numba.njit(cache=True, nogil=True)
def link_trees(planner, planner_count, goal_tree, goal_count, checked, context, record) -> bool:
    """Try the untried nodes of both trees against the other; True on the first free link.

    ``planner`` and ``goal_tree`` are ``(positions, grid, scratch)`` with ``*_count`` nodes.
    First the planner's nodes from ``checked[0]`` on, each against its nearest in the goal tree
    (the motion towards it), then the goal tree's from ``checked[1]`` on, against the
    planner's (the motion from it): `first_link` twice, so the joined path runs from the
    start. ``checked`` moves past the nodes tried; the link and the motion checks go into
    ``record`` (`LINK`).
    """
    counters = np.zeros(len(COUNTERS), dtype=np.int64)
    planner_node, goal_node = first_link(
        planner[0], checked[0], planner_count, goal_tree[0], goal_count, goal_tree[1],
        goal_tree[2], context, counters, True,
    )  # fmt: skip
    checked[0] = planner_count if planner_node < 0 else planner_node + 1
    if planner_node < 0:
        goal_node, planner_node = first_link(
            goal_tree[0], checked[1], goal_count, planner[0], planner_count, planner[1],
            planner[2], context, counters, False,
        )  # fmt: skip
        checked[1] = goal_count if goal_node < 0 else goal_node + 1
    record[LINK_CHECKS] += counters[CHECKS]
    if planner_node < 0:
        return False
    record[PLANNER_NODE], record[GOAL_NODE] = planner_node, goal_node
    return True


@numba.njit(cache=True, nogil=True)
def graft_branch(arrays, counters, best_cost, params, goal, node, branch):
    """Append the states ``branch`` (rows, in order) to the tree as a chain under ``node``.

    Each appended node's parent is the one before it (the first's is ``node``); the edges are
    the caller's to have checked. Stops after the first node inside the goal region, which
    becomes the best goal node when it is cheaper. No rewiring: the chain's edges are as
    given. Returns how many nodes were appended; the caller guarantees the room.
    """
    positions, costs, links, goal_nodes, near_idx, near_dist, cand_idx = arrays[:7]
    parent = node
    added = 0
    for row in range(branch.shape[0]):
        count = counters[NUM_NODES]
        cost, reached_goal, _ = insert_node(
            positions, costs, links, count, branch[row], parent, goal, params[GOAL_RADIUS_SQ],
            near_idx, near_dist, 0, cand_idx,
        )  # fmt: skip
        _count_new_node(counters, goal_nodes, best_cost, count, cost, reached_goal)
        added += 1
        parent = count
        if reached_goal:
            break
    return added
