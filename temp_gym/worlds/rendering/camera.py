"""Where a camera may stand to see a point among boxes: orbit positions and ray tests.

A picture of an arm is only useful if the goal pose can be seen, so the renderers (the
static `temp_gym.worlds.rendering.arm.ArmRenderer` and the browser viewer
`temp_gym.viewer`) choose among views on an orbit around the scene those from which the
goal hand is not hidden behind a box: a straight ray from the camera to each of a few points
of the hand must miss every box.

Angles follow pybullet's ``computeViewMatrixFromYawPitchRoll`` with z up: yaw turns about z
(0 looks along +y), a negative pitch looks down.

Example:
    >>> eye = orbit_position(target=(0, 0, 0.4), yaw=90.0, pitch=-30.0, distance=3.0)
    >>> eye.round(2)
    array([ 2.6 , -0.  ,  1.9 ])
    >>> visible_points(eye, np.array([[0.5, 0.0, 0.5]]), lower, upper)  # per point: no box hit
    array([ True])
"""

from __future__ import annotations

import numpy as np


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


def visible_points(
    eye: np.ndarray, points: np.ndarray, lower: np.ndarray, upper: np.ndarray
) -> np.ndarray:
    """Per point ``(N, 3)``: whether the ray from ``eye`` to it misses every box."""
    points = np.atleast_2d(np.asarray(points, dtype=np.float64))
    eyes = np.broadcast_to(np.asarray(eye, dtype=np.float64), points.shape)
    return ~segments_hit_boxes(eyes, points, lower, upper)


def views_seeing(
    points: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    views: list[tuple[float, float]],
    target: np.ndarray | tuple[float, float, float],
    distance: float,
) -> list[int]:
    """Per ``(yaw, pitch)`` view: how many of ``points`` it sees (`visible_points`)."""
    eyes = [orbit_position(target, yaw, pitch, distance) for yaw, pitch in views]
    return [int(visible_points(eye, points, lower, upper).sum()) for eye in eyes]


def clearest_views(
    points: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    views: list[tuple[float, float]],
    target: np.ndarray | tuple[float, float, float],
    distance: float,
) -> list[tuple[float, float]]:
    """The ``views`` that see the most of ``points`` (all of them when every box is missed)."""
    seen = views_seeing(points, lower, upper, views, target, distance)
    best = max(seen)
    return [view for view, count in zip(views, seen) if count == best]
