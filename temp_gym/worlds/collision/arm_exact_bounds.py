"""The exact checker's cheap bounds at one pose of a certified motion, compiled.

A motion's certification (`temp_gym.worlds.collision.arm_exact`) takes hundreds of steps near
obstacles, and at each it needs the bodies' poses, every body's world-AABB gap to every
obstacle and every enabled pair's bounding-sphere gap before it decides what fcl must measure.
Computed with numpy, these three cost more than the fcl calls they save; `pose_bounds` computes
them in one compiled call. The bounding-box gaps are `aabb_gaps_into`'s, which
`ArmExactChecker._aabb_gaps` calls too; the sphere gaps are `BodyHulls.sphere_gaps`'s arithmetic
for one pose (that method keeps numpy for batches of poses), up to the order of a few roundings.

The bookkeeping between those bounds and fcl is compiled too, for the same reason: the bounds
carried from the last two poses (`carried_bounds`), each body's and pair's cheap bound, the new
frontier and the order in which to measure (`cover_bounds`), and where a body's bounding box
stands (`box_center`). These repeat numpy's arithmetic element by element, so the certifier
measures the same poses and gives the same verdicts as when numpy did them.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from temp_gym.worlds.arm.kinematics import chain_into, place


@numba.njit(cache=True, nogil=True)
def aabb_gaps_into(poses, local_center, local_half, aabb_center, aabb_half, gaps) -> None:
    """Fill ``gaps`` (B, M) with lower bounds on the bodies' distances to the obstacles.

    Each body's local box, posed and enlarged to a world AABB, to each obstacle's AABB (0 where
    they overlap). ``poses`` are (B, 3, 4) or (B, 4, 4).
    """
    bodies, obstacles = gaps.shape
    center = np.empty(3)
    half = np.empty(3)
    for j in range(bodies):
        center[0], center[1], center[2] = place(poses, j, local_center, j)
        for i in range(3):
            half[i] = (abs(poses[j, i, 0]) * local_half[j, 0]
                       + abs(poses[j, i, 1]) * local_half[j, 1]
                       + abs(poses[j, i, 2]) * local_half[j, 2])  # fmt: skip
        for b in range(obstacles):
            total = 0.0
            for i in range(3):
                gap = max((abs(center[i] - aabb_center[b, i]) - half[i]) - aabb_half[b, i], 0.0)
                total += gap * gap
            gaps[j, b] = math.sqrt(total)


@numba.njit(cache=True, nogil=True)
def pose_bounds(start, delta, t, kind, rotation, shift, local_center, local_half, aabb_center,
                aabb_half, sphere_centers, sphere_radii, pairs, poses, gaps,
                sphere_gaps) -> None:  # fmt: skip
    """Fill ``poses``, ``gaps`` and ``sphere_gaps`` for the configuration ``q = start + t delta``.

    ``poses`` (B, 3, 4), whose first entry is the identity, gets the body poses (exact sines,
    as `ArmModel.forward_kinematics`); ``gaps`` (B, M) the distance from each body's local box
    (``local_center``, ``local_half``), posed and enlarged to a world AABB, to each obstacle's
    AABB; ``sphere_gaps`` (P,) the distance between each pair's bounding spheres (negative:
    overlap). All are lower bounds on the true distances.
    """
    dim = start.shape[0]
    q, sines, cosines = np.empty(dim), np.empty(dim), np.empty(dim)
    for i in range(dim):
        q[i] = start[i] + t * delta[i]
        sines[i], cosines[i] = math.sin(q[i]), math.cos(q[i])
    chain_into(poses, kind, rotation, shift, cosines, sines, 0, q, 0)
    aabb_gaps_into(poses, local_center, local_half, aabb_center, aabb_half, gaps)
    bodies = gaps.shape[0]
    world = np.empty((bodies, 3))
    for j in range(bodies):
        world[j, 0], world[j, 1], world[j, 2] = place(poses, j, sphere_centers, j)
    for p in range(pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        dx = world[a, 0] - world[b, 0]
        dy = world[a, 1] - world[b, 1]
        dz = world[a, 2] - world[b, 2]
        sphere_gaps[p] = math.sqrt(dx * dx + dy * dy + dz * dz) - sphere_radii[a] - sphere_radii[b]


@numba.njit(cache=True, nogil=True)
def box_center(poses, j, local_center):
    """World center ``(3,)`` of body ``j``'s bounding box (``local_center[j]`` in its frame)."""
    center = np.empty(3)
    center[0], center[1], center[2] = place(poses, j, local_center, j)
    return center


@numba.njit(cache=True, nogil=True, inline="always")
def _maximum(a, b):
    """``np.maximum(a, b)`` of two floats: NaN if either is."""
    return b if b > a or b != b else a


@numba.njit(cache=True, nogil=True)
def carried_bounds(t, rates, last_t, last, before_t, before):
    """The clearance bounds that the last two poses measured carry to ``t``.

    ``last`` holds the bounds known at ``last_t``, ``before`` (empty when there is no such
    pose) those at ``before_t``; each, less its item's rate times the distance in ``t``, still
    holds at ``t``. The larger is kept.
    """
    carried = last - rates * abs(t - last_t)
    if before.shape[0]:
        elapsed = abs(t - before_t)
        for k in range(carried.shape[0]):
            carried[k] = _maximum(carried[k], before[k] - rates[k] * elapsed)
    return carried


@numba.njit(cache=True, nogil=True)
def cover_bounds(t, frontier, rates, carried, moving, moving_pairs, gaps, sphere_gaps,
                 tolerance, self_gap, safety):  # fmt: skip
    """The cheap part of one pose's cover: ``(bounds, pair_gaps, frontier, order)``.

    Items are the ``moving`` bodies, then the ``moving_pairs``. An item's cheap bound is its
    nearest AABB gap (``gaps`` rows, less ``tolerance``) or its pair's bounding-sphere gap less
    ``self_gap`` (``pair_gaps``, which `BodyHulls.pair_clearance` reads) and ``tolerance``, raised
    to ``carried`` when that is given (non-empty). The new ``frontier`` takes each item's span
    ``t +- safety * bound / rate`` where it meets the old one; ``order`` sorts the new frontier
    (stable). numpy's arithmetic, element by element, so the same numbers.
    """
    bodies = moving.shape[0]
    bounds = np.empty(bodies + moving_pairs.shape[0])
    for k in range(bodies):
        row = gaps[moving[k]]
        least = row[0]
        for b in range(1, row.shape[0]):
            if row[b] < least or row[b] != row[b]:
                least = row[b]
        bounds[k] = least - tolerance
    pair_gaps = np.empty(moving_pairs.shape[0])
    for p in range(moving_pairs.shape[0]):
        pair_gaps[p] = sphere_gaps[moving_pairs[p]] - self_gap
        bounds[bodies + p] = pair_gaps[p] - tolerance
    if carried.shape[0]:
        for k in range(bounds.shape[0]):
            bounds[k] = _maximum(bounds[k], carried[k])
    out = frontier.copy()
    for k in range(bounds.shape[0]):
        reach = safety * bounds[k] / rates[k]
        if t - reach <= frontier[k]:
            out[k] = _maximum(frontier[k], t + reach)
    return bounds, pair_gaps, out, np.argsort(out, kind="mergesort")


__all__ = ["aabb_gaps_into", "box_center", "carried_bounds", "cover_bounds", "pose_bounds"]
