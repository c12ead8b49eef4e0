"""Compiled geometry of one obstacle of any kind: points, segments and boxes against it.

The point robots' checker (`temp_gym.worlds.collision.point_shapes`) and the occupancy grid
(`temp_gym.worlds.encoding`) read a workspace's obstacles through `obstacle_arrays`, one row
per obstacle, and test them here, so both agree on what an obstacle is. Every obstacle is
closed: touching it counts.

Each obstacle carries a *shape code*: `AXIS_BOX` for a box with the identity orientation
(its bounding box is the box, tested exactly by the callers' slab tests), `CYLINDER`,
`SPHERE` (their kind numbers in `temp_gym.problem.obstacles`) and `ROTATED_BOX`.

**Rounding errs towards collision.** A rotated or curved obstacle is tested in its own frame,
``R^T (p - c)``, whose rounding an exact world-frame answer does not have. So these tests
grow the obstacle by `ROUNDING_SLACK` relative to the sizes involved (its half extents and how
far the tested points are from its center): a point within about ``1e-12`` of the size of the
scene from a rotated or curved surface counts as touching it. Nothing inside is ever called
outside; the bounding boxes of `obstacle_arrays` are grown likewise.
"""

from __future__ import annotations

import math

import numpy as np

from temp_gym.problem import Workspace
from temp_gym.problem.obstacles import BOX, CYLINDER, SPHERE
from temp_gym.worlds.hot_path import hot_path

AXIS_BOX = BOX
"""Shape code of a box with the identity orientation: its bounding box is exact."""
ROTATED_BOX = 3
"""Shape code of a box with any other orientation."""
ROUNDING_SLACK = 1e-12
"""How much the rotated and curved tests grow an obstacle, relative to the sizes involved:
thousands of times the rounding of the frame change, far below any size that matters."""
BOUNDING_SLACK = 1e-9
"""How much `obstacle_arrays` grows a rotated or curved obstacle's bounding box, relative to
its half sides and center: it must hold the obstacle grown by `ROUNDING_SLACK` too."""


def obstacle_arrays(workspace: Workspace) -> tuple[np.ndarray, ...]:
    """``(codes, centers, halves, rotations, lower, upper)`` of a workspace's obstacles.

    Fresh, writable, contiguous arrays: ``codes`` int8 ``(M,)`` (the module docstring),
    ``centers`` and ``halves`` ``(M, w)``, ``rotations`` ``(M, w, w)`` and the bounding
    boxes' corners ``(M, w)``. An axis-aligned box's bounding box is the box itself, to the
    bit; any other obstacle's is grown by `BOUNDING_SLACK` so that rounding never shrinks it
    below the obstacle.
    """
    codes = np.array(workspace.obstacle_kinds, dtype=np.int8)
    codes[(codes == BOX) & ~workspace.unrotated] = ROTATED_BOX
    centers = np.array(workspace.obstacle_centers, dtype=np.float64)
    halves = np.array(workspace.obstacle_half_extents, dtype=np.float64)
    rotations = np.array(workspace.obstacle_rotations, dtype=np.float64)
    reach = workspace.obstacle_world_half_extents  # what `Workspace.obstacle_lower` subtracts
    lower, upper = centers - reach, centers + reach
    shaped = codes != AXIS_BOX
    if np.any(shaped):
        grow = BOUNDING_SLACK * (reach[shaped] + np.abs(centers[shaped]))
        lower[shaped] -= grow
        upper[shaped] += grow
    return codes, centers, halves, rotations, lower, upper


@hot_path
def _local(point, centers, rotations, b, k) -> float:
    """Coordinate ``k`` of ``point`` in obstacle ``b``'s frame: ``(R^T (p - c))_k``."""
    total = 0.0
    for j in range(point.shape[0]):
        total += rotations[b, j, k] * (point[j] - centers[b, j])
    return total


@hot_path
def _reach(point, centers, b) -> float:
    """How far ``point`` is from obstacle ``b``'s center along an axis (rounding scales with it)."""
    far = 0.0
    for j in range(point.shape[0]):
        far = max(far, abs(point[j] - centers[b, j]))
    return far


@hot_path
def _grown(size: float, reach: float) -> float:
    """``size`` grown by `ROUNDING_SLACK` of the sizes in play."""
    return size + ROUNDING_SLACK * (size + reach)


