"""`Workspace`: a robot's bounds and box obstacles, shared by the many tasks planned in them."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from temp_gym.limits import MAX_OBSTACLES
from temp_gym.problem.parsing import MIN_LENGTH, float_array
from temp_gym.problem.robots import robot_named


@dataclass(frozen=True, eq=False)
class Workspace:
    """A robot's configuration bounds and axis-aligned boxes, without a task.

    Generators draw one workspace and then many tasks in it, as the paper does (200
    start-goal pairs per workspace); the occupancy encoding and other per-workspace work are
    done once per workspace. Every field is validated (a `ValueError` names the field) and
    stored as a read-only float64 array. Two workspaces are equal when their robot, bounds and
    boxes are, and equal workspaces hash alike, so a workspace can key a cache.

    Examples:
        >>> workspace = Workspace("point2d", [[0, 0], [20, 20]], [[10, 10]], [[1, 3]])
        >>> problem = Problem(workspace, start=[2, 2], goal=[18, 18], goal_radius=0.5)
    """

    robot: str
    """The robot's registered name (`temp_gym.problem.robots`)."""
    bounds: np.ndarray
    """The configuration space ``[lower, upper]``, shape ``(2, dim)``."""
    obstacle_centers: np.ndarray
    """Box centers, shape ``(M, workspace_dim)``."""
    obstacle_half_extents: np.ndarray
    """Box half sides, shape ``(M, workspace_dim)``, positive."""
    _key: tuple = field(init=False, repr=False)

    def __post_init__(self) -> None:
        robot = robot_named(self.robot)
        dim, wdim = robot.dim, robot.workspace_dim
        bounds = float_array(self.bounds, "bounds")
        if bounds.shape != (2, dim):
            raise ValueError(
                f"bounds: expected shape (2, {dim}) for {self.robot}, got {bounds.shape}"
            )
        if np.any(bounds[0] >= bounds[1]):
            raise ValueError(
                f"bounds: lower must be below upper in every dimension, got {bounds.tolist()}"
            )
        if np.any(bounds[1] - bounds[0] < MIN_LENGTH):
            raise ValueError(f"bounds: every side must be at least {MIN_LENGTH:g} long")
        limits = None if robot.joint_limits is None else robot.joint_limits()
        if limits is not None and (np.any(bounds[0] < limits[0]) or np.any(bounds[1] > limits[1])):
            joint = int(np.argmax((bounds[0] < limits[0]) | (bounds[1] > limits[1])))
            raise ValueError(
                f"bounds: wider than the {self.robot} joint limits at joint {joint + 1}: "
                f"[{bounds[0, joint]}, {bounds[1, joint]}] is not within "
                f"[{limits[0, joint]}, {limits[1, joint]}] (the URDF's limits, radians)"
            )
        centers = float_array(self.obstacle_centers, "obstacles: center").reshape(-1, wdim)
        halves = float_array(self.obstacle_half_extents, "obstacles: half_extents")
        halves = halves.reshape(-1, wdim)
        if centers.shape != halves.shape:
            raise ValueError("obstacles: centers and half_extents differ in count")
        if len(centers) > MAX_OBSTACLES:
            raise ValueError(
                f"obstacles: {len(centers)} boxes, at most {MAX_OBSTACLES} are supported "
                "(temp_gym.limits)"
            )
        if np.any(halves <= 0):
            bad = int(np.argmax(np.any(halves <= 0, axis=1)))
            raise ValueError(
                f"obstacles[{bad}].half_extents: must be positive, got {halves[bad].tolist()}"
            )
        # -0.0 becomes 0.0: equal workspaces must have equal bytes, which equality and hash read
        bounds, centers, halves = bounds + 0.0, centers + 0.0, halves + 0.0
        for array in (bounds, centers, halves):
            array.setflags(write=False)
        object.__setattr__(self, "bounds", bounds)
        object.__setattr__(self, "obstacle_centers", centers)
        object.__setattr__(self, "obstacle_half_extents", halves)
        key = (self.robot, bounds.tobytes(), centers.shape, centers.tobytes(), halves.tobytes())
        object.__setattr__(self, "_key", key)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Workspace):
            return NotImplemented
        return self._key == other._key

    def __hash__(self) -> int:
        return hash(self._key)

    @property
    def dim(self) -> int:
        """Configuration-space dimension."""
        return self.bounds.shape[1]

    @property
    def workspace_dim(self) -> int:
        """Dimension of the workspace the boxes live in."""
        return robot_named(self.robot).workspace_dim

    @property
    def num_obstacles(self) -> int:
        """Number of boxes."""
        return len(self.obstacle_centers)

    @property
    def obstacle_lower(self) -> np.ndarray:
        """Lower box corners, (M, workspace_dim)."""
        return self.obstacle_centers - self.obstacle_half_extents

    @property
    def obstacle_upper(self) -> np.ndarray:
        """Upper box corners, (M, workspace_dim)."""
        return self.obstacle_centers + self.obstacle_half_extents
