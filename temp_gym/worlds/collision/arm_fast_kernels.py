"""The fast arm checker's compiled kernels: states and edges against obstacles and itself.

`temp_gym.worlds.collision.arm_fast` prepares the arrays and explains why the tests are
conservative and certify whole motions; `temp_gym.worlds.collision.arm_fast_obstacles` holds
the sphere-versus-obstacle tests and `temp_gym.worlds.collision.arm_fast_self` the
self-collision tests. The kernels that return arrays allocate them and their scratch space,
then hand everything to loops compiled without reference counting
(`temp_gym.worlds.hot_path`), whose helpers numba inlines: counting the references of some
thirty arrays per state used to cost more than the forward kinematics. The self-collision
pairs are first screened on the root-sphere centers the obstacle broad phase has just
computed.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from temp_gym.worlds.arm.kinematics import (
    chain_into,
    identity_poses,
    segment_levers_into,
    sincos_into,
)
from temp_gym.worlds.collision.arm_fast_obstacles import (
    CERTAIN,
    FREE,
    HIT,
    UNSURE,
    body_touches,
)
from temp_gym.worlds.collision.arm_fast_self import (
    FAST_SELF_GAP,
    TABLE_MARGIN,
    pair_free,
    pairs_free,
    place,
    roots_apart,
    tables_free,
)
from temp_gym.worlds.hot_path import hot_inline, hot_path

GROWTH_FLOOR = 1e-4
"""An edge interval whose spheres would grow by at most this (m) and still touch is blocked."""
COARSE_INTERVALS = 4
"""Most resolution-wide intervals an edge's middle is first checked as one (`_edge_free`): its
spheres grow by up to this many half resolutions, and a check that fails is split as any
other: fewer checks on a free edge, a few more near a surface. 4 and 8 checked random edges
from free states about as fast, 16 slower (the research notes on collision checking); the
smaller keeps the growth, and the splits near a surface, smaller."""


@hot_inline
def _in_bounds(states, i, bounds) -> bool:
    """Whether ``states[i]`` is within ``bounds`` (indexed whole: row views cost refcounts)."""
    for k in range(states.shape[1]):
        # Written so that NaN fails the test.
        if not (states[i, k] >= bounds[0, k] and states[i, k] <= bounds[1, k]):
            return False
    return True


@hot_inline
def _pose_free(sines, cosines, base, values, value_base, kind, rotation, shift,
               node_centers, node_radii, node_skip, node_first, node_count, body_start, centers,
               radii, inner_centers, inner_radii, inner_start, box_params, body_boxes,
               body_box_count, body_lower, body_upper, hulls, inflation, poses,
               root_world) -> int:  # fmt: skip
    """Whether a pose is free of the obstacles: `FREE`, `HIT` or `CERTAIN`.

    `FREE` when the moving bodies' spheres (grown by ``inflation[j]``) miss every obstacle, or
    touch one only within their bulge while the body's convex pieces clear it by
    ``inflation[j]`` (`arm_fast_hulls`); `HIT` when a body touches an obstacle, `CERTAIN` when a
    body's inner ball (inside its pieces, not grown) does: the state itself is in collision.
    ``box_params`` holds every obstacle's row, ``body_boxes[j]`` body ``j``'s candidates:
    ``body_box_count[j, 0]`` axis-aligned boxes, then ``body_box_count[j, 1]`` others
    (`arm_fast_obstacles.body_touches`); ``hulls`` the bodies' convex pieces, which decide
    touches within the spheres' bulge.

    ``sines[base + i]``, ``cosines[base + i]`` and ``values[value_base + i]`` are joint ``i``'s;
    ``poses`` (B, 3, 4) is scratch whose first entry is the identity. When this returns True,
    ``poses`` holds the body frames and ``root_world`` (B, 3) the world centers of the bodies'
    root spheres (row 0, the base's, never changes): the self-collision test reads them.
    """
    chain_into(poses, kind, rotation, shift, cosines, sines, base, values, value_base)
    # Distal bodies first: they sweep the most space, so collisions are found sooner. Touches
    # within the spheres' bulge are left for a second pass, which only a state that collides
    # nowhere else reaches.
    unsure = False
    for j in range(poses.shape[0] - 1, 0, -1):
        root = body_start[j]
        if root == body_start[j + 1]:
            continue
        bx, by, bz = place(poses, j, node_centers, root)
        root_world[j, 0], root_world[j, 1], root_world[j, 2] = bx, by, bz
        answer = body_touches(poses, j, bx, by, bz, node_radii[root] + inflation[j],
                              node_centers, node_radii, node_skip, node_first, node_count,
                              body_start, centers, radii, inner_centers, inner_radii,
                              inner_start, inflation[j], box_params, body_boxes, body_box_count,
                              body_lower, body_upper, hulls, False)  # fmt: skip
        if answer == UNSURE:
            unsure = True
        elif answer != FREE:
            return answer
    if not unsure:
        return FREE
    for j in range(poses.shape[0] - 1, 0, -1):
        root = body_start[j]
        if root < body_start[j + 1]:
            answer = body_touches(poses, j, root_world[j, 0], root_world[j, 1],
                                  root_world[j, 2], node_radii[root] + inflation[j],
                                  node_centers, node_radii, node_skip, node_first, node_count,
                                  body_start, centers, radii, inner_centers, inner_radii,
                                  inner_start, inflation[j], box_params, body_boxes,
                                  body_box_count, body_lower, body_upper, hulls,
                                  True)  # fmt: skip
            if answer != FREE:
                return answer
    return FREE


@numba.njit(cache=True, nogil=True)
def _state_pair_growth(pairs, inflation):
    """``(P, 2)``: each sphere pair's two bodies grown by their state-check inflation."""
    growth = np.empty((pairs.shape[0], 2))
    for p in range(pairs.shape[0]):
        growth[p, 0] = inflation[pairs[p, 0]]
        growth[p, 1] = inflation[pairs[p, 1]]
    return growth


_BLOCK = 256
"""States per block: sines and cosines are computed a block at a time, vectorized."""


@numba.njit(cache=True, nogil=True)
def states_free_kernel(states, bounds, kinematics, trees, boxes, self_model, clearance, scratch):
    """``bool[N]``: each state in ``bounds`` and free, every sphere grown by ``clearance``.

    The tuples are `ArmSphereChecker`'s arrays; ``scratch`` is `pair_free`'s. Allocates the
    output and scratch space; `_states_loop` does the work.
    """
    node_centers, body_start = trees[0], trees[5]
    num, dim = states.shape
    bodies = dim + 1
    out = np.zeros(num, dtype=np.bool_)
    root_world = np.zeros((bodies, 3))
    if body_start[0] < body_start[1]:
        for k in range(3):
            root_world[0, k] = node_centers[body_start[0], k]
    inflation = np.full(bodies, clearance)
    inflation[0] = 0.0
    work = (identity_poses(bodies), root_world, inflation,
            np.full(self_model[1].shape[0], clearance), _state_pair_growth(self_model[0],
                                                                           inflation),
            np.empty(_BLOCK * dim), np.empty(_BLOCK * dim), scratch)  # fmt: skip
    _states_loop(states, states.reshape(-1), bounds, kinematics, trees, boxes, self_model,
                 work, out)  # fmt: skip
    return out


@hot_path
def _states_loop(states, flat, bounds, kinematics, trees, boxes, self_model, work, out) -> None:
    """`states_free_kernel`'s loop; ``flat`` is ``states`` flattened, ``work`` its scratch."""
    kind, rotation, shift = kinematics
    (node_centers, node_radii, node_skip, node_first, node_count, body_start, centers, radii,
     inner_centers, inner_radii, inner_start, capsules) = trees  # fmt: skip
    box_params, body_boxes, body_box_count, body_lower, body_upper, hulls = boxes
    (sphere_pairs, table_grid, table_bounds, table_motion, field_values,
     field_layout) = self_model  # fmt: skip
    poses, root_world, inflation, table_growth, pair_growth, sines, cosines, scratch = work
    num, dim = states.shape
    for first in range(0, num, _BLOCK):
        last = min(first + _BLOCK, num)
        sincos_into(flat, first * dim, last * dim, sines, cosines)
        for i in range(first, last):
            # The joint-space tables need no kinematics: they go first; the sphere pairs last.
            if not (_in_bounds(states, i, bounds) and tables_free(
                    flat, i * dim, table_grid, table_bounds, table_growth,
                    TABLE_MARGIN)):  # fmt: skip
                continue
            obstacles_free = _pose_free(
                sines, cosines, (i - first) * dim, flat, i * dim, kind, rotation, shift,
                node_centers, node_radii, node_skip, node_first, node_count,
                body_start, centers, radii, inner_centers, inner_radii, inner_start, box_params,
                body_boxes, body_box_count, body_lower, body_upper, hulls, inflation, poses,
                root_world,
            ) == FREE  # fmt: skip
            # Most poses keep every pair's root spheres apart: no tree walk.
            out[i] = obstacles_free and (
                roots_apart(root_world, sphere_pairs, node_radii, body_start, pair_growth,
                            FAST_SELF_GAP)
                or pairs_free(poses, sphere_pairs, node_centers, node_radii, node_skip,
                              node_first, node_count, body_start, centers, radii,
                              inner_centers, inner_radii, inner_start, capsules,
                              field_values, field_layout, pair_growth, FAST_SELF_GAP, scratch)
            )  # fmt: skip


@hot_path
def _state_free(q, kind, rotation, shift, node_centers, node_radii,
                node_skip, node_first, node_count, body_start, centers, radii, inner_centers,
                inner_radii, inner_start, capsules, box_params, body_boxes, body_box_count,
                body_lower, body_upper, hulls, sphere_pairs, field_values, field_layout,
                table_grid, table_bounds, inflation, table_growth, pair_growth, poses, root_world,
                sines, cosines, scratch) -> int:  # fmt: skip
    """`_pose_free`'s answer for the one state ``q``, self-collision included.

    Spheres are grown by ``inflation`` against obstacles, the sphere pairs by ``pair_growth``
    (`arm_fast_self`) and the table pairs by ``table_growth``; no bounds check (an edge's
    states lie between its checked ends).
    """
    if not tables_free(q, 0, table_grid, table_bounds, table_growth, TABLE_MARGIN):
        return HIT
    sincos_into(q, 0, q.shape[0], sines, cosines)
    answer = _pose_free(sines, cosines, 0, q, 0, kind, rotation, shift,
                        node_centers, node_radii, node_skip, node_first, node_count, body_start,
                        centers, radii, inner_centers, inner_radii, inner_start, box_params,
                        body_boxes, body_box_count, body_lower, body_upper, hulls, inflation,
                        poses, root_world)  # fmt: skip
    if answer != FREE:
        return answer
    if roots_apart(root_world, sphere_pairs, node_radii, body_start, pair_growth,
                   FAST_SELF_GAP) or pairs_free(
            poses, sphere_pairs, node_centers, node_radii, node_skip, node_first, node_count,
            body_start, centers, radii, inner_centers, inner_radii, inner_start, capsules,
            field_values, field_layout, pair_growth, FAST_SELF_GAP, scratch):  # fmt: skip
        return FREE
    return HIT


@hot_inline
def first_intervals(steps, stack_low, stack_high) -> int:
    """Push an edge's first intervals onto the stack; returns how many.

    Of the ``steps`` intervals ``[k / steps, (k + 1) / steps]`` the last comes out first, then
    the first (an edge whose new end collides is refused at once), then the ones between in
    chunks of up to `COARSE_INTERVALS`, left to right: pushed in the reverse of that order.
    """
    top = 0
    if steps > 2:
        inner = steps - 2
        chunks = (inner + COARSE_INTERVALS - 1) // COARSE_INTERVALS
        for c in range(chunks - 1, -1, -1):
            stack_low[top] = (1 + (c * inner) // chunks) / steps
            stack_high[top] = (1 + ((c + 1) * inner) // chunks) / steps
            top += 1
    if steps > 1:
        stack_low[top], stack_high[top] = 0.0, 1.0 / steps
        top += 1
    stack_low[top], stack_high[top] = (steps - 1) / steps, 1.0
    return top + 1


@hot_path
def _edge_free(starts, ends, e, bounds, kind, rotation, shift, node_centers,
               node_radii, node_skip, node_first, node_count, body_start, centers, radii,
               inner_centers, inner_radii, inner_start, capsules, box_params, body_boxes,
               body_box_count, body_lower, body_upper, hulls, sphere_pairs, field_values,
               field_layout, table_grid, table_bounds, table_motion, motion, resolution, poses,
               root_world, sweep, inflation, table_sweep, table_growth, pair_sweep,
               pair_growth, lever, q, sines, cosines, stack_low, stack_high,
               scratch) -> bool:  # fmt: skip
    """Whether edge ``starts[e] -> ends[e]`` is free (`arm_fast`'s adaptive intervals).

    Against obstacles body ``j`` grows by its own motion, bounded with this motion's lever arms
    (`segment_levers_into`); a sphere pair's second body by its motion relative to the first,
    which only the joints between them make; a table pair by the same, with the arm's
    lever-arm bounds (`arm_fast_self`).
    """
    # The configuration space is a box: a segment with both ends in bounds stays in bounds.
    if not (_in_bounds(starts, e, bounds) and _in_bounds(ends, e, bounds)):
        return False
    dim = starts.shape[1]
    segment_levers_into(starts, ends, e, kind, rotation, shift, motion, body_start,
                        node_centers, node_radii, poses, q, sines, cosines,
                        lever)  # fmt: skip
    worst = 0.0
    for j in range(sweep.shape[0]):
        total = 0.0
        for i in range(dim):
            total += abs(ends[e, i] - starts[e, i]) * lever[i, j]
        sweep[j] = total
        worst = max(worst, total)
    for p in range(table_sweep.shape[0]):
        total = 0.0
        for i in range(dim):
            total += abs(ends[e, i] - starts[e, i]) * table_motion[p, i]
        table_sweep[p] = total
    for p in range(pair_sweep.shape[0]):
        total = 0.0
        for i in range(sphere_pairs[p, 0], sphere_pairs[p, 1]):
            total += abs(ends[e, i] - starts[e, i]) * lever[i, sphere_pairs[p, 1]]
        pair_sweep[p] = total
    steps = max(1, int(math.ceil(worst / resolution)))
    top = first_intervals(steps, stack_low, stack_high)
    while top > 0:
        top -= 1
        low, high = stack_low[top], stack_high[top]
        t = 0.5 * (low + high)
        half = 0.5 * (high - low)
        for i in range(dim):
            q[i] = starts[e, i] + t * (ends[e, i] - starts[e, i])
        for j in range(sweep.shape[0]):
            inflation[j] = sweep[j] * half
        for p in range(table_sweep.shape[0]):
            table_growth[p] = table_sweep[p] * half
        for p in range(pair_sweep.shape[0]):
            pair_growth[p, 1] = pair_sweep[p] * half
        answer = _state_free(q, kind, rotation, shift, node_centers,
                             node_radii, node_skip, node_first, node_count, body_start, centers,
                             radii, inner_centers, inner_radii, inner_start, capsules, box_params,
                             body_boxes, body_box_count, body_lower, body_upper, hulls,
                             sphere_pairs,
                             field_values, field_layout, table_grid, table_bounds, inflation,
                             table_growth, pair_growth, poses, root_world, sines, cosines,
                             scratch)  # fmt: skip
        if answer == FREE:
            continue
        if answer == CERTAIN or worst * half <= GROWTH_FLOOR or top + 2 > stack_low.shape[0]:
            return False
        # Blocked with grown spheres: is the state itself free? Then look closer.
        for j in range(sweep.shape[0]):
            inflation[j] = 0.0
        for p in range(table_sweep.shape[0]):
            table_growth[p] = 0.0
        for p in range(pair_sweep.shape[0]):
            pair_growth[p, 1] = 0.0
        if _state_free(q, kind, rotation, shift, node_centers, node_radii,
                       node_skip, node_first, node_count, body_start, centers, radii,
                       inner_centers, inner_radii, inner_start, capsules, box_params, body_boxes,
                       body_box_count, body_lower, body_upper, hulls, sphere_pairs,
                       field_values, field_layout, table_grid, table_bounds, inflation,
                       table_growth, pair_growth, poses, root_world, sines, cosines,
                       scratch) != FREE:  # fmt: skip
            return False
        stack_low[top], stack_high[top] = t, high
        top += 1
        stack_low[top], stack_high[top] = low, t
        top += 1
    return True


_STACK_DEPTH = 96
"""Room for nested splits on top of an edge's first intervals."""


@numba.njit(cache=True, nogil=True)
def _edge_work(dim, bodies, tables, pairs, steps_hint):
    """Scratch for `_edge_free`: poses, centers, sweeps, growths, levers, a state, the stack.

    A sphere pair's first body never grows (`arm_fast_self`): its column stays 0.
    """
    return (identity_poses(bodies), np.zeros((bodies, 3)), np.empty(bodies), np.empty(bodies),
            np.empty(tables), np.empty(tables), np.empty(pairs), np.zeros((pairs, 2)),
            np.empty((dim, bodies)), np.empty(dim), np.empty(dim), np.empty(dim),
            np.empty(steps_hint + _STACK_DEPTH), np.empty(steps_hint + _STACK_DEPTH))  # fmt: skip


@numba.njit(cache=True, nogil=True)
def edges_free_kernel(starts, ends, bounds, kinematics, trees, boxes, self_model, motion,
                      resolution, scratch):  # fmt: skip
    """``bool[N]``: each motion ``starts[e] -> ends[e]`` certified free (`_edge_free`)."""
    kind, rotation, shift = kinematics
    (node_centers, node_radii, node_skip, node_first, node_count, body_start, centers, radii,
     inner_centers, inner_radii, inner_start, capsules) = trees  # fmt: skip
    box_params, body_boxes, body_box_count, body_lower, body_upper, hulls = boxes
    (sphere_pairs, table_grid, table_bounds, table_motion, field_values,
     field_layout) = self_model  # fmt: skip
    dim = starts.shape[1]
    bodies = dim + 1
    out = np.empty(starts.shape[0], dtype=np.bool_)
    most = 1
    for e in range(starts.shape[0]):
        worst = 0.0
        for j in range(bodies):
            total = 0.0
            for i in range(dim):
                total += abs(ends[e, i] - starts[e, i]) * motion[i, j]
            worst = max(worst, total)
        if worst < 1e9:  # not NaN or inf: such an edge fails its bounds check
            most = max(most, int(math.ceil(worst / resolution)))
    (poses, root_world, sweep, inflation, table_sweep, table_growth, pair_sweep, pair_growth,
     lever, q, sines, cosines, stack_low, stack_high) = _edge_work(dim, bodies, table_grid.shape[0],
                                                         sphere_pairs.shape[0],
                                                         most)  # fmt: skip
    if body_start[0] < body_start[1]:
        for k in range(3):
            root_world[0, k] = node_centers[body_start[0], k]
    for e in range(starts.shape[0]):
        out[e] = _edge_free(starts, ends, e, bounds, kind, rotation, shift,
                            node_centers, node_radii, node_skip, node_first, node_count,
                            body_start, centers, radii, inner_centers, inner_radii,
                            inner_start, capsules, box_params, body_boxes, body_box_count,
                            body_lower, body_upper, hulls, sphere_pairs, field_values,
                            field_layout, table_grid, table_bounds, table_motion, motion,
                            resolution, poses, root_world, sweep, inflation, table_sweep,
                            table_growth, pair_sweep, pair_growth, lever, q, sines, cosines,
                            stack_low, stack_high, scratch)  # fmt: skip
    return out


@numba.njit(cache=True, nogil=True)
def motion_free_kernel(context, start, end) -> bool:
    """One motion ``start -> end`` by `_edge_free`, for compiled callers.

    ``context`` is `ArmSphereChecker.compiled_context`: the checker's arrays plus scratch
    space, so a call allocates nothing unless the edge needs more intervals than it holds.
    """
    settings, bounds, kinematics, trees, boxes, self_model, motion, scratch, work = context
    if settings[0] == 0.0:  # the base collides: nothing is free
        return False
    kind, rotation, shift = kinematics
    (node_centers, node_radii, node_skip, node_first, node_count, body_start, centers, radii,
     inner_centers, inner_radii, inner_start, capsules) = trees  # fmt: skip
    box_params, body_boxes, body_box_count, body_lower, body_upper, hulls = boxes
    (sphere_pairs, table_grid, table_bounds, table_motion, field_values,
     field_layout) = self_model  # fmt: skip
    (starts, ends, poses, root_world, sweep, inflation, table_sweep, table_growth, pair_sweep,
     pair_growth, lever, q, sines, cosines, stack_low, stack_high) = work  # fmt: skip
    for i in range(start.shape[0]):
        starts[0, i] = start[i]
        ends[0, i] = end[i]
    worst = 0.0
    for j in range(sweep.shape[0]):
        total = 0.0
        for i in range(start.shape[0]):
            total += abs(end[i] - start[i]) * motion[i, j]
        worst = max(worst, total)
    if worst < 1e9 and int(math.ceil(worst / settings[1])) + _STACK_DEPTH > stack_low.shape[0]:
        stack_low = np.empty(int(math.ceil(worst / settings[1])) + _STACK_DEPTH)
        stack_high = np.empty(stack_low.shape[0])
    return _edge_free(starts, ends, 0, bounds, kind, rotation, shift,
                      node_centers, node_radii, node_skip, node_first, node_count, body_start,
                      centers, radii, inner_centers, inner_radii, inner_start, capsules, box_params,
                      body_boxes, body_box_count, body_lower,
                      body_upper, hulls, sphere_pairs, field_values, field_layout, table_grid,
                      table_bounds, table_motion, motion, settings[1], poses, root_world,
                      sweep, inflation, table_sweep, table_growth, pair_sweep, pair_growth,
                      lever, q, sines, cosines, stack_low, stack_high, scratch)  # fmt: skip


@numba.njit(cache=True, nogil=True)
def colliding_pairs_kernel(state, kinematics, trees, self_model, scratch):
    """``(sphere pairs hit, table pairs hit)``: which pairs of one state collide."""
    kind, rotation, shift = kinematics
    (node_centers, node_radii, node_skip, node_first, node_count, body_start, centers, radii,
     inner_centers, inner_radii, inner_start, capsules) = trees  # fmt: skip
    (sphere_pairs, table_grid, table_bounds, table_motion, field_values,
     field_layout) = self_model  # fmt: skip
    dim = state.shape[0]
    poses = identity_poses(dim + 1)
    chain_into(poses, kind, rotation, shift, np.cos(state), np.sin(state), 0, state, 0)
    spheres_hit = np.zeros(sphere_pairs.shape[0], dtype=np.bool_)
    for p in range(sphere_pairs.shape[0]):
        spheres_hit[p] = not pair_free(poses, sphere_pairs[p, 0], sphere_pairs[p, 1],
                                       node_centers, node_radii, node_skip, node_first,
                                       node_count, body_start, centers, radii, inner_centers,
                                       inner_radii, inner_start, capsules, field_values,
                                       field_layout, 0.0, 0.0, FAST_SELF_GAP,
                                       scratch)  # fmt: skip
    tables_hit = np.zeros(table_grid.shape[0], dtype=np.bool_)
    for p in range(table_grid.shape[0]):
        tables_hit[p] = not tables_free(state, 0, table_grid[p : p + 1], table_bounds[p : p + 1],
                                        np.zeros(1), TABLE_MARGIN)  # fmt: skip
    return spheres_hit, tables_hit


__all__ = [
    "GROWTH_FLOOR",
    "colliding_pairs_kernel",
    "edges_free_kernel",
    "motion_free_kernel",
    "states_free_kernel",
]
