"""Where a camera may stand to see a point among obstacles: orbit positions and ray tests.

A picture of an arm is only useful if the goal pose can be seen, so the renderers (the
static `temp_gym.worlds.rendering.arm.ArmRenderer` and the browser viewer
`temp_gym.viewer`) choose among views on an orbit around the scene those from which the
goal hand is not hidden behind an obstacle: a straight ray from the camera to each of a few
points of the hand must miss every obstacle. Each obstacle is tested by its true shape
(`segments_hit_solids`), so a turned box or a cylinder hides only what it covers, not what its
bounding box would.

Angles follow pybullet's ``computeViewMatrixFromYawPitchRoll`` with z up: yaw turns about z
(0 looks along +y), a negative pitch looks down.

Example:
    >>> eye = orbit_position(target=(0, 0, 0.4), yaw=90.0, pitch=-30.0, distance=3.0)
    >>> eye.round(2)
    array([ 2.6 , -0.  ,  1.9 ])
    >>> solids = Solids.of_workspace(problem.workspace)
    >>> visible_points(eye, np.array([[0.5, 0.0, 0.5]]), solids)  # per point: nothing hit
    array([ True])
"""

from __future__ import annotations

import numpy as np

from temp_gym.problem.obstacles import BOX, SPHERE
from temp_gym.worlds.rendering.solids import Solids


def orbit_position(
    target: np.ndarray | tuple[float, float, float], yaw: float, pitch: float, distance: float
) -> np.ndarray:
    """The eye ``(3,)`` of a camera ``distance`` from ``target`` at ``yaw``, ``pitch`` (degrees)."""
    yaw_rad, pitch_rad = np.radians(yaw), np.radians(pitch)
    direction = np.array(
        [
            np.sin(yaw_rad) * np.cos(pitch_rad),
            -np.cos(yaw_rad) * np.cos(pitch_rad),
            -np.sin(pitch_rad),
        ]
    )
    return np.asarray(target, dtype=np.float64) + distance * direction


