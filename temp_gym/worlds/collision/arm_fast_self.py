"""Self-collision in the fast arm checker, for the body pairs the collision matrix enables.

Compiled helpers that `temp_gym.worlds.collision.arm_fast_kernels` calls inside its state and
edge kernels, on the joint values and body poses those kernels already have. Two tests:

* **Joint-space tables** for close pairs two joints apart: a lookup of a certified lower bound
  on the pair's padded distance in the cell of the two joints' values
  (`temp_gym.worlds.arm.pair_tables`). The pair is free when the bound exceeds the two bodies'
  growth plus ``2 * DISTANCE_TOLERANCE``.
* **Sphere trees against each other** for the other pairs: both trees walked at once, from
  their roots down to the pairs of leaf nodes whose spheres meet; or, when the pair's first
  body has a distance field, the second body's tree walked against that field
  (`temp_gym.worlds.collision.arm_fast_fields`), with the same verdict.

**Conservative.** The leaves of body ``j`` cover its convex pieces
(`temp_gym.worlds.arm.spheres`). The exact checker calls bodies ``a`` and ``b`` colliding when
fcl's piece distance, less its tolerance, is at most the padding gap ``G``
(`temp_gym.worlds.collision.arm_self`), so when the true distance is at most
``G + 2 * DISTANCE_TOLERANCE``: then points ``x`` of ``a`` and ``y`` of ``b`` lie that close, some
leaf ``(c_a, r_a)`` holds ``x`` and some ``(c_b, r_b)`` holds ``y``, and ``|c_a - c_b| <= r_a + r_b
+ G + 2 * DISTANCE_TOLERANCE``: the test `FAST_SELF_GAP` makes. A table entry bounds the true
padded distance from below over its whole cell, so a pose the table calls free has true
distance above the gap plus ``2 * DISTANCE_TOLERANCE``.

**Motions.** A pair is tested with its own growth, ``growth[p] = (g_a, g_b)``, added to the
two bodies' radii. In an edge check that is the pair's *relative* motion: in body ``a``'s frame
only the joints between the two bodies move body ``b``, so ``g_a = 0`` and ``g_b`` bounds how
far a point of ``b`` moves relative to ``a`` between a checked pose and the poses it stands
for: those joints' motions times their lever arms to ``b`` along the edge
(`temp_gym.worlds.arm.kinematics.segment_levers_into`); the shoulder's large sweep, which
carries both bodies as one, does not count. A table pair's bound must exceed the same relative
motion, with the arm's lever arms for every configuration (`ArmModel.relative_motion_radii`).
In a state check with a clearance both bodies grow by it.
"""

from __future__ import annotations

import numba
import numpy as np

from temp_gym.worlds.arm.kinematics import place, place_point
from temp_gym.worlds.collision.arm_fast_fields import field_pair_free
from temp_gym.worlds.collision.arm_self import DISTANCE_TOLERANCE, SELF_COLLISION_GAP
from temp_gym.worlds.hot_path import hot_inline

FAST_SELF_GAP = SELF_COLLISION_GAP + 2 * DISTANCE_TOLERANCE
"""Two spheres of an enabled pair this close (m) or closer count as a self-collision."""
TABLE_MARGIN = 2 * DISTANCE_TOLERANCE
"""A tabulated pair is free when its bound (which already has the gap taken off) exceeds the
growth by more than this: fcl's tolerance at the cell's center and at the pose."""


@numba.njit(cache=True, nogil=True, inline="always")
def _near(x0, y0, z0, x1, y1, z1, reach) -> bool:
    dx, dy, dz = x0 - x1, y0 - y1, z0 - z1
    return dx * dx + dy * dy + dz * dz <= reach * reach


