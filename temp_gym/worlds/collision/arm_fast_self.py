"""Self-collision in the fast arm checker, for the body pairs the collision matrix enables.

Compiled helpers that `temp_gym.worlds.collision.arm_fast_kernels` calls inside its state and
edge kernels, on the joint values and body poses those kernels already have. Two tests:

* **Joint-space tables** for close pairs two joints apart: a lookup of a certified lower bound
  on the pair's padded distance in the cell of the first joint's value
  (`temp_gym.worlds.arm.pair_tables`). The pair is free when the bound exceeds the two bodies'
  growth plus ``2 * DISTANCE_TOLERANCE``.
* **Sphere trees against each other** for the other pairs: the leaves of body ``b`` that reach
  body ``a``'s root sphere are placed in the world once, and each walks ``a``'s tree.

**Conservative.** The leaves of body ``j`` cover its convex pieces
(`temp_gym.worlds.arm.spheres`). The exact checker calls bodies ``a`` and ``b`` colliding when
fcl's piece distance, less its tolerance, is at most the padding gap ``G``
(`temp_gym.worlds.collision.arm_self`), so when the true distance is at most
``G + 2 * DISTANCE_TOLERANCE``: then points ``x`` of ``a`` and ``y`` of ``b`` lie that close, some
leaf ``(c_a, r_a)`` holds ``x`` and some ``(c_b, r_b)`` holds ``y``, and ``|c_a - c_b| <= r_a + r_b
+ G + 2 * DISTANCE_TOLERANCE``: the test `FAST_SELF_GAP` makes. A table entry bounds the true
padded distance from below over its whole cell, so a pose the table calls free has true
distance above the gap plus ``2 * DISTANCE_TOLERANCE``.

**Motions.** In an edge check body ``j``'s spheres are grown by ``g_j`` (the distance any of
its points moves between a checked pose and the poses it stands for; see `arm_fast`), and a
pair is tested with both grown radii; a table pair's bound must exceed the pair's relative
motion over the same span. So the test certifies the relative motion of the pair.
"""

from __future__ import annotations

import numba
import numpy as np

from temp_gym.worlds.collision.arm_self import DISTANCE_TOLERANCE, SELF_COLLISION_GAP

FAST_SELF_GAP = SELF_COLLISION_GAP + 2 * DISTANCE_TOLERANCE
"""Two spheres of an enabled pair this close (m) or closer count as a self-collision."""


@numba.njit(cache=True, nogil=True, inline="always")
def place(poses, j, centers, k):
    """World position of row ``k`` of ``centers``, a point of body ``j`` (poses (B, 3, 4))."""
    c0, c1, c2 = centers[k, 0], centers[k, 1], centers[k, 2]
    x = poses[j, 0, 0] * c0 + poses[j, 0, 1] * c1 + poses[j, 0, 2] * c2 + poses[j, 0, 3]
    y = poses[j, 1, 0] * c0 + poses[j, 1, 1] * c1 + poses[j, 1, 2] * c2 + poses[j, 1, 3]
    z = poses[j, 2, 0] * c0 + poses[j, 2, 1] * c1 + poses[j, 2, 2] * c2 + poses[j, 2, 3]
    return x, y, z


@numba.njit(cache=True, nogil=True, inline="always")
def _near(x0, y0, z0, x1, y1, z1, reach) -> bool:
    dx, dy, dz = x0 - x1, y0 - y1, z0 - z1
    return dx * dx + dy * dy + dz * dz <= reach * reach


@numba.njit(cache=True, nogil=True)
def tree_hits_sphere(poses, j, node_centers, node_radii, node_skip, node_first, node_count,
                     body_start, centers, radii, grow, x, y, z, reach) -> bool:  # fmt: skip
    """Whether a leaf of body ``j``, grown by ``grow``, comes within ``reach`` of ``(x, y, z)``."""
    n = body_start[j]
    end = body_start[j + 1]
    while n < end:
        nx, ny, nz = place(poses, j, node_centers, n)
        if _near(nx, ny, nz, x, y, z, node_radii[n] + grow + reach):
            count = node_count[n]
            if count > 0:
                for k in range(node_first[n], node_first[n] + count):
                    kx, ky, kz = place(poses, j, centers, k)
                    if _near(kx, ky, kz, x, y, z, radii[k] + grow + reach):
                        return True
                n = node_skip[n]
            else:
                n += 1
        else:
            n = node_skip[n]
    return False


