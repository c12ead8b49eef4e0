"""The ``shapes`` family of point worlds: rotated boxes, spheres (discs) and cylinders.

Where the other families are made of axis-aligned boxes, a ``shapes`` workspace scatters a
random mix of obstacle kinds, each turned at random: boxes at any angle (any orientation in
3D), discs or spheres, and, in 3D, solid cylinders along any axis. Counts and sizes follow
the ``boxes`` family's (`temp_gym.worlds.point_world.DEFAULT_POINT_WORLDS`): a box's half
sides, a sphere's radius, a cylinder's radius and half length are each drawn from its half
extent range. `temp_gym.worlds.structured.generate_structured_workspace` draws the family
and applies the structured families' occupancy and connectivity checks.

Examples:
    >>> workspace = generate_workspace("point3d", np.random.default_rng(0), "shapes")
"""

from __future__ import annotations

import numpy as np

from temp_gym.problem.obstacles import Box, Cylinder, Obstacle, Sphere
from temp_gym.worlds.point_world import DEFAULT_POINT_WORLDS

SHAPES = "shapes"
"""The family's name (``workspace_family: shapes``)."""


def random_quaternion(rng: np.random.Generator) -> tuple[float, ...]:
    """A 3D orientation drawn uniformly, as a unit quaternion ``[x, y, z, w]``.

    A normalized 4D Gaussian is uniform over the rotations.
    """
    quaternion = rng.normal(size=4)
    return tuple(float(v) for v in quaternion / np.linalg.norm(quaternion))


def random_orientation(rng: np.random.Generator, dim: int) -> float | tuple[float, ...]:
    """An orientation drawn uniformly: an angle in 2D, a unit quaternion in 3D."""
    return float(rng.uniform(-np.pi, np.pi)) if dim == 2 else random_quaternion(rng)


def draw_shapes(dim: int, size: float, rng: np.random.Generator) -> list[Obstacle]:
    """A random mix of obstacles in ``[0, size]^dim``, before the family's checks.

    Boxes and discs in 2D; boxes, spheres and cylinders in 3D, each kind as likely.
    """
    config = DEFAULT_POINT_WORLDS[dim]
    low, high = config.min_half_extent, config.max_half_extent
    count = int(rng.integers(config.min_boxes, config.max_boxes + 1))
    kinds = (Box, Sphere) if dim == 2 else (Box, Sphere, Cylinder)
    obstacles: list[Obstacle] = []
    for _ in range(count):
        kind = kinds[int(rng.integers(len(kinds)))]
        center = tuple(float(v) for v in rng.uniform(0.0, size, dim))
        if kind is Box:
            half = tuple(float(v) for v in rng.uniform(low, high, dim))
            obstacles.append(Box(center, half, random_orientation(rng, dim)))
        elif kind is Sphere:
            obstacles.append(Sphere(center, float(rng.uniform(low, high))))
        else:
            radius, half_length = (float(v) for v in rng.uniform(low, high, 2))
            orientation = random_quaternion(rng)
            obstacles.append(Cylinder(center, radius, 2.0 * half_length, orientation))
    return obstacles


__all__ = ["SHAPES", "draw_shapes", "random_orientation", "random_quaternion"]
