"""The fast arm checker's sphere-versus-obstacle tests, for every obstacle kind.

`temp_gym.worlds.collision.arm_fast_kernels` calls `body_touches` once per moving body. The
obstacles live in two tables (`obstacle_tables`), and a body's candidate obstacles list rows of
the first, then rows of the second:

* **axis-aligned boxes**, rows of `BOX_COLUMNS` numbers ``(cx, cy, cz, hx, hy, hz)``, tested
  by `sphere_hits_box`: the arithmetic and the memory layout every box-only world has always
  been checked with;
* **other obstacles** (oriented boxes, cylinders, spheres), rows of `OBSTACLE_COLUMNS`
  numbers: center, half extents in the obstacle's frame, kind (`temp_gym.problem.obstacles`)
  and the rotation matrix row by row, tested by `sphere_hits_shape` in the obstacle's frame.

The tests take the list's kind as a constant (``any_kind``); inlined, the compiler drops the
other branch, so the boxes run the code they always ran and a world without other obstacles
pays one empty loop per body.

Every test is closed (touching counts) and exact up to rounding, so the fast checker stays
conservative: its spheres cover the arm (`temp_gym.worlds.collision.arm_fast`). A touch within
the spheres' bulge is not taken as a collision at once: `tree_hits` tells it apart, and the
body's convex pieces decide it (`temp_gym.worlds.collision.arm_fast_hulls`), in a second pass
that a state colliding elsewhere never reaches.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from temp_gym.problem.obstacles import CYLINDER, SPHERE
from temp_gym.worlds.arm.kinematics import place
from temp_gym.worlds.collision.arm_fast_hulls import pieces_clear
from temp_gym.worlds.hot_path import hot_inline

if TYPE_CHECKING:
    from temp_gym.worlds.collision.arm_obstacles import ArmObstacles

FREE, HIT, CERTAIN, UNSURE = 0, 1, 2, 3
"""Answers: free; a grown sphere touches an obstacle; an inner ball does (the state collides);
a first pass found only touches within the spheres' bulge (`body_touches`)."""
MISSED, DEEP, SHALLOW = 0, 1, 2
"""`tree_hits`'s answers: no leaf touches; one touches beyond the bulge; all within it."""
BOX_COLUMNS = 6
"""Numbers per axis-aligned box: center (3), half extents (3)."""
OBSTACLE_COLUMNS = 16
"""Numbers per other obstacle: center (3), half extents (3), kind (1), rotation (9, by rows)."""


def obstacle_tables(obstacles: ArmObstacles) -> tuple[np.ndarray, np.ndarray]:
    """``(boxes, others)``: the axis-aligned boxes' rows, then the other obstacles' rows.

    Each table keeps the obstacles' order; `ArmSphereChecker` maps an obstacle to its row.
    """
    aligned = obstacles.axis_aligned
    boxes = np.hstack([obstacles.centers[aligned], obstacles.half_extents[aligned]])
    others = np.zeros((int((~aligned).sum()), OBSTACLE_COLUMNS))
    others[:, :3] = obstacles.centers[~aligned]
    others[:, 3:6] = obstacles.half_extents[~aligned]
    others[:, 6] = obstacles.kinds[~aligned]
    others[:, 7:] = obstacles.rotations[~aligned].reshape(-1, 9)
    return boxes, others


@hot_inline
def sphere_hits_box(x, y, z, radius, box_params, b) -> bool:
    """Closed sphere versus closed box ``box_params[b] = (cx, cy, cz, hx, hy, hz)``."""
    gx = max(abs(x - box_params[b, 0]) - box_params[b, 3], 0.0)
    gy = max(abs(y - box_params[b, 1]) - box_params[b, 4], 0.0)
    gz = max(abs(z - box_params[b, 2]) - box_params[b, 5], 0.0)
    return gx * gx + gy * gy + gz * gz <= radius * radius


