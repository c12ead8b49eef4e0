"""Distance fields of arm bodies: a faster self-collision walk with the same verdicts.

Two bodies of an enabled pair that come within a few centimetres of each other defeat the
bounding spheres of their trees: both trees must be walked many levels down before their
node spheres come apart. A body's *distance field* answers the question for the other body's
nodes directly. It samples, on a regular grid in the body's frame, the distance from each grid
point to the body's leaf spheres (the union of the spheres the fast checker tests), clamped at
`FIELD_CAP`. Distance to a union of spheres is 1-Lipschitz, so for any point ``p`` and grid
point ``v``

    distance(p) >= field(v) - |p - v|,

a certified lower bound (`field_bound`); off the grid the body's root sphere gives one. The
values are stored as float32 rounded down, so the bound stays a bound.

`field_pair_free` walks the other body's tree in the field's frame: a node whose bound exceeds
its radius plus the pair's reach holds no leaf within reach of any leaf of the field's body,
and is dropped. A leaf sphere the field cannot clear is tested against the field body's tree,
leaf against leaf, exactly as the tree-against-tree walk
(`temp_gym.worlds.collision.arm_fast_self.pair_free`) tests it. Both walks answer "is some
pair of leaves within reach", so the verdicts are the same: the field only drops nodes the other
walk would also have found apart (with `FIELD_SLACK` to spare for rounding). Tested state by
state and edge by edge against the walk without fields.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from temp_gym.worlds.arm.kinematics import place
from temp_gym.worlds.hot_path import hot_inline

FIELD_CAP = 0.15
"""Largest distance (m) a field stores: farther grid points hold this."""
FIELD_SPACING = 0.01
"""Finest grid spacing (m); a large body gets a coarser grid (`FIELD_CELLS`)."""
FIELD_CELLS = 64
"""Most grid points along an axis."""
FIELD_SLACK = 1e-6
"""Margin (m) a field's bound must clear beyond the pair's reach: rounding in the frame change
and the fast kinematics stay far below it."""


@numba.njit(cache=True, nogil=True)
def _fill_field(values, first_node, end_node, node_centers, node_radii, node_skip, node_first,
                node_count, centers, radii, low, spacing, cells, cap):  # fmt: skip
    """Fill ``values`` (cells**3): each grid point's clamped distance to the tree's leaves.

    The tree is nodes ``[first_node, end_node)``; a branch-and-bound walk per grid point.
    """
    stack = np.empty(256, dtype=np.int64)
    for i in range(cells):
        x = low[0] + i * spacing
        for j in range(cells):
            y = low[1] + j * spacing
            for k in range(cells):
                z = low[2] + k * spacing
                best = cap
                stack[0] = first_node
                top = 1
                while top > 0:
                    top -= 1
                    node = stack[top]
                    dx = x - node_centers[node, 0]
                    dy = y - node_centers[node, 1]
                    dz = z - node_centers[node, 2]
                    if math.sqrt(dx * dx + dy * dy + dz * dz) - node_radii[node] >= best:
                        continue
                    if node_count[node] > 0:
                        for s in range(node_first[node], node_first[node] + node_count[node]):
                            dx = x - centers[s, 0]
                            dy = y - centers[s, 1]
                            dz = z - centers[s, 2]
                            best = min(best, math.sqrt(dx * dx + dy * dy + dz * dz) - radii[s])
                    else:
                        # Children: the next node and the one after its subtree, nearer last
                        # so that it is walked first.
                        left, right = node + 1, node_skip[node + 1]
                        lx = x - node_centers[left, 0]
                        ly = y - node_centers[left, 1]
                        lz = z - node_centers[left, 2]
                        rx = x - node_centers[right, 0]
                        ry = y - node_centers[right, 1]
                        rz = z - node_centers[right, 2]
                        if lx * lx + ly * ly + lz * lz < rx * rx + ry * ry + rz * rz:
                            left, right = right, left
                        stack[top], stack[top + 1] = left, right
                        top += 2
                values[(i * cells + j) * cells + k] = best


def body_fields(trees, bodies) -> tuple[np.ndarray, np.ndarray]:
    """``(values, layout)``: the distance fields of ``bodies`` of the sphere ``trees``.

    ``values`` (float32) holds every field's grid, flattened; ``layout`` is ``(B, 6)``, per
    body ``[offset, cells, spacing, low x, low y, low z]``, offset -1 for a body without a
    field. A field's grid is centred on the body's root sphere and reaches `FIELD_CAP` beyond
    it.
    """
    count = len(trees.body_start) - 1
    layout = np.zeros((count, 6))
    layout[:, 0] = -1.0
    chunks: list[np.ndarray] = []
    offset = 0
    for body in sorted(set(int(b) for b in bodies)):
        root, end = int(trees.body_start[body]), int(trees.body_start[body + 1])
        if root == end:
            continue
        half = float(trees.node_radii[root]) + FIELD_CAP
        spacing = max(FIELD_SPACING, 2 * half / (FIELD_CELLS - 1))
        cells = int(math.ceil(2 * half / spacing)) + 1
        low = trees.node_centers[root] - half
        exact = np.empty(cells**3)
        _fill_field(exact, root, end, trees.node_centers, trees.node_radii, trees.node_skip,
                    trees.node_first, trees.node_count, trees.centers, trees.radii, low,
                    spacing, cells, FIELD_CAP)  # fmt: skip
        stored = exact.astype(np.float32)
        stored = np.where(stored > exact, np.nextafter(stored, np.float32(-np.inf)), stored)
        layout[body] = [offset, cells, spacing, *low]
        chunks.append(stored)
        offset += len(stored)
    values = np.concatenate(chunks) if chunks else np.zeros(0, dtype=np.float32)
    return values.astype(np.float32), layout


@hot_inline
def field_bound(values, layout, a, x, y, z, root_x, root_y, root_z, root_radius) -> float:
    """A lower bound on the distance from ``(x, y, z)`` (body ``a``'s frame) to ``a``'s leaves.

    Each grid point ``v`` gives ``field(v) - |p - v|``; inside a cell the best of its eight
    corners is taken, which is never below the nearest point's alone and prunes more of the
    other body's tree (the research notes on collision checking).
    ``(root_x, root_y, root_z)`` and ``root_radius`` are ``a``'s root sphere, in its frame: the
    bound off the grid.
    """
    offset, cells, spacing = int(layout[a, 0]), int(layout[a, 1]), layout[a, 2]
    gi = (x - layout[a, 3]) / spacing
    gj = (y - layout[a, 4]) / spacing
    gk = (z - layout[a, 5]) / spacing
    last = cells - 1
    if gi >= 0.0 and gj >= 0.0 and gk >= 0.0 and gi < last and gj < last and gk < last:
        # Inside a cell: the best of its eight corners' bounds (the nearest grid point is one).
        i0, j0, k0 = int(gi), int(gj), int(gk)
        best = -math.inf
        for di in range(2):
            dx = x - (layout[a, 3] + (i0 + di) * spacing)
            for dj in range(2):
                dy = y - (layout[a, 4] + (j0 + dj) * spacing)
                row = offset + ((i0 + di) * cells + j0 + dj) * cells + k0
                for dk in range(2):
                    dz = z - (layout[a, 5] + (k0 + dk) * spacing)
                    bound = values[row + dk] - math.sqrt(dx * dx + dy * dy + dz * dz)
                    best = max(best, bound)
        return best
    # The grid's outer half cell: the nearest grid point alone.
    fi, fj, fk = gi + 0.5, gj + 0.5, gk + 0.5
    if fi >= 0.0 and fj >= 0.0 and fk >= 0.0 and fi < cells and fj < cells and fk < cells:
        i, j, k = int(fi), int(fj), int(fk)
        dx = x - (layout[a, 3] + i * spacing)
        dy = y - (layout[a, 4] + j * spacing)
        dz = z - (layout[a, 5] + k * spacing)
        near = values[offset + (i * cells + j) * cells + k]
        return near - math.sqrt(dx * dx + dy * dy + dz * dz)
    dx, dy, dz = x - root_x, y - root_y, z - root_z
    return math.sqrt(dx * dx + dy * dy + dz * dz) - root_radius


@hot_inline
def _dot(poses, a, i, b, j) -> float:
    """Column ``i`` of pose ``a`` dotted with column ``j`` of pose ``b`` (rows 0-2)."""
    return (
        poses[a, 0, i] * poses[b, 0, j]
        + poses[a, 1, i] * poses[b, 1, j]
        + (poses[a, 2, i] * poses[b, 2, j])
    )


@hot_inline
def _bound_at(relative, points, k, values, layout, a, root) -> float:
    """`field_bound` at row ``k`` of ``points``, a point of another body.

    ``relative`` is that body's frame in ``a``'s (``R`` row by row, then ``t``), ``root``
    ``a``'s root sphere (center, radius).
    """
    r00, r01, r02, r10, r11, r12, r20, r21, r22, t0, t1, t2 = relative
    c0, c1, c2 = points[k, 0], points[k, 1], points[k, 2]
    x = r00 * c0 + r01 * c1 + r02 * c2 + t0
    y = r10 * c0 + r11 * c1 + r12 * c2 + t1
    z = r20 * c0 + r21 * c1 + r22 * c2 + t2
    return field_bound(values, layout, a, x, y, z, root[0], root[1], root[2], root[3])


@hot_inline
def field_pair_free(poses, a, b, node_centers, node_radii, node_skip, node_first, node_count,
                    body_start, centers, radii, values, layout, grow_a, grow_b, gap,
                    stack) -> bool:  # fmt: skip
    """Whether no leaf of body ``b`` comes within reach of a leaf of body ``a`` (module doc).

    Body ``a`` has a field. Reach of two leaves: their radii plus ``grow_a``, ``grow_b`` and
    ``gap``. ``stack`` is `scratch_for`'s: column 0 holds ``b``'s walk, column 1 ``a``'s.
    """
    root_a = body_start[a]
    # b's frame in a's: R = Ra^T Rb, t = Ra^T (tb - ta).
    r00, r01, r02 = _dot(poses, a, 0, b, 0), _dot(poses, a, 0, b, 1), _dot(poses, a, 0, b, 2)
    r10, r11, r12 = _dot(poses, a, 1, b, 0), _dot(poses, a, 1, b, 1), _dot(poses, a, 1, b, 2)
    r20, r21, r22 = _dot(poses, a, 2, b, 0), _dot(poses, a, 2, b, 1), _dot(poses, a, 2, b, 2)
    t0, t1, t2 = _dot(poses, a, 0, b, 3), _dot(poses, a, 1, b, 3), _dot(poses, a, 2, b, 3)
    t0 -= _dot(poses, a, 0, a, 3)
    t1 -= _dot(poses, a, 1, a, 3)
    t2 -= _dot(poses, a, 2, a, 3)
    relative = (r00, r01, r02, r10, r11, r12, r20, r21, r22, t0, t1, t2)
    root = (node_centers[root_a, 0], node_centers[root_a, 1], node_centers[root_a, 2],
            node_radii[root_a])  # fmt: skip
    extra = grow_a + grow_b + gap + FIELD_SLACK
    stack[0, 0] = body_start[b]
    top = 1
    while top > 0:
        top -= 1
        nb = int(stack[top, 0])
        if _bound_at(relative, node_centers, nb, values, layout, a, root) > node_radii[nb] + extra:
            continue
        if node_count[nb] == 0:
            stack[top, 0] = nb + 1
            stack[top + 1, 0] = node_skip[nb + 1]
            top += 2
            continue
        for s in range(node_first[nb], node_first[nb] + node_count[nb]):
            if _bound_at(relative, centers, s, values, layout, a, root) > radii[s] + extra:
                continue
            # The leaf against a's tree, in the world frame, as the tree-against-tree walk.
            sx, sy, sz = place(poses, b, centers, s)
            stack[0, 1] = root_a
            depth = 1
            while depth > 0:
                depth -= 1
                na = int(stack[depth, 1])
                ax, ay, az = place(poses, a, node_centers, na)
                dx, dy, dz = ax - sx, ay - sy, az - sz
                within = node_radii[na] + grow_a + radii[s] + grow_b + gap
                if dx * dx + dy * dy + dz * dz > within * within:
                    continue
                if node_count[na] == 0:
                    stack[depth, 1] = na + 1
                    stack[depth + 1, 1] = node_skip[na + 1]
                    depth += 2
                    continue
                for i in range(node_first[na], node_first[na] + node_count[na]):
                    ax, ay, az = place(poses, a, centers, i)
                    dx, dy, dz = ax - sx, ay - sy, az - sz
                    # The sum in `pair_free`'s order: the same verdict to the last bit.
                    within = radii[i] + grow_a + radii[s] + grow_b + gap
                    if dx * dx + dy * dy + dz * dz <= within * within:
                        return False
    return True


__all__ = [
    "FIELD_CAP",
    "FIELD_CELLS",
    "FIELD_SLACK",
    "FIELD_SPACING",
    "body_fields",
    "field_bound",
    "field_pair_free",
]
