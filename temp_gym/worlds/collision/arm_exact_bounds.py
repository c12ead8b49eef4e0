"""The exact checker's cheap bounds at one pose of a certified motion, compiled.

A motion's certification (`temp_gym.worlds.collision.arm_exact`) takes hundreds of steps near
obstacles, and at each it needs the bodies' poses, every body's world-AABB gap to every
obstacle and every enabled pair's bounding-sphere gap before it decides what fcl must measure.
Computed with numpy, these three cost more than the fcl calls they save; `pose_bounds` computes
them in one compiled call. The bounding-box gaps are `aabb_gaps_into`'s, which
`ArmExactChecker._aabb_gaps` calls too; the sphere gaps are `BodyHulls.sphere_gaps`'s arithmetic
for one pose (that method keeps numpy for batches of poses), up to the order of a few roundings.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from temp_gym.worlds.arm.kinematics import chain_into


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
        for i in range(3):
            center[i] = (poses[j, i, 0] * local_center[j, 0] + poses[j, i, 1] * local_center[j, 1]
                         + poses[j, i, 2] * local_center[j, 2]) + poses[j, i, 3]  # fmt: skip
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
def pose_bounds(q, kind, rotation, shift, local_center, local_half, aabb_center, aabb_half,
                sphere_centers, sphere_radii, pairs, poses, gaps, sphere_gaps) -> None:  # fmt: skip
    """Fill ``poses``, ``gaps`` and ``sphere_gaps`` for the configuration ``q``.

    ``poses`` (B, 3, 4), whose first entry is the identity, gets the body poses (exact sines,
    as `ArmModel.forward_kinematics`); ``gaps`` (B, M) the distance from each body's local box
    (``local_center``, ``local_half``), posed and enlarged to a world AABB, to each obstacle's
    AABB; ``sphere_gaps`` (P,) the distance between each pair's bounding spheres (negative:
    overlap). All are lower bounds on the true distances.
    """
    dim = q.shape[0]
    sines, cosines = np.empty(dim), np.empty(dim)
    for i in range(dim):
        sines[i], cosines[i] = math.sin(q[i]), math.cos(q[i])
    chain_into(poses, kind, rotation, shift, cosines, sines, 0, q, 0)
    aabb_gaps_into(poses, local_center, local_half, aabb_center, aabb_half, gaps)
    bodies = gaps.shape[0]
    world = np.empty((bodies, 3))
    for j in range(bodies):
        for i in range(3):
            world[j, i] = (poses[j, i, 0] * sphere_centers[j, 0]
                           + poses[j, i, 1] * sphere_centers[j, 1]
                           + poses[j, i, 2] * sphere_centers[j, 2]) + poses[j, i, 3]  # fmt: skip
    for p in range(pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        dx = world[a, 0] - world[b, 0]
        dy = world[a, 1] - world[b, 1]
        dz = world[a, 2] - world[b, 2]
        sphere_gaps[p] = math.sqrt(dx * dx + dy * dy + dz * dz) - sphere_radii[a] - sphere_radii[b]


__all__ = ["aabb_gaps_into", "pose_bounds"]
