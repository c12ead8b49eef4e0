"""Collision checking behind one interface, at two levels.

* The **fast** checker is what planners call in their hot loop: batched states ``(N, d)`` to
  ``bool[N]`` and edges to ``bool``. Point robots use an exact analytic segment-versus-box
  test. The iiwa uses forward kinematics and a sphere model of its links that covers the
  collision meshes, and tests the link pairs its allowed-collision matrix enables against each
  other, so it is conservative: it never calls a state free that is in collision.
* The **exact** checker certifies the paths a planner returns. Point robots: the same analytic
  test, which is exact. The iiwa: python-fcl on the links' collision meshes against the boxes
  and on their (padded) convex hulls against each other, within the URDF joint limits.

``True`` always means *free* (OMPL's "valid"), so ``checker.states_free(x)`` reads as it says.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

if TYPE_CHECKING:
    from temp_gym.problem import Problem


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


def make_checker(problem: Problem, exact: bool = False) -> CollisionChecker:
    """Build the fast (default) or the exact collision checker for ``problem``.

    Example:
        >>> checker = make_checker(problem)
        >>> checker.states_free(np.array([[2.0, 2.0], [10.0, 10.0]]))
        array([ True, False])
    """
    if problem.robot in ("point2d", "point3d"):
        from temp_gym.worlds.collision.point import PointBoxChecker

        return PointBoxChecker(problem.bounds, problem.obstacle_lower, problem.obstacle_upper)
    if problem.robot == "kuka_iiwa14":
        if exact:
            from temp_gym.worlds.collision.iiwa_exact import IiwaExactChecker

            return IiwaExactChecker(problem.bounds, problem.obstacle_lower, problem.obstacle_upper)
        from temp_gym.worlds.collision.iiwa_fast import IiwaSphereChecker

        return IiwaSphereChecker(problem.bounds, problem.obstacle_lower, problem.obstacle_upper)
    raise ValueError(f"robot: no collision checker for {problem.robot!r}")


def certify_path(problem: Problem, path: np.ndarray) -> bool:
    """Certify ``path`` with the exact checker: every state and motion is collision-free.

    For the iiwa that includes self-collision and the URDF joint limits at every waypoint.
    """
    path = np.asarray(path, dtype=np.float64)
    if path.ndim != 2 or path.shape[1] != problem.dim or len(path) == 0:
        raise ValueError(f"path: expected shape (K, {problem.dim}), got {path.shape}")
    return bool(make_checker(problem, exact=True).path_free(path))


__all__ = ["CollisionChecker", "SelfCollisionChecker", "certify_path", "make_checker"]