@hot_path
def point_in_shape(point, codes, centers, halves, rotations, b) -> bool:
    """Whether ``point`` lies in obstacle ``b`` (closed), a rotated box, a cylinder or a sphere.

    An `AXIS_BOX` is answered as a box too, with the slack: callers test those exactly on
    their bounding boxes instead.
    """
    code = codes[b]
    reach = _reach(point, centers, b)
    if code == SPHERE:
        radius = _grown(halves[b, 0], reach)
        squared = 0.0
        for j in range(point.shape[0]):
            squared += (point[j] - centers[b, j]) ** 2
        return squared <= radius * radius
    if code == CYLINDER:
        if abs(_local(point, centers, rotations, b, 2)) > _grown(halves[b, 2], reach):
            return False
        x = _local(point, centers, rotations, b, 0)
        y = _local(point, centers, rotations, b, 1)
        radius = _grown(halves[b, 0], reach)
        return x * x + y * y <= radius * radius
    for k in range(point.shape[0]):
        if abs(_local(point, centers, rotations, b, k)) > _grown(halves[b, k], reach):
            return False
    return True


@hot_path
def _clip(t_enter: float, t_exit: float, start: float, end: float, half: float):
    """``[t_enter, t_exit]`` narrowed to where ``start + t (end - start)`` is in ``[-half, half]``.

    Empty (``t_enter > t_exit``) when the segment misses the slab.
    """
    delta = end - start
    if delta == 0.0:
        if start < -half or start > half:
            return 1.0, 0.0
        return t_enter, t_exit
    t0 = (-half - start) / delta
    t1 = (half - start) / delta
    if t0 > t1:
        t0, t1 = t1, t0
    return max(t_enter, t0), min(t_exit, t1)


@hot_path
def segment_meets_shape(start, end, codes, centers, halves, rotations, b) -> bool:
    """Whether the closed segment ``start``-``end`` meets obstacle ``b`` (as `point_in_shape`).

    A rotated box: the slab test in the box's frame. A sphere: the distance from its center to
    the segment, at most its radius. A cylinder: in its frame, the segment clipped to the
    cylinder's length, then the least distance from its axis over the clipped part (a convex
    quadratic on an interval), at most its radius.
    """
    code = codes[b]
    reach = max(_reach(start, centers, b), _reach(end, centers, b))
    if code == SPHERE:
        along = 0.0
        length = 0.0
        for j in range(start.shape[0]):
            delta = end[j] - start[j]
            along += (start[j] - centers[b, j]) * delta
            length += delta * delta
        t = 0.0 if length == 0.0 else min(max(-along / length, 0.0), 1.0)
        squared = 0.0
        for j in range(start.shape[0]):
            squared += (start[j] - centers[b, j] + t * (end[j] - start[j])) ** 2
        radius = _grown(halves[b, 0], reach)
        return squared <= radius * radius
    if code == CYLINDER:
        t0, t1 = _clip(
            0.0,
            1.0,
            _local(start, centers, rotations, b, 2),
            _local(end, centers, rotations, b, 2),
            _grown(halves[b, 2], reach),
        )
        if t0 > t1:
            return False
        ax = _local(start, centers, rotations, b, 0)
        ay = _local(start, centers, rotations, b, 1)
        dx = _local(end, centers, rotations, b, 0) - ax
        dy = _local(end, centers, rotations, b, 1) - ay
        length = dx * dx + dy * dy
        t = t0 if length == 0.0 else min(max(-(ax * dx + ay * dy) / length, t0), t1)
        x, y = ax + t * dx, ay + t * dy
        radius = _grown(halves[b, 0], reach)
        return x * x + y * y <= radius * radius
    t0, t1 = 0.0, 1.0
    for k in range(start.shape[0]):
        t0, t1 = _clip(
            t0,
            t1,
            _local(start, centers, rotations, b, k),
            _local(end, centers, rotations, b, k),
            _grown(halves[b, k], reach),
        )
        if t0 > t1:
            return False
    return True


@hot_path
def _axis_component(axis: int, k: int, dim: int, rotations, b) -> float:
    """Component ``k`` of probe axis number ``axis`` for obstacle ``b``.

    Axes ``0 .. dim - 1`` are the world's, the next ``dim`` the obstacle's (its rotation's
    columns) and, in 3D, axes 6-14 the world axis ``(axis - 6) // 3`` crossed with the
    obstacle's axis ``(axis - 6) % 3``.
    """
    if axis < dim:
        return 1.0 if k == axis else 0.0
    if axis < 2 * dim:
        return rotations[b, k, axis - dim]
    world = (axis - 6) // 3
    u = (axis - 6) % 3
    # (e_world x u)_k = e_world[k1] u[k2] - e_world[k2] u[k1], with k1, k2 = k + 1, k + 2 mod 3
    k1, k2 = (k + 1) % 3, (k + 2) % 3
    first = rotations[b, k2, u] if world == k1 else 0.0
    second = rotations[b, k1, u] if world == k2 else 0.0
    return first - second


