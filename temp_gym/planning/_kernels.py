"""Numba kernels behind `temp_gym.planning.tree.Tree`: the per-extension hot loops.

The tree lives in flat arrays (see `Tree`): ``positions (capacity, d)``, ``costs (capacity,)``
and ``links (capacity, 3)`` holding, per node, its parent, its first child and its next
sibling (``-1`` for none), so children form singly linked lists and a subtree can be walked
without allocating. Collision checks are not done here: a kernel returns the edges that need
checking, Python hands them to the (any-robot) checker in one batch, and the next kernel
consumes the answers.

Nearest and near neighbours are brute-force scans, which beat a tree index for the few
thousand nodes a planning query grows (20k nodes x 7 dims is still only ~100 us).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from temp_gym.planning._grid import grid_nearest, in_use, scan_nearest, within_box
from temp_gym.planning._grid import squared_distance_to as _squared_distance

PARENT = 0
FIRST_CHILD = 1
NEXT_SIBLING = 2

# A rewire or parent change must lower a cost by more than this fraction of it, so that
# floating-point ties never flip edges back and forth (and never close a cycle). Relative,
# not absolute: an absolute 1e-10 was a tenth of an edge in a world 1e-9 across, and RRT*
# there stopped rewiring (cost 1.71x the optimum instead of 1.04x).
COST_EPS = 1e-10


@numba.njit(cache=True, nogil=True, inline="always")
def lowers(candidate, current):
    """Whether cost ``candidate`` is below ``current`` by more than ``COST_EPS`` of it."""
    return candidate < current - COST_EPS * abs(current)


@numba.njit(cache=True, nogil=True)
def nearest(positions, count, point, grid, scratch):
    """``(node, squared distance)`` of the node nearest ``point``.

    Through the ``grid`` of a big point-robot tree, else by a scan (the same answer);
    ``scratch`` holds ``count`` int64.
    """
    if in_use(grid, count, point):
        return grid_nearest(positions, count, point, grid, scratch)
    return scan_nearest(positions, count, point)


@numba.njit(cache=True, nogil=True)
def nearest_and_steer(positions, count, sample, step_size, out_new, grid, scratch):
    """Find the node nearest to ``sample`` and steer from it by at most ``step_size``.

    Writes the steered state into ``out_new`` and returns ``(nearest, distance)`` where
    ``distance`` is from the nearest node to ``sample`` (before steering). A big point-robot
    tree is searched through its ``grid`` (`temp_gym.planning._grid`, the same answer as the
    scan); ``scratch`` holds ``count`` int64.
    """
    dim = positions.shape[1]
    if in_use(grid, count, sample):
        best, best_sq = grid_nearest(positions, count, sample, grid, scratch)
    else:
        best, best_sq = scan_nearest(positions, count, sample)
    distance = math.sqrt(best_sq)
    scale = 1.0
    if distance > step_size:
        scale = step_size / distance
    for k in range(dim):
        out_new[k] = positions[best, k] + scale * (sample[k] - positions[best, k])
    return best, distance


@numba.njit(cache=True, nogil=True)
def action_to_sample(action, bounds, out) -> bool:
    """Clip ``action`` to [-1, 1] and map it into ``bounds`` (2, d); False if any is not finite.

    -1 and 1 map to the lower and upper bounds (the normalization of the env's actions).
    """
    for k in range(action.shape[0]):
        a = action[k]
        if not np.isfinite(a):
            return False
        a = min(max(a, -1.0), 1.0)
        out[k] = bounds[0, k] + 0.5 * (a + 1.0) * (bounds[1, k] - bounds[0, k])
    return True


# Not nogil: the env calls this once per step, and releasing the GIL costs ~0.1 us.
@numba.njit(cache=True)
def action_nearest_and_steer(positions, count, action, bounds, step_size, out_new, grid, scratch):
    """`action_to_sample` then `nearest_and_steer`, in one call: the env's extension.

    Returns ``(nearest, distance)`` as `nearest_and_steer` does, or ``(-1, nan)`` (and does
    nothing else) when an entry of ``action`` is not finite. The sample is held in
    ``out_new`` until it is steered in place (each entry is read before it is overwritten).
    """
    if not action_to_sample(action, bounds, out_new):
        return -1, np.nan
    return nearest_and_steer(positions, count, out_new, step_size, out_new, grid, scratch)


@numba.njit(cache=True, nogil=True, inline="always")
def _join_if_near(positions, i, new, nearest, radius, loose, near_idx, near_dist, num_near, dim):
    """Append node ``i`` to the near set if within ``radius`` (``nearest`` always); the count.

    The radius test on squared distances first, with the ``loose`` margin far above rounding,
    so that the square root is taken only near the ball; the exact test ``sqrt <= radius``
    then decides, as it would on every node: the same near set, the same distances.
    """
    sq = _squared_distance(positions, i, new, dim)
    if sq <= loose or i == nearest:
        distance = math.sqrt(sq)
        if distance <= radius or i == nearest:
            near_idx[num_near] = i
            near_dist[num_near] = distance
            return num_near + 1
    return num_near


@numba.njit(cache=True, nogil=True)
def _grid_near_set(
    positions, count, new, nearest, radius, loose, grid, near_idx, near_dist, listed
):
    """The scan's near set (below) from the nodes of the grid cells the ball meets.

    ``listed`` (room for ``count``) receives those nodes, ascending; ``nearest`` joins the
    set at its place in index order whether or not it is within ``radius``.
    """
    dim = positions.shape[1]
    num_listed = within_box(positions, count, new, radius, grid, listed)
    num_near = 0
    unlisted_nearest = True
    for j in range(num_listed + 1):
        i = listed[j] if j < num_listed else count  # past the list: nearest, if left
        if unlisted_nearest and nearest < i:  # its place in index order
            num_near = _join_if_near(positions, nearest, new, nearest, radius, loose, near_idx,
                                     near_dist, num_near, dim)  # fmt: skip
            unlisted_nearest = False
        if j == num_listed:
            break
        num_near = _join_if_near(positions, i, new, nearest, radius, loose, near_idx, near_dist,
                                 num_near, dim)  # fmt: skip
        if i == nearest:
            unlisted_nearest = False
    return num_near


@numba.njit(cache=True, nogil=True)
def near_and_parent_candidates(
    positions, costs, count, new, nearest, radius, k_nearest, near_idx, near_dist, cand_idx, grid
):
    """Collect the near set of ``new`` and the parent candidates cheaper than ``nearest``.

    The near set is every node within ``radius`` (when ``k_nearest <= 0``) or the
    ``k_nearest`` closest nodes; ``nearest`` is always in it. Writes the near set into
    ``near_idx``/``near_dist`` and, sorted by cost-to-come through them, the near nodes that
    would give ``new`` a lower cost than ``nearest`` does into ``cand_idx`` (their edges still
    need a collision check; the edge from ``nearest`` is already known to be free).

    Returns ``(num_near, num_candidates)``.
    """
    dim = positions.shape[1]
    num_near = 0
    if k_nearest > 0:
        dist = np.empty(count)
        for i in range(count):
            dist[i] = math.sqrt(_squared_distance(positions, i, new, dim))
        threshold = np.inf
        if k_nearest < count:
            threshold = np.partition(dist, k_nearest - 1)[k_nearest - 1]
        for i in range(count):
            if dist[i] <= threshold or i == nearest:
                near_idx[num_near] = i
                near_dist[num_near] = dist[i]
                num_near += 1
    else:
        loose = radius * radius * (1.0 + 1e-9)  # `_join_if_near` says why
        if in_use(grid, count, new):  # the nodes of the cells the ball meets, ascending
            num_near = _grid_near_set(
                positions, count, new, nearest, radius, loose, grid, near_idx, near_dist, cand_idx
            )
        else:
            for i in range(count):
                num_near = _join_if_near(positions, i, new, nearest, radius, loose, near_idx,
                                         near_dist, num_near, dim)  # fmt: skip
    via_nearest = costs[nearest] + math.sqrt(_squared_distance(positions, nearest, new, dim))
    through = np.empty(num_near)
    num_cand = 0
    for j in range(num_near):
        i = near_idx[j]
        c = costs[i] + near_dist[j]
        if i != nearest and lowers(c, via_nearest):
            cand_idx[num_cand] = i
            through[num_cand] = c
            num_cand += 1
    if num_cand > 1:
        order = np.argsort(through[:num_cand], kind="mergesort")
        sorted_idx = cand_idx[:num_cand][order]
        cand_idx[:num_cand] = sorted_idx
    return num_near, num_cand


@numba.njit(cache=True, nogil=True)
def insert_node(
    positions,
    costs,
    links,
    count,
    new,
    parent,
    goal,
    goal_radius_sq,
    near_idx,
    near_dist,
    num_near,
    rewire_idx,
):
    """Append ``new`` as node ``count`` under ``parent`` and list its rewire candidates.

    Rewire candidates are the near nodes whose cost would drop by re-parenting them to the
    new node; they are written into ``rewire_idx``. Returns
    ``(cost_to_come, in_goal_region, num_rewire_candidates)``.
    """
    dim = positions.shape[1]
    sq = 0.0
    goal_sq = 0.0
    for k in range(dim):
        positions[count, k] = new[k]
        diff = new[k] - positions[parent, k]
        sq += diff * diff
        to_goal = new[k] - goal[k]
        goal_sq += to_goal * to_goal
    cost = costs[parent] + math.sqrt(sq)
    costs[count] = cost
    links[count, PARENT] = parent
    links[count, FIRST_CHILD] = -1
    links[count, NEXT_SIBLING] = links[parent, FIRST_CHILD]
    links[parent, FIRST_CHILD] = count
    num = 0
    for j in range(num_near):
        i = near_idx[j]
        if lowers(cost + near_dist[j], costs[i]):
            rewire_idx[num] = i
            num += 1
    return cost, goal_sq <= goal_radius_sq, num


@numba.njit(cache=True, nogil=True)
def _detach(links, child):
    parent = links[child, PARENT]
    previous = -1
    current = links[parent, FIRST_CHILD]
    while current != child:
        previous = current
        current = links[current, NEXT_SIBLING]
    if previous == -1:
        links[parent, FIRST_CHILD] = links[child, NEXT_SIBLING]
    else:
        links[previous, NEXT_SIBLING] = links[child, NEXT_SIBLING]


@numba.njit(cache=True, nogil=True)
def _edge_length(positions, a, b):
    sq = 0.0
    for k in range(positions.shape[1]):
        diff = positions[a, k] - positions[b, k]
        sq += diff * diff
    return math.sqrt(sq)


@numba.njit(cache=True, nogil=True)
def propagate_costs(positions, costs, links, root, stack):
    """Recompute the cost of every strict descendant of ``root`` from its parent's cost.

    Costs are recomputed edge by edge rather than shifted by a delta, so they stay exactly
    the sum of edge lengths along the root path (no drift over many rewires).
    """
    top = 0
    child = links[root, FIRST_CHILD]
    while child != -1:
        stack[top] = child
        top += 1
        child = links[child, NEXT_SIBLING]
    while top > 0:
        top -= 1
        node = stack[top]
        costs[node] = costs[links[node, PARENT]] + _edge_length(
            positions, node, links[node, PARENT]
        )
        child = links[node, FIRST_CHILD]
        while child != -1:
            stack[top] = child
            top += 1
            child = links[child, NEXT_SIBLING]


@numba.njit(cache=True, nogil=True)
def best_goal_node(costs, goal_nodes, num_goal):
    """Index of the cheapest goal node (``-1`` when there is none)."""
    best = -1
    best_cost = np.inf
    for j in range(num_goal):
        i = goal_nodes[j]
        if costs[i] < best_cost:
            best_cost = costs[i]
            best = i
    return best


@numba.njit(cache=True, nogil=True)
def apply_rewires(
    positions, costs, links, node, cand_idx, free, num_cand, stack, goal_nodes, num_goal, best
):
    """Re-parent each candidate whose edge from ``node`` is free and still an improvement.

    The improvement is re-tested against current costs because rewiring one candidate can
    already have lowered another (its descendant). Returns ``(rewired, best_goal_node)``,
    the latter recomputed when anything was rewired (otherwise ``best`` is passed through).
    """
    rewired = 0
    for j in range(num_cand):
        if not free[j]:
            continue
        i = cand_idx[j]
        through = costs[node] + _edge_length(positions, node, i)
        if not lowers(through, costs[i]):
            continue
        _detach(links, i)
        links[i, PARENT] = node
        links[i, NEXT_SIBLING] = links[node, FIRST_CHILD]
        links[node, FIRST_CHILD] = i
        costs[i] = through
        propagate_costs(positions, costs, links, i, stack)
        rewired += 1
    if rewired > 0 and num_goal > 0:
        best = best_goal_node(costs, goal_nodes, num_goal)
    return rewired, best


@numba.njit(cache=True, nogil=True)
def root_path_indices(links, node, out):
    """Write the node indices from ``node`` up to the root into ``out``; return the count."""
    num = 0
    while node != -1:
        out[num] = node
        num += 1
        node = links[node, PARENT]
    return num
