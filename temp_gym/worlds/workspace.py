"""`Workspace`: the obstacles and bounds shared by many start-goal tasks."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from temp_gym.problem import ROBOTS, Problem


@dataclass(frozen=True)
class Workspace:
    """A robot's bounds and box obstacles, without a task.

    Generators draw one workspace and then many tasks in it, as the paper does
    (200 start-goal pairs per workspace); the environment encoding is computed per workspace.
    """

    robot: str
    bounds: np.ndarray
    obstacle_centers: np.ndarray
    obstacle_half_extents: np.ndarray

    def __post_init__(self) -> None:
        if self.robot not in ROBOTS:
            raise ValueError(f"robot: unknown robot {self.robot!r}; expected one of {list(ROBOTS)}")
        dim, wdim = ROBOTS[self.robot]
        object.__setattr__(
            self, "bounds", np.asarray(self.bounds, dtype=np.float64).reshape(2, dim)
        )
        for name in ("obstacle_centers", "obstacle_half_extents"):
            value = np.asarray(getattr(self, name), dtype=np.float64).reshape(-1, wdim)
            object.__setattr__(self, name, value)

    @property
    def dim(self) -> int:
        """Configuration-space dimension."""
        return ROBOTS[self.robot][0]

    @property
    def obstacle_lower(self) -> np.ndarray:
        """Lower box corners, (M, workspace_dim)."""
        return self.obstacle_centers - self.obstacle_half_extents

    @property
    def obstacle_upper(self) -> np.ndarray:
        """Upper box corners, (M, workspace_dim)."""
        return self.obstacle_centers + self.obstacle_half_extents

    def problem(self, start: np.ndarray, goal: np.ndarray, goal_radius: float) -> Problem:
        """A validated `Problem` for one start-goal task in this workspace."""
        return Problem(
            robot=self.robot,
            bounds=self.bounds,
            obstacle_centers=self.obstacle_centers,
            obstacle_half_extents=self.obstacle_half_extents,
            start=start,
            goal=goal,
            goal_radius=goal_radius,
        )

    @classmethod
    def of(cls, problem: Problem) -> Workspace:
        """The workspace a problem lives in."""
        return cls(
            problem.robot, problem.bounds, problem.obstacle_centers, problem.obstacle_half_extents
        )
