"""The fast iiwa checker's compiled kernels: states and edges against boxes and itself.

`temp_gym.worlds.collision.iiwa_fast` prepares the arrays and explains why the tests are
conservative and certify whole motions; `temp_gym.worlds.collision.iiwa_fast_self` holds the
self-collision tests these kernels call. Arrays come unpacked and are indexed whole, never
sliced: tuple unpacking and row views cost atomic reference counts in the hot loop, and so do
calls to non-inlined functions, which is why the self-collision pairs are first screened here,
on the bounding-sphere centers the box broad phase has just computed.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from temp_gym.worlds.collision.iiwa_fast_self import (
    FAST_SELF_GAP,
    bounds_apart,
    pair_free,
    pairs_free,
    tables_free,
)
from temp_gym.worlds.iiwa14.kinematics import joint_step_into, sincos_into


@numba.njit(cache=True, nogil=True, inline="always")
def sphere_hits_box(x, y, z, radius, box_params, b) -> bool:
    """Closed sphere versus closed box ``box_params[b] = (cx, cy, cz, hx, hy, hz)``."""
    gx = max(abs(x - box_params[b, 0]) - box_params[b, 3], 0.0)
    gy = max(abs(y - box_params[b, 1]) - box_params[b, 4], 0.0)
    gz = max(abs(z - box_params[b, 2]) - box_params[b, 5], 0.0)
    return gx * gx + gy * gy + gz * gz <= radius * radius


@numba.njit(cache=True, nogil=True, inline="always")
def _in_bounds(states, i, bounds) -> bool:
    """Whether ``states[i]`` is within ``bounds`` (indexed whole: row views cost refcounts)."""
    for k in range(states.shape[1]):
        # Written so that NaN fails the test.
        if not (states[i, k] >= bounds[0, k] and states[i, k] <= bounds[1, k]):
            return False
    return True


@numba.njit(cache=True, nogil=True)
def _pose_free(sines, cosines, base, perm, sign, shift, centers, radii, link_start,
               bound_centers, bound_radii, box_params, link_boxes, link_box_count, link_lower,
               link_upper, inflation, poses, link_bounds) -> bool:  # fmt: skip
    """Whether the moving links' spheres (grown by ``inflation[j]``) miss every box.

    ``sines[base + i]``, ``cosines[base + i]`` are joint ``i``'s; ``poses`` (8, 3, 4) is
    scratch whose first entry is the identity. When this returns True, ``poses`` holds the
    link frames and ``link_bounds`` (8, 3) the world centers of the links' bounding spheres
    (row 0, the base's, never changes): the self-collision test reads them. Arrays come
    unpacked and are indexed whole, never sliced: tuple unpacking and views cost atomic
    reference counting per call.
    """
    for j in range(perm.shape[0]):
        joint_step_into(poses, j, perm, sign, shift, cosines[base + j], sines[base + j])
    # Distal links first: they sweep the most space, so collisions are found sooner.
    for j in range(poses.shape[0] - 1, 0, -1):
        count = link_box_count[j]
        grow = inflation[j]
        c0, c1, c2 = bound_centers[j, 0], bound_centers[j, 1], bound_centers[j, 2]
        bx = poses[j, 0, 0] * c0 + poses[j, 0, 1] * c1 + poses[j, 0, 2] * c2 + poses[j, 0, 3]
        by = poses[j, 1, 0] * c0 + poses[j, 1, 1] * c1 + poses[j, 1, 2] * c2 + poses[j, 1, 3]
        bz = poses[j, 2, 0] * c0 + poses[j, 2, 1] * c1 + poses[j, 2, 2] * c2 + poses[j, 2, 3]
        link_bounds[j, 0], link_bounds[j, 1], link_bounds[j, 2] = bx, by, bz
        bound = bound_radii[j] + grow
        # Broad phase, branch-free so that LLVM makes it SIMD over the link's candidates.
        hits = 0
        for n in range(count):
            gx = max(max(link_lower[j, 0, n] - bx, bx - link_upper[j, 0, n]), 0.0)
            gy = max(max(link_lower[j, 1, n] - by, by - link_upper[j, 1, n]), 0.0)
            gz = max(max(link_lower[j, 2, n] - bz, bz - link_upper[j, 2, n]), 0.0)
            hits += gx * gx + gy * gy + gz * gz <= bound * bound
        if hits == 0:
            continue
        for n in range(count):
            b = link_boxes[j, n]
            if not sphere_hits_box(bx, by, bz, bound, box_params, b):
                continue
            for k in range(link_start[j], link_start[j + 1]):
                c0, c1, c2 = centers[k, 0], centers[k, 1], centers[k, 2]
                x = poses[j, 0, 0] * c0 + poses[j, 0, 1] * c1 + poses[j, 0, 2] * c2 + poses[j, 0, 3]
                y = poses[j, 1, 0] * c0 + poses[j, 1, 1] * c1 + poses[j, 1, 2] * c2 + poses[j, 1, 3]
                z = poses[j, 2, 0] * c0 + poses[j, 2, 1] * c1 + poses[j, 2, 2] * c2 + poses[j, 2, 3]
                if sphere_hits_box(x, y, z, radii[k] + grow, box_params, b):
                    return False
    return True


@numba.njit(cache=True, nogil=True)
def _identity_poses(count):
    poses = np.zeros((count, 3, 4))
    for r in range(3):
        poses[0, r, r] = 1.0
    return poses


_BLOCK = 256
"""States per block: sines and cosines are computed a block at a time, vectorized."""


@numba.njit(cache=True, nogil=True)
def states_free_kernel(states, bounds, kinematics, spheres, boxes, self_model, clearance, scratch):
    """``bool[N]``: each state in ``bounds`` and free, every sphere grown by ``clearance``.

    The tuples are `IiwaSphereChecker`'s arrays; ``scratch`` is `pairs_free`'s.
    """
    perm, sign, shift = kinematics
    centers, radii, link_start, bound_centers, bound_radii = spheres
    box_params, link_boxes, link_box_count, link_lower, link_upper = boxes
    sphere_pairs, table_pairs, table_grid, table_bounds, table_motion = self_model
    num, dim = states.shape
    out = np.zeros(num, dtype=np.bool_)
    # `clearance` between the links of a pair: all of it on one side. The base never moves
    # (an edge check never grows it either), so a pair with the base grows its other link only.
    table_growth = np.full(table_pairs.shape[0], clearance)
    poses = _identity_poses(dim + 1)
    link_bounds = bound_centers.copy()  # row 0 stays: the base never moves
    inflation = np.full(dim + 1, clearance)
    inflation[0] = 0.0
    flat = states.reshape(-1)
    sines = np.empty(_BLOCK * dim)
    cosines = np.empty(_BLOCK * dim)
    for first in range(0, num, _BLOCK):
        last = min(first + _BLOCK, num)
        sincos_into(flat[first * dim : last * dim], sines, cosines)
        for i in range(first, last):
            # The joint-space tables need no kinematics: they go first; the sphere pairs last.
            if not (_in_bounds(states, i, bounds) and tables_free(
                    flat, i * dim, table_grid, table_bounds, table_growth,
                    FAST_SELF_GAP)):  # fmt: skip
                continue
            boxes_free = _pose_free(sines, cosines, (i - first) * dim, perm, sign, shift, centers,
                                    radii, link_start, bound_centers, bound_radii, box_params,
                                    link_boxes, link_box_count, link_lower, link_upper, inflation,
                                    poses, link_bounds)  # fmt: skip
            # Most poses keep every pair's bounding spheres apart: no call, no narrow phase.
            out[i] = boxes_free and (
                bounds_apart(link_bounds, sphere_pairs, bound_radii, inflation, FAST_SELF_GAP)
                or pairs_free(poses, sphere_pairs, centers, radii, link_start, bound_centers,
                              bound_radii, inflation, FAST_SELF_GAP, scratch)
            )  # fmt: skip
    return out


@numba.njit(cache=True, nogil=True)
def _edge_free(starts, ends, e, bounds, perm, sign, shift, centers, radii, link_start,
               bound_centers, bound_radii, box_params, link_boxes, link_box_count, link_lower,
               link_upper, sphere_pairs, table_grid, table_bounds, table_motion, motion,
               resolution, poses, link_bounds, inflation, table_growth, q, sines, cosines,
               scratch) -> bool:  # fmt: skip
    """Whether edge ``starts[e] -> ends[e]`` is free (arrays unpacked, as in `_pose_free`)."""
    # The configuration space is a box: a segment with both ends in bounds stays in bounds.
    if not (_in_bounds(starts, e, bounds) and _in_bounds(ends, e, bounds)):
        return False
    dim = starts.shape[1]
    worst = 0.0
    for j in range(inflation.shape[0]):
        sweep = 0.0
        for i in range(dim):
            sweep += abs(ends[e, i] - starts[e, i]) * motion[i, j]
        inflation[j] = sweep
        worst = max(worst, sweep)
    steps = max(1, int(math.ceil(worst / resolution)))
    for j in range(inflation.shape[0]):
        inflation[j] /= 2.0 * steps
    # A tabulated pair moves relative to itself only through the joints between its links.
    for p in range(table_growth.shape[0]):
        sweep = 0.0
        for i in range(dim):
            sweep += abs(ends[e, i] - starts[e, i]) * table_motion[p, i]
        table_growth[p] = sweep / (2.0 * steps)
    # Endpoints first, then bisection order: k = stride * odd visits each 0 < k < steps once.
    order = np.empty(steps + 1, dtype=np.int64)
    order[0], order[1] = 0, steps
    count = 2
    stride = 1
    while stride < steps:
        stride *= 2
    stride //= 2
    while stride >= 1:
        for k in range(stride, steps, 2 * stride):
            order[count] = k
            count += 1
        stride //= 2
    for k in order:
        t = k / steps
        for i in range(dim):
            q[i] = starts[e, i] + t * (ends[e, i] - starts[e, i])
        if not tables_free(q, 0, table_grid, table_bounds, table_growth, FAST_SELF_GAP):
            return False
        sincos_into(q, sines, cosines)
        if not _pose_free(sines, cosines, 0, perm, sign, shift, centers, radii, link_start,
                          bound_centers, bound_radii, box_params, link_boxes, link_box_count,
                          link_lower, link_upper, inflation, poses, link_bounds):  # fmt: skip
            return False
        pairs_clear = bounds_apart(link_bounds, sphere_pairs, bound_radii, inflation,
                                   FAST_SELF_GAP) or pairs_free(
            poses, sphere_pairs, centers, radii, link_start, bound_centers, bound_radii,
            inflation, FAST_SELF_GAP, scratch)  # fmt: skip
        if not pairs_clear:
            return False
    return True


@numba.njit(cache=True, nogil=True)
def edges_free_kernel(starts, ends, bounds, kinematics, spheres, boxes, self_model, motion,
                      resolution, scratch):  # fmt: skip
    """``bool[N]``: each motion ``starts[e] -> ends[e]`` certified free (`_edge_free`)."""
    perm, sign, shift = kinematics
    centers, radii, link_start, bound_centers, bound_radii = spheres
    box_params, link_boxes, link_box_count, link_lower, link_upper = boxes
    sphere_pairs, table_pairs, table_grid, table_bounds, table_motion = self_model
    dim = starts.shape[1]
    poses = _identity_poses(dim + 1)
    link_bounds = bound_centers.copy()  # row 0 stays: the base never moves
    inflation = np.empty(dim + 1)
    table_growth = np.empty(table_pairs.shape[0])
    q, sines, cosines = np.empty(dim), np.empty(dim), np.empty(dim)
    out = np.empty(starts.shape[0], dtype=np.bool_)
    for e in range(starts.shape[0]):
        out[e] = _edge_free(starts, ends, e, bounds, perm, sign, shift, centers, radii,
                            link_start, bound_centers, bound_radii, box_params, link_boxes,
                            link_box_count, link_lower, link_upper, sphere_pairs, table_grid,
                            table_bounds, table_motion, motion, resolution, poses, link_bounds,
                            inflation, table_growth, q, sines, cosines, scratch)  # fmt: skip
    return out


@numba.njit(cache=True, nogil=True)
def motion_free_kernel(context, start, end) -> bool:
    """One motion ``start -> end`` (float64 ``(7,)``) by `_edge_free`, for compiled callers.

    ``context`` is `IiwaSphereChecker.compiled_context`: the checker's arrays plus the scratch
    space `edges_free_kernel` would allocate, so a call allocates nothing.
    """
    settings, bounds, kinematics, spheres, boxes, self_model, motion, scratch, work = context
    if settings[0] == 0.0:  # the base link collides: nothing is free
        return False
    perm, sign, shift = kinematics
    centers, radii, link_start, bound_centers, bound_radii = spheres
    box_params, link_boxes, link_box_count, link_lower, link_upper = boxes
    sphere_pairs, table_pairs, table_grid, table_bounds, table_motion = self_model
    starts, ends, poses, link_bounds, inflation, table_growth, q, sines, cosines = work
    for i in range(start.shape[0]):
        starts[0, i] = start[i]
        ends[0, i] = end[i]
    return _edge_free(starts, ends, 0, bounds, perm, sign, shift, centers, radii, link_start,
                      bound_centers, bound_radii, box_params, link_boxes, link_box_count,
                      link_lower, link_upper, sphere_pairs, table_grid, table_bounds,
                      table_motion, motion, settings[1], poses, link_bounds, inflation,
                      table_growth, q, sines, cosines, scratch)  # fmt: skip


@numba.njit(cache=True, nogil=True)
def colliding_pairs_kernel(state, kinematics, spheres, self_model, scratch):
    """``(sphere pairs hit, table pairs hit)``: which pairs of one state ``(7,)`` collide."""
    perm, sign, shift = kinematics
    centers, radii, link_start, bound_centers, bound_radii = spheres
    sphere_pairs, table_pairs, table_grid, table_bounds, table_motion = self_model
    dim = state.shape[0]
    poses = _identity_poses(dim + 1)
    inflation = np.zeros(dim + 1)
    sines, cosines = np.empty(dim), np.empty(dim)
    sincos_into(state, sines, cosines)
    for j in range(dim):
        joint_step_into(poses, j, perm, sign, shift, cosines[j], sines[j])
    spheres_hit = np.zeros(sphere_pairs.shape[0], dtype=np.bool_)
    for p in range(sphere_pairs.shape[0]):
        spheres_hit[p] = not pair_free(poses, p, sphere_pairs, centers, radii, link_start,
                                       bound_centers, bound_radii, inflation, FAST_SELF_GAP,
                                       scratch)  # fmt: skip
    tables_hit = np.zeros(table_pairs.shape[0], dtype=np.bool_)
    for p in range(table_pairs.shape[0]):
        tables_hit[p] = not tables_free(state, 0, table_grid[p : p + 1], table_bounds[p : p + 1],
                                        np.zeros(1), FAST_SELF_GAP)  # fmt: skip
    return spheres_hit, tables_hit


__all__ = [
    "colliding_pairs_kernel",
    "edges_free_kernel",
    "motion_free_kernel",
    "sphere_hits_box",
    "states_free_kernel",
]