@hot_inline
def sphere_hits_shape(x, y, z, radius, shapes, s) -> bool:
    """Closed sphere versus the closed obstacle row ``shapes[s]`` of any kind.

    A sphere obstacle: center distance against the summed radii. A cylinder, in its frame:
    the distance from a point to it is the hypotenuse of the radial excess
    ``max(|xy| - r, 0)`` and the axial excess ``max(|z| - l, 0)``. A box, in its frame: the
    axis-aligned test.
    """
    dx = x - shapes[s, 0]
    dy = y - shapes[s, 1]
    dz = z - shapes[s, 2]
    kind = shapes[s, 6]
    if kind == SPHERE:
        reach = radius + shapes[s, 3]
        return dx * dx + dy * dy + dz * dz <= reach * reach
    # The point in the obstacle's frame, R^T (p - c); R's rows are columns 7-9, 10-12, 13-15.
    lx = shapes[s, 7] * dx + shapes[s, 10] * dy + shapes[s, 13] * dz
    ly = shapes[s, 8] * dx + shapes[s, 11] * dy + shapes[s, 14] * dz
    lz = shapes[s, 9] * dx + shapes[s, 12] * dy + shapes[s, 15] * dz
    if kind == CYLINDER:
        radial = max(math.sqrt(lx * lx + ly * ly) - shapes[s, 3], 0.0)
        axial = max(abs(lz) - shapes[s, 5], 0.0)
        return radial * radial + axial * axial <= radius * radius
    gx = max(abs(lx) - shapes[s, 3], 0.0)
    gy = max(abs(ly) - shapes[s, 4], 0.0)
    gz = max(abs(lz) - shapes[s, 5], 0.0)
    return gx * gx + gy * gy + gz * gz <= radius * radius


@hot_inline
def sphere_hits(x, y, z, radius, tables, b, any_kind) -> bool:
    """Row ``b`` of ``tables[1]`` (`sphere_hits_shape`) or of ``tables[0]`` (`sphere_hits_box`).

    ``any_kind`` picks the table and the test; it is a constant per caller.
    """
    if any_kind:
        return sphere_hits_shape(x, y, z, radius, tables[1], b)
    return sphere_hits_box(x, y, z, radius, tables[0], b)


@hot_inline
def tree_hits(poses, j, node_centers, node_radii, node_skip, node_first, node_count,
              body_start, centers, radii, grow, tables, b, any_kind, bulge,
              full) -> int:  # fmt: skip
    """How the leaf spheres of body ``j``, grown by ``grow``, touch obstacle ``b`` (a walk).

    `MISSED`: none does; `DEEP`: one still would, shrunk by ``bulge`` (how far a leaf may
    reach beyond its piece), so the touch is not the bulge's; `SHALLOW`: some do, all within
    the bulge (not ``full``: the first leaf that touches does). A negative ``bulge`` makes
    every touch `DEEP`.
    """
    shallow = False
    n = body_start[j]
    end = body_start[j + 1]
    while n < end:
        x, y, z = place(poses, j, node_centers, n)
        if sphere_hits(x, y, z, node_radii[n] + grow, tables, b, any_kind):
            count = node_count[n]
            if count > 0:
                for k in range(node_first[n], node_first[n] + count):
                    x, y, z = place(poses, j, centers, k)
                    reach = radii[k] + grow
                    if sphere_hits(x, y, z, reach, tables, b, any_kind):
                        if bulge < 0.0 or (reach > bulge and sphere_hits(
                                x, y, z, reach - bulge, tables, b, any_kind)):  # fmt: skip
                            return DEEP
                        if not full:
                            return SHALLOW
                        shallow = True
                n = node_skip[n]
            else:
                n += 1
        else:
            n = node_skip[n]
    return SHALLOW if shallow else MISSED