@hot_path
def _separates(lower, upper, codes, centers, halves, rotations, b, axis: int) -> bool:
    """Whether probe ``axis`` separates the closed box ``[lower, upper]`` from obstacle ``b``.

    ``b`` is a box or a cylinder; `_axis_component` numbers the axes. The gap must exceed the
    two radii by the slack.
    """
    dim = lower.shape[0]
    gap = 0.0  # (obstacle center - cell center) . L
    cell_radius = 0.0
    scale = 0.0
    norm = 0.0
    along = 0.0  # L . cylinder axis
    for k in range(dim):
        component = _axis_component(axis, k, dim, rotations, b)
        middle = 0.5 * (lower[k] + upper[k])
        half = 0.5 * (upper[k] - lower[k])
        gap += (centers[b, k] - middle) * component
        cell_radius += half * abs(component)
        scale += abs(centers[b, k] - middle) + half + halves[b, k]
        norm += abs(component)
        if dim == 3:
            along += rotations[b, k, 2] * component
    if codes[b] == CYLINDER:
        squared = 0.0
        for k in range(dim):
            component = _axis_component(axis, k, dim, rotations, b)
            squared += component * component
        shape_radius = halves[b, 2] * abs(along) + halves[b, 0] * math.sqrt(
            max(squared - along * along, 0.0)
        )
    else:
        shape_radius = 0.0
        for i in range(dim):
            projected = 0.0
            for k in range(dim):
                projected += rotations[b, k, i] * _axis_component(axis, k, dim, rotations, b)
            shape_radius += halves[b, i] * abs(projected)
    return abs(gap) > cell_radius + shape_radius + ROUNDING_SLACK * norm * scale


@hot_path
def _radial_separates(lower, upper, centers, halves, rotations, b) -> bool:
    """Whether the direction from cylinder ``b``'s axis to the cell's center separates them."""
    middle0 = 0.5 * (lower[0] + upper[0]) - centers[b, 0]
    middle1 = 0.5 * (lower[1] + upper[1]) - centers[b, 1]
    middle2 = 0.5 * (lower[2] + upper[2]) - centers[b, 2]
    along = (
        middle0 * rotations[b, 0, 2] + middle1 * rotations[b, 1, 2] + middle2 * rotations[b, 2, 2]
    )
    l0 = middle0 - along * rotations[b, 0, 2]
    l1 = middle1 - along * rotations[b, 1, 2]
    l2 = middle2 - along * rotations[b, 2, 2]
    squared = l0 * l0 + l1 * l1 + l2 * l2
    if squared == 0.0:
        return False
    gap = -(middle0 * l0 + middle1 * l1 + middle2 * l2)  # (c - m) . L
    cell_radius = 0.5 * (
        (upper[0] - lower[0]) * abs(l0)
        + (upper[1] - lower[1]) * abs(l1)
        + (upper[2] - lower[2]) * abs(l2)
    )
    shape_radius = halves[b, 0] * math.sqrt(squared)  # L is normal to the axis
    scale = abs(middle0) + abs(middle1) + abs(middle2) + halves[b, 0] + halves[b, 2]
    scale += upper[0] - lower[0] + upper[1] - lower[1] + upper[2] - lower[2]
    norm = abs(l0) + abs(l1) + abs(l2)
    return abs(gap) > cell_radius + shape_radius + ROUNDING_SLACK * norm * scale


@hot_path
def box_overlaps_shape(lower, upper, codes, centers, halves, rotations, b) -> bool:
    """Whether the closed axis-aligned box ``[lower, upper]`` overlaps obstacle ``b``.

    Exact (up to the slack) for a sphere (the distance from its center to the box, clamped)
    and a rotated box (separating axes: the world's, the box's and, in 3D, their nine cross
    products). For a cylinder, conservative: it is separated on the world's axes, its own,
    their cross products and the direction from its axis to the box's center, else called
    overlapping; a box near a cylinder's rim may be called overlapping without touching it,
    never the other way round. An `AXIS_BOX` is answered as a rotated box.
    """
    dim = lower.shape[0]
    code = codes[b]
    if code == SPHERE:
        squared = 0.0
        scale = halves[b, 0]
        for k in range(dim):
            c = centers[b, k]
            outside = max(lower[k] - c, 0.0, c - upper[k])
            squared += outside * outside
            scale += abs(c - lower[k]) + abs(c - upper[k])
        radius = _grown(halves[b, 0], scale)
        return squared <= radius * radius
    probes = 4 if dim == 2 else 15
    if code == CYLINDER:
        probes = 6  # the world's axes, its own three (its axis among them)...
    for axis in range(probes):
        if _separates(lower, upper, codes, centers, halves, rotations, b, axis):
            return False
    if code == CYLINDER:
        for axis in (8, 11, 14):  # ... and the world axes crossed with its axis, then radial
            if _separates(lower, upper, codes, centers, halves, rotations, b, axis):
                return False
        if _radial_separates(lower, upper, centers, halves, rotations, b):
            return False
    return True


__all__ = [
    "AXIS_BOX",
    "ROTATED_BOX",
    "ROUNDING_SLACK",
    "box_overlaps_shape",
    "obstacle_arrays",
    "point_in_shape",
    "segment_meets_shape",
]