@numba.njit(cache=True, nogil=True)
def pair_free(poses, a, b, node_centers, node_radii, node_skip, node_first, node_count,
              body_start, centers, radii, inflation, gap, scratch) -> bool:  # fmt: skip
    """Whether the grown leaves of bodies ``a`` and ``b`` stay more than ``gap`` apart.

    ``scratch`` is ``(>= leaves per body, 4)``.
    """
    root_a, root_b = body_start[a], body_start[b]
    if root_a == body_start[a + 1] or root_b == body_start[b + 1]:
        return True
    ax, ay, az = place(poses, a, node_centers, root_a)
    reach_a = node_radii[root_a] + inflation[a]
    grow_b = inflation[b]
    # The leaves of b near a's root sphere, placed once.
    count = 0
    n = root_b
    end = body_start[b + 1]
    while n < end:
        nx, ny, nz = place(poses, b, node_centers, n)
        if _near(nx, ny, nz, ax, ay, az, node_radii[n] + grow_b + reach_a + gap):
            leaves = node_count[n]
            if leaves > 0:
                for k in range(node_first[n], node_first[n] + leaves):
                    kx, ky, kz = place(poses, b, centers, k)
                    r = radii[k] + grow_b
                    if _near(kx, ky, kz, ax, ay, az, r + reach_a + gap):
                        scratch[count, 0], scratch[count, 1] = kx, ky
                        scratch[count, 2], scratch[count, 3] = kz, r
                        count += 1
                n = node_skip[n]
            else:
                n += 1
        else:
            n = node_skip[n]
    for m in range(count):
        if tree_hits_sphere(poses, a, node_centers, node_radii, node_skip, node_first,
                            node_count, body_start, centers, radii, inflation[a], scratch[m, 0],
                            scratch[m, 1], scratch[m, 2], scratch[m, 3] + gap):  # fmt: skip
            return False
    return True


@numba.njit(cache=True, nogil=True, inline="always")
def roots_apart(root_world, pairs, node_radii, body_start, inflation, gap) -> bool:
    """Whether every pair's grown root spheres are more than ``gap`` apart (broad phase).

    ``root_world`` (B, 3) holds the roots' world centers.
    """
    for p in range(pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        reach = (node_radii[body_start[a]] + inflation[a] + node_radii[body_start[b]]
                 + inflation[b] + gap)  # fmt: skip
        if _near(root_world[a, 0], root_world[a, 1], root_world[a, 2], root_world[b, 0],
                 root_world[b, 1], root_world[b, 2], reach):  # fmt: skip
            return False
    return True


@numba.njit(cache=True, nogil=True)
def pairs_free(poses, pairs, node_centers, node_radii, node_skip, node_first, node_count,
               body_start, centers, radii, inflation, gap, scratch) -> bool:  # fmt: skip
    """Whether every enabled pair is free (`pair_free`), stopping at the first collision."""
    for p in range(pairs.shape[0]):
        if not pair_free(poses, pairs[p, 0], pairs[p, 1], node_centers, node_radii, node_skip,
                         node_first, node_count, body_start, centers, radii, inflation, gap,
                         scratch):  # fmt: skip
            return False
    return True


@numba.njit(cache=True, nogil=True)
def tables_free(values, base, table_grid, table_bounds, growth, gap) -> bool:
    """Whether each tabulated pair's bound at ``values[base:]`` exceeds ``gap + growth[p]``.

    ``table_grid[p] = (joint, lower, cell width, cells)`` locates the value's cell in
    ``table_bounds[p]``. The values must be within the joint limits (checked before).
    """
    for p in range(table_grid.shape[0]):
        joint = int(table_grid[p, 0])
        cell = int((values[base + joint] - table_grid[p, 1]) / table_grid[p, 2])
        cell = min(max(cell, 0), int(table_grid[p, 3]) - 1)
        if not table_bounds[p, cell] > gap + growth[p]:
            return False
    return True


def scratch_for(trees) -> np.ndarray:
    """The ``scratch`` array `pair_free` needs for these sphere trees."""
    leaves = np.bincount(trees.sphere_body, minlength=len(trees.body_start) - 1)
    return np.empty((max(int(leaves.max(initial=1)), 1), 4))


__all__ = [
    "FAST_SELF_GAP",
    "pair_free",
    "pairs_free",
    "place",
    "roots_apart",
    "scratch_for",
    "tables_free",
    "tree_hits_sphere",
]