@hot_inline
def _touches(poses, j, bx, by, bz, bound, node_centers, node_radii, node_skip, node_first,
             node_count, body_start, centers, radii, inner_centers, inner_radii, inner_start,
             grow, tables, body_list, first, last, any_kind, hulls, full) -> int:  # fmt: skip
    """`body_touches`'s narrow phase over candidates ``body_list[j, first:last]``."""
    unsure = False
    for n in range(first, last):
        b = body_list[j, n]
        if not sphere_hits(bx, by, bz, bound, tables, b, any_kind):
            continue
        # An obstacle that reaches an inner ball is in the body: no tree walk needed.
        for k in range(inner_start[j], inner_start[j + 1]):
            x, y, z = place(poses, j, inner_centers, k)
            if sphere_hits(x, y, z, inner_radii[k], tables, b, any_kind):
                return CERTAIN
        touch = tree_hits(poses, j, node_centers, node_radii, node_skip, node_first,
                          node_count, body_start, centers, radii, grow, tables, b, any_kind,
                          hulls[3][0], full)  # fmt: skip
        if touch == DEEP:
            return HIT
        if touch == SHALLOW:
            if not full:
                unsure = True
            elif not pieces_clear(poses, j, hulls, tables, b, any_kind, grow):
                return HIT
    return UNSURE if unsure else FREE


@hot_inline
def body_touches(poses, j, bx, by, bz, bound, node_centers, node_radii, node_skip, node_first,
                 node_count, body_start, centers, radii, inner_centers, inner_radii,
                 inner_start, grow, tables, body_list, counts, body_lower, body_upper,
                 hulls, full) -> int:  # fmt: skip
    """`FREE`, `HIT`, `CERTAIN` or `UNSURE`: body ``j`` against its candidate obstacles.

    ``(bx, by, bz)`` is its root sphere's world center and ``bound`` that sphere's grown
    radius. ``body_list[j]`` lists the candidates: ``counts[j, 0]`` rows of the box table
    ``tables[0]``, then ``counts[j, 1]`` rows of the other obstacles' table ``tables[1]``
    (`obstacle_tables`); ``body_lower[j]`` and ``body_upper[j]`` (3, candidates) are their
    world bounding boxes.

    ``hulls`` is `arm_fast_hulls.hull_arrays`: a body whose leaves touch an obstacle only
    within their bulge is decided by its convex pieces, but only in a ``full`` pass. A first
    pass (not ``full``) answers `UNSURE` instead, cheaply: a state that collides elsewhere
    needs neither the rest of the walk nor the pieces.
    """
    boxes = counts[j, 0]
    total = boxes + counts[j, 1]
    # Broad phase, branch-free so that LLVM makes it SIMD over the body's candidates.
    hits = 0
    for n in range(total):
        gx = max(max(body_lower[j, 0, n] - bx, bx - body_upper[j, 0, n]), 0.0)
        gy = max(max(body_lower[j, 1, n] - by, by - body_upper[j, 1, n]), 0.0)
        gz = max(max(body_lower[j, 2, n] - bz, bz - body_upper[j, 2, n]), 0.0)
        hits += gx * gx + gy * gy + gz * gz <= bound * bound
    if hits == 0:
        return FREE
    answer = _touches(poses, j, bx, by, bz, bound, node_centers, node_radii, node_skip,
                      node_first, node_count, body_start, centers, radii, inner_centers,
                      inner_radii, inner_start, grow, tables, body_list, 0, boxes,
                      False, hulls, full)  # fmt: skip
    if answer == HIT or answer == CERTAIN:
        return answer
    others = _touches(poses, j, bx, by, bz, bound, node_centers, node_radii, node_skip,
                      node_first, node_count, body_start, centers, radii, inner_centers,
                      inner_radii, inner_start, grow, tables, body_list, boxes, total,
                      True, hulls, full)  # fmt: skip
    return answer if others == FREE else others


__all__ = [
    "BOX_COLUMNS",
    "CERTAIN",
    "DEEP",
    "FREE",
    "HIT",
    "MISSED",
    "OBSTACLE_COLUMNS",
    "SHALLOW",
    "UNSURE",
    "body_touches",
    "obstacle_tables",
    "sphere_hits",
    "sphere_hits_box",
    "sphere_hits_shape",
    "tree_hits",
]