@hot_inline
def _segments_apart(poses, a, b, capsules, reach) -> bool:
    """Whether the axes of bodies ``a`` and ``b``'s capsules are more than ``reach`` apart.

    The closest points of two segments (Ericson, Real-Time Collision Detection, 5.1.9), with
    an allowance for rounding: a "yes" is certain.
    """
    px, py, pz = place_point(poses, a, capsules[a, 0], capsules[a, 1], capsules[a, 2])
    qx, qy, qz = place_point(poses, a, capsules[a, 3], capsules[a, 4], capsules[a, 5])
    rx, ry, rz = place_point(poses, b, capsules[b, 0], capsules[b, 1], capsules[b, 2])
    sx, sy, sz = place_point(poses, b, capsules[b, 3], capsules[b, 4], capsules[b, 5])
    d1x, d1y, d1z = qx - px, qy - py, qz - pz
    d2x, d2y, d2z = sx - rx, sy - ry, sz - rz
    wx, wy, wz = px - rx, py - ry, pz - rz
    a11 = d1x * d1x + d1y * d1y + d1z * d1z
    a22 = d2x * d2x + d2y * d2y + d2z * d2z
    b12 = d1x * d2x + d1y * d2y + d1z * d2z
    c1 = d1x * wx + d1y * wy + d1z * wz
    c2 = d2x * wx + d2y * wy + d2z * wz
    tiny = 1e-18
    if a11 <= tiny and a22 <= tiny:
        s, t = 0.0, 0.0
    elif a11 <= tiny:
        s, t = 0.0, min(max(c2 / a22, 0.0), 1.0)
    elif a22 <= tiny:
        s, t = min(max(-c1 / a11, 0.0), 1.0), 0.0
    else:
        denominator = a11 * a22 - b12 * b12
        s = min(max((b12 * c2 - c1 * a22) / denominator, 0.0), 1.0) if denominator > tiny else 0.0
        t = (b12 * s + c2) / a22
        if t < 0.0:
            s, t = min(max(-c1 / a11, 0.0), 1.0), 0.0
        elif t > 1.0:
            s, t = min(max((b12 - c1) / a11, 0.0), 1.0), 1.0
    dx = wx + s * d1x - t * d2x
    dy = wy + s * d1y - t * d2y
    dz = wz + s * d1z - t * d2z
    # Any s, t in [0, 1] give an upper bound on the distance; these give the least, up to
    # rounding: allow a micrometre.
    allowed = reach + 1e-6
    return dx * dx + dy * dy + dz * dz > allowed * allowed


@hot_inline
def pair_free(poses, a, b, node_centers, node_radii, node_skip, node_first, node_count,
              body_start, centers, radii, inner_centers, inner_radii, inner_start, capsules,
              field_values, field_layout, grow_a, grow_b, gap, stack) -> bool:  # fmt: skip
    """Whether the leaves of ``a`` and ``b``, grown by ``grow_a`` and ``grow_b``, stay apart.

    Apart: more than ``gap``.

    A walk of both trees at once: a pair of nodes whose spheres are apart is dropped, else the
    larger inner node of the two is split, and two leaf nodes compare their leaf spheres. Two
    bodies whose root spheres overlap but whose pieces are apart are told apart a few levels
    down. First, capsules that hold each body's leaves and are apart end the test (free), and
    so do two inner balls (inside the bodies' pieces) that overlap (in collision). When body
    ``a`` has a distance field (``field_layout[a, 0] >= 0``, `arm_fast_fields`), ``b``'s tree
    is walked against it instead, with the same verdict. ``stack`` is
    ``(>= 2 * (depth of a + depth of b) + 2, 2)`` scratch (`scratch_for`).
    """
    root_a, root_b = body_start[a], body_start[b]
    if root_a == body_start[a + 1] or root_b == body_start[b + 1]:
        return True
    ax, ay, az = place(poses, a, node_centers, root_a)
    bx, by, bz = place(poses, b, node_centers, root_b)
    if not _near(ax, ay, az, bx, by, bz,
                 node_radii[root_a] + grow_a + node_radii[root_b] + grow_b + gap):  # fmt: skip
        return True
    if _segments_apart(poses, a, b, capsules,
                       capsules[a, 6] + grow_a + capsules[b, 6] + grow_b + gap):  # fmt: skip
        return True
    for i in range(inner_start[a], inner_start[a + 1]):
        ix, iy, iz = place(poses, a, inner_centers, i)
        for k in range(inner_start[b], inner_start[b + 1]):
            kx, ky, kz = place(poses, b, inner_centers, k)
            if _near(ix, iy, iz, kx, ky, kz, inner_radii[i] + inner_radii[k]):
                return False
    if field_layout[a, 0] >= 0.0:
        return field_pair_free(poses, a, b, node_centers, node_radii, node_skip, node_first,
                               node_count, body_start, centers, radii, field_values,
                               field_layout, grow_a, grow_b, gap, stack)  # fmt: skip
    stack[0, 0], stack[0, 1] = root_a, root_b
    top = 1
    while top > 0:
        top -= 1
        na, nb = int(stack[top, 0]), int(stack[top, 1])
        ax, ay, az = place(poses, a, node_centers, na)
        bx, by, bz = place(poses, b, node_centers, nb)
        if not _near(ax, ay, az, bx, by, bz,
                     node_radii[na] + grow_a + node_radii[nb] + grow_b + gap):  # fmt: skip
            continue
        leaf_a, leaf_b = node_count[na] > 0, node_count[nb] > 0
        if leaf_a and leaf_b:
            for i in range(node_first[na], node_first[na] + node_count[na]):
                ix, iy, iz = place(poses, a, centers, i)
                for k in range(node_first[nb], node_first[nb] + node_count[nb]):
                    kx, ky, kz = place(poses, b, centers, k)
                    if _near(ix, iy, iz, kx, ky, kz, radii[i] + grow_a + radii[k] + grow_b + gap):
                        return False
        elif leaf_b or (not leaf_a and node_radii[na] >= node_radii[nb]):
            # An inner node's children: the next node and the one after its subtree.
            stack[top, 0], stack[top, 1] = na + 1, nb
            stack[top + 1, 0], stack[top + 1, 1] = node_skip[na + 1], nb
            top += 2
        else:
            stack[top, 0], stack[top, 1] = na, nb + 1
            stack[top + 1, 0], stack[top + 1, 1] = na, node_skip[nb + 1]
            top += 2
    return True