def segments_hit_boxes(
    starts: np.ndarray, ends: np.ndarray, lower: np.ndarray, upper: np.ndarray
) -> np.ndarray:
    """Per segment ``starts[i] -> ends[i]`` (``(N, 3)`` each): whether it meets any box.

    The slab test: a segment meets the box ``[lower, upper]`` when the parameter intervals
    in which it lies between each pair of faces overlap within ``[0, 1]``.
    """
    starts, ends = np.atleast_2d(starts), np.atleast_2d(ends)
    if len(lower) == 0:
        return np.zeros(len(starts), dtype=bool)
    delta = (ends - starts)[:, None, :]  # (N, 1, 3)
    origin = starts[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        t_low = (lower[None] - origin) / delta  # (N, B, 3)
        t_high = (upper[None] - origin) / delta
    near, far = np.minimum(t_low, t_high), np.maximum(t_low, t_high)
    # An axis the segment runs parallel to: inside the slab for every t, or never.
    parallel = delta == 0.0
    inside = (origin >= lower[None]) & (origin <= upper[None])
    near = np.where(parallel, np.where(inside, -np.inf, np.inf), near)
    far = np.where(parallel, np.where(inside, np.inf, -np.inf), far)
    entry = np.maximum(near.max(axis=2), 0.0)
    leave = np.minimum(far.min(axis=2), 1.0)
    return np.any(entry <= leave, axis=1)


def segments_hit_solids(starts: np.ndarray, ends: np.ndarray, solids: Solids) -> np.ndarray:
    """Per segment ``starts[i] -> ends[i]`` (``(N, 3)`` each): whether it meets any solid.

    Axis-aligned boxes take the slab test on their corners (`segments_hit_boxes`); every
    other obstacle is tested in its own frame, where a turned box is an axis-aligned one, a
    cylinder stands along z and a sphere is a point with a radius.
    """
    starts, ends = np.atleast_2d(starts), np.atleast_2d(ends)
    aligned = solids.aligned_boxes
    hits = segments_hit_boxes(starts, ends, solids.lower[aligned], solids.upper[aligned])
    for index in np.flatnonzero(~aligned):
        center, rotation = solids.centers[index], solids.rotations[index]
        half = solids.half_extents[index]
        # A world point p is R^T (p - c) in the obstacle's frame: (p - c) @ R row by row.
        local_starts, local_ends = (starts - center) @ rotation, (ends - center) @ rotation
        kind = solids.kinds[index]
        if kind == BOX:
            hits |= segments_hit_boxes(local_starts, local_ends, -half[None], half[None])
        elif kind == SPHERE:
            hits |= _segments_near_origin(local_starts, local_ends, half[0])
        else:
            hits |= _segments_hit_cylinder(local_starts, local_ends, half[0], half[2])
    return hits


def _segments_near_origin(starts: np.ndarray, ends: np.ndarray, radius: float) -> np.ndarray:
    """Per segment: whether it passes within ``radius`` of the origin (meets that ball)."""
    delta = ends - starts
    length2 = np.einsum("ij,ij->i", delta, delta)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(length2 > 0.0, -np.einsum("ij,ij->i", starts, delta) / length2, 0.0)
    nearest = starts + np.clip(t, 0.0, 1.0)[:, None] * delta
    return np.einsum("ij,ij->i", nearest, nearest) <= radius * radius


def _segments_hit_cylinder(
    starts: np.ndarray, ends: np.ndarray, radius: float, half_length: float
) -> np.ndarray:
    """Per segment: whether it meets the solid cylinder of ``radius`` along z, ``|z| <= half``.

    The segment's parameters ``t`` in ``[0, 1]`` between the caps' planes and those within
    ``radius`` of the axis (a quadratic in ``t``) must overlap.
    """
    delta = ends - starts
    with np.errstate(divide="ignore", invalid="ignore"):
        t_low = (-half_length - starts[:, 2]) / delta[:, 2]
        t_high = (half_length - starts[:, 2]) / delta[:, 2]
    along = delta[:, 2] == 0.0
    between_caps = np.abs(starts[:, 2]) <= half_length
    z_near = np.where(along, np.where(between_caps, -np.inf, np.inf), np.minimum(t_low, t_high))
    z_far = np.where(along, np.where(between_caps, np.inf, -np.inf), np.maximum(t_low, t_high))
    # |o + t d|^2 <= r^2 in the xy plane: a t^2 + b t + c <= 0.
    a = delta[:, 0] ** 2 + delta[:, 1] ** 2
    b = 2.0 * (starts[:, 0] * delta[:, 0] + starts[:, 1] * delta[:, 1])
    c = starts[:, 0] ** 2 + starts[:, 1] ** 2 - radius * radius
    discriminant = b * b - 4.0 * a * c
    root = np.sqrt(np.maximum(discriminant, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        r_near, r_far = (-b - root) / (2.0 * a), (-b + root) / (2.0 * a)
    parallel = a == 0.0  # along the axis: within the radius for every t, or never
    r_near = np.where(parallel, np.where(c <= 0.0, -np.inf, np.inf), r_near)
    r_far = np.where(parallel, np.where(c <= 0.0, np.inf, -np.inf), r_far)
    missed = ~parallel & (discriminant < 0.0)
    entry = np.maximum(np.maximum(z_near, r_near), 0.0)
    leave = np.minimum(np.minimum(z_far, r_far), 1.0)
    return ~missed & (entry <= leave)


def visible_points(eye: np.ndarray, points: np.ndarray, solids: Solids) -> np.ndarray:
    """Per point ``(N, 3)``: whether the ray from ``eye`` to it misses every solid."""
    points = np.atleast_2d(np.asarray(points, dtype=np.float64))
    eyes = np.broadcast_to(np.asarray(eye, dtype=np.float64), points.shape)
    return ~segments_hit_solids(eyes, points, solids)


def views_seeing(
    points: np.ndarray,
    solids: Solids,
    views: list[tuple[float, float]],
    target: np.ndarray | tuple[float, float, float],
    distance: float,
) -> list[int]:
    """Per ``(yaw, pitch)`` view: how many of ``points`` it sees (`visible_points`)."""
    eyes = [orbit_position(target, yaw, pitch, distance) for yaw, pitch in views]
    return [int(visible_points(eye, points, solids).sum()) for eye in eyes]


def clearest_views(
    points: np.ndarray,
    solids: Solids,
    views: list[tuple[float, float]],
    target: np.ndarray | tuple[float, float, float],
    distance: float,
) -> list[tuple[float, float]]:
    """The ``views`` that see the most of ``points`` (all of them when every solid is missed)."""
    seen = views_seeing(points, solids, views, target, distance)
    best = max(seen)
    return [view for view, count in zip(views, seen) if count == best]
