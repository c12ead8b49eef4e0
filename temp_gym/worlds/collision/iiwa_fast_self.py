"""Self-collision in the fast iiwa checker, for the link pairs the collision matrix enables.

Compiled helpers that `temp_gym.worlds.collision.iiwa_fast` calls inside its state and edge
kernels, on the joint angles and link poses those kernels already have. Two tests:

* **Joint-space tables** for pairs two joints apart (link_5 - link_7): a lookup of a certified
  lower bound on the pair's padded hull distance in the cell of the first joint's angle
  (`temp_gym.worlds.iiwa14.pair_tables`). The pair is free when the bound exceeds the two
  links' growth (below) plus ``2 * DISTANCE_TOLERANCE``. These links are a few centimetres
  apart in every pose, so spheres would have to be tiny and many not to overlap everywhere.
* **Sphere against sphere** for the other pairs (the base against the forearm and wrist).

Both run after the box tests and stop at the first colliding pair.

**Conservative (spheres).** The spheres of link ``j`` cover its solid convex hull
(`temp_gym.worlds.iiwa14.sphere_fit`). The exact checker calls links ``a`` and ``b`` colliding
when fcl's hull distance, less its tolerance, is at most the padding gap ``G``
(`temp_gym.worlds.collision.iiwa_self`), so when the true distance is at most
``G + 2 * DISTANCE_TOLERANCE``: then points ``x`` of hull ``a`` and ``y`` of hull ``b`` lie that
close, some sphere ``(c_a, r_a)`` holds ``x`` and some ``(c_b, r_b)`` holds ``y``, and
``|c_a - c_b| <= r_a + r_b + G + 2 * DISTANCE_TOLERANCE``. This test (`FAST_SELF_GAP`) is what
the kernel makes, so it never calls free a pose that the exact checker finds colliding.

**Conservative (tables).** An entry bounds the true padded distance from below over its
whole cell, so a pose the table calls free has true distance above the gap plus
``2 * DISTANCE_TOLERANCE``, and fcl's distance there, less its tolerance, is above the gap:
the exact checker calls it free too.

**Motions.** In an edge check link ``j``'s spheres are grown by ``g_j = W_j / (2 n)`` (see
`iiwa_fast`), and a pair is tested with both grown radii: ``|c_a - c_b| <= r_a + g_a + r_b + g_b
+ gap``. Every pose ``q(t)`` of the edge is within ``1 / (2 n)`` in ``t`` of a checked pose
``q(t_k)``, and in that time every point of hull ``j`` moves at most ``g_j`` (``W_j`` bounds the
motion of mesh vertices, hence of their convex combinations). So hull ``a`` at ``t`` lies in
the union of ``a``'s spheres at ``t_k`` grown by ``g_a``, and likewise for ``b``; if no grown
sphere of ``a`` comes within the gap of a grown sphere of ``b``, the hulls at ``t`` do not
either. The test therefore certifies the relative motion of the pair over the whole edge. A
table pair is certified the same way: between ``t_k`` and ``t`` the pair's distance shrinks by
at most ``g_a + g_b``, which is what its test asks the bound to exceed.

**Speed.** A pair is first tested on the links' bounding spheres (most pairs stop there); then
each sphere of ``b`` that reaches ``a``'s bounding sphere is placed in the world once, and each
sphere of ``a`` that reaches ``b``'s bounding sphere is tested against those. Any hit exits.
"""

from __future__ import annotations

import numba
import numpy as np

from temp_gym.worlds.collision.iiwa_self import DISTANCE_TOLERANCE, SELF_COLLISION_GAP

FAST_SELF_GAP = SELF_COLLISION_GAP + 2 * DISTANCE_TOLERANCE
"""Two spheres of an enabled pair this close (m) or closer count as a self-collision."""


@numba.njit(cache=True, nogil=True, inline="always")
def _place(poses, j, centers, k):
    """World position of row ``k`` of ``centers``, a point of link ``j`` (poses (8, 3, 4))."""
    c0, c1, c2 = centers[k, 0], centers[k, 1], centers[k, 2]
    x = poses[j, 0, 0] * c0 + poses[j, 0, 1] * c1 + poses[j, 0, 2] * c2 + poses[j, 0, 3]
    y = poses[j, 1, 0] * c0 + poses[j, 1, 1] * c1 + poses[j, 1, 2] * c2 + poses[j, 1, 3]
    z = poses[j, 2, 0] * c0 + poses[j, 2, 1] * c1 + poses[j, 2, 2] * c2 + poses[j, 2, 3]
    return x, y, z