@hot_inline
def roots_apart(root_world, pairs, node_radii, body_start, growth, gap) -> bool:
    """Whether every pair's grown root spheres are more than ``gap`` apart (broad phase).

    ``root_world`` (B, 3) holds the roots' world centers, ``growth[p]`` (P, 2) pair ``p``'s
    growth of its two bodies.
    """
    for p in range(pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        reach = (node_radii[body_start[a]] + growth[p, 0] + node_radii[body_start[b]]
                 + growth[p, 1] + gap)  # fmt: skip
        if _near(root_world[a, 0], root_world[a, 1], root_world[a, 2], root_world[b, 0],
                 root_world[b, 1], root_world[b, 2], reach):  # fmt: skip
            return False
    return True


@hot_inline
def pairs_free(poses, pairs, node_centers, node_radii, node_skip, node_first, node_count,
               body_start, centers, radii, inner_centers, inner_radii, inner_start, capsules,
               field_values, field_layout, growth, gap, stack) -> bool:  # fmt: skip
    """Whether every enabled pair is free (`pair_free`), stopping at the first collision.

    ``growth[p]`` (P, 2) is pair ``p``'s growth of its two bodies (module docstring).
    """
    for p in range(pairs.shape[0]):
        if not pair_free(poses, pairs[p, 0], pairs[p, 1], node_centers, node_radii, node_skip,
                         node_first, node_count, body_start, centers, radii, inner_centers,
                         inner_radii, inner_start, capsules, field_values, field_layout,
                         growth[p, 0], growth[p, 1], gap, stack):  # fmt: skip
            return False
    return True


@hot_inline
def tables_free(values, base, table_grid, table_bounds, growth, margin) -> bool:
    """Whether each tabulated pair's bound at ``values[base:]`` exceeds ``margin + growth[p]``.

    The bounds have the collision gap taken off already (`TABLE_MARGIN` is the margin to use).

    ``table_grid[p]`` locates the cell of the two joints' values in ``table_bounds[p]``
    (`temp_gym.worlds.arm.pair_tables.table_arrays`). The values must be within the joint
    limits (checked before).
    """
    for p in range(table_grid.shape[0]):
        joint = int(table_grid[p, 0])
        cells = int(table_grid[p, 6])
        first = int((values[base + joint] - table_grid[p, 1]) / table_grid[p, 2])
        first = min(max(first, 0), int(table_grid[p, 3]) - 1)
        second = int((values[base + joint + 1] - table_grid[p, 4]) / table_grid[p, 5])
        second = min(max(second, 0), cells - 1)
        if not table_bounds[p, first * cells + second] > margin + growth[p]:
            return False
    return True


def scratch_for(trees) -> np.ndarray:
    """The ``stack`` array `pair_free` needs for these sphere trees (two rows per level)."""
    deepest = 1
    for j in range(len(trees.body_start) - 1):
        nodes = int(trees.body_start[j + 1] - trees.body_start[j])
        deepest = max(deepest, int(np.ceil(np.log2(nodes + 1))) + 1 if nodes else 1)
    return np.empty((4 * deepest + 2, 2))


__all__ = [
    "FAST_SELF_GAP",
    "TABLE_MARGIN",
    "pair_free",
    "pairs_free",
    "place",
    "place_point",
    "roots_apart",
    "scratch_for",
    "tables_free",
]
