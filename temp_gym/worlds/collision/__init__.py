"""Collision checking behind one interface, at two levels.

* The **fast** checker is what planners call in their hot loop: batched states ``(N, d)`` to
  ``bool[N]`` and edges to ``bool``. Point robots use exact analytic tests of a segment
  against each obstacle kind (`point_shapes.point_checker`; the slab test of `point` when
  every obstacle is an axis-aligned box). An arm (`arm_fast`) uses forward kinematics and
  trees of spheres that cover its links' convex pieces, and tests the body pairs its
  allowed-collision matrix enables against each other, so it is conservative: it never calls
  a state free that is in collision.
* The **exact** checker certifies the paths a planner returns. Point robots: the same analytic
  test, which is exact. An arm (`arm_exact`): python-fcl on the links' collision meshes against
  the boxes and on their (padded) convex pieces against each other, within the joint limits.

``True`` always means *free* (OMPL's "valid"), so ``checker.states_free(x)`` reads as it says.

Optional methods, used when a checker has them: ``compiled_context()`` (a compiled motion
check, `temp_gym.worlds.collision.compiled`) and ``free_volume()`` (the exact free volume,
for RRT*'s rewiring radius; without it the tree estimates it by Monte Carlo).

A robot's spec names its checkers (`temp_gym.worlds.robots.RobotSpec.make_checker`);
`temp_gym.worlds.checkers` builds a problem's.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class CollisionChecker(Protocol):
    """What every checker offers: state validity and motion validity, batched."""

    dim: int
    """Configuration-space dimension."""
    description: str
    """One line naming the checker, used in error messages and benchmark tables."""

    def states_free(self, states: np.ndarray) -> np.ndarray:
        """Return ``bool[N]``: whether each state of ``states`` (N x d) is free and in bounds."""
        ...

    def edge_free(self, start: np.ndarray, end: np.ndarray) -> bool:
        """Whether the straight motion from ``start`` to ``end`` is free, endpoints included."""
        ...

    def edges_free(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """Return ``bool[N]``: `edge_free` for N edges at once."""
        ...

    def path_free(self, path: np.ndarray) -> bool:
        """Whether every edge of the polyline ``path`` (K x d) is free."""
        ...


@runtime_checkable
class SelfCollisionChecker(Protocol):
    """A checker of a robot that can collide with itself (the iiwa's both checkers)."""

    def self_collisions(self, state: np.ndarray) -> list[tuple[str, str]]:
        """The link pairs of one ``state`` that collide with each other, by link name."""
        ...


__all__ = ["CollisionChecker", "SelfCollisionChecker"]