@numba.njit(cache=True, nogil=True, inline="always")
def _apart(x0, y0, z0, x1, y1, z1, reach) -> bool:
    dx, dy, dz = x0 - x1, y0 - y1, z0 - z1
    return dx * dx + dy * dy + dz * dz > reach * reach


@numba.njit(cache=True, nogil=True, inline="always")
def pair_free(poses, p, pairs, centers, radii, link_start, bound_centers, bound_radii,
              inflation, gap, scratch) -> bool:  # fmt: skip
    """Whether the grown spheres of pair ``pairs[p] = (a, b)`` stay more than ``gap`` apart.

    ``inflation[j]`` grows link ``j``'s spheres; ``scratch`` is ``(>= spheres per link, 4)``.
    """
    a, b = pairs[p, 0], pairs[p, 1]
    ax, ay, az = _place(poses, a, bound_centers, a)
    bx, by, bz = _place(poses, b, bound_centers, b)
    reach_a = bound_radii[a] + inflation[a]
    reach_b = bound_radii[b] + inflation[b]
    if _apart(ax, ay, az, bx, by, bz, reach_a + reach_b + gap):
        return True
    count = 0
    for k in range(link_start[b], link_start[b + 1]):
        x, y, z = _place(poses, b, centers, k)
        r = radii[k] + inflation[b]
        if _apart(x, y, z, ax, ay, az, r + reach_a + gap):
            continue
        scratch[count, 0], scratch[count, 1], scratch[count, 2], scratch[count, 3] = x, y, z, r
        count += 1
    if count == 0:
        return True
    for k in range(link_start[a], link_start[a + 1]):
        x, y, z = _place(poses, a, centers, k)
        r = radii[k] + inflation[a]
        if _apart(x, y, z, bx, by, bz, r + reach_b + gap):
            continue
        for m in range(count):
            if not _apart(x, y, z, scratch[m, 0], scratch[m, 1], scratch[m, 2],
                          r + scratch[m, 3] + gap):  # fmt: skip
                return False
    return True


@numba.njit(cache=True, nogil=True, inline="always")
def bounds_apart(link_bounds, pairs, bound_radii, inflation, gap) -> bool:
    """Whether every pair's grown bounding spheres are more than ``gap`` apart (broad phase).

    ``link_bounds`` (8, 3) holds the spheres' world centers. When this is True no narrow
    phase is needed.
    """
    for p in range(pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        reach = bound_radii[a] + inflation[a] + bound_radii[b] + inflation[b] + gap
        if not _apart(link_bounds[a, 0], link_bounds[a, 1], link_bounds[a, 2], link_bounds[b, 0],
                      link_bounds[b, 1], link_bounds[b, 2], reach):  # fmt: skip
            return False
    return True


@numba.njit(cache=True, nogil=True)
def pairs_free(poses, pairs, centers, radii, link_start, bound_centers, bound_radii, inflation,
               gap, scratch) -> bool:  # fmt: skip
    """Whether every enabled pair is free (`pair_free`), stopping at the first collision."""
    for p in range(pairs.shape[0]):
        if not pair_free(poses, p, pairs, centers, radii, link_start, bound_centers,
                         bound_radii, inflation, gap, scratch):  # fmt: skip
            return False
    return True


@numba.njit(cache=True, nogil=True)
def tables_free(angles, base, table_grid, table_bounds, growth, gap) -> bool:
    """Whether each tabulated pair's bound at ``angles[base:]`` exceeds ``gap + growth[p]``.

    ``growth[p]`` is how much the pair's distance may shrink around the pose (its two links'
    clearance, or their relative motion in an edge check); ``table_grid[p] = (joint, lower,
    cell width, cells)`` locates the angle's cell in ``table_bounds[p]``. The angles must be
    within the joint limits (checked before).
    """
    for p in range(table_grid.shape[0]):
        joint = int(table_grid[p, 0])
        cell = int((angles[base + joint] - table_grid[p, 1]) / table_grid[p, 2])
        cell = min(max(cell, 0), int(table_grid[p, 3]) - 1)
        if not table_bounds[p, cell] > gap + growth[p]:
            return False
    return True


def scratch_for(link_start: np.ndarray) -> np.ndarray:
    """The ``scratch`` array `pair_free` needs for a sphere model with these link offsets."""
    return np.empty((int(np.max(np.diff(link_start))), 4))


__all__ = ["FAST_SELF_GAP", "bounds_apart", "pair_free", "pairs_free", "scratch_for", "tables_free"]
