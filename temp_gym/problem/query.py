"""`Problem`: one motion-planning query (a workspace, start, goal, goal region) and its JSON format.

The JSON format is fixed, because users and our own test sets are written against it::

    {"robot": "point2d",
     "bounds": [[0, 0], [20, 20]],
     "obstacles": [{"center": [10, 10], "half_extents": [1, 3]}],
     "start": [2, 2], "goal": [18, 18], "goal_radius": 0.5}

* ``robot`` names a registered robot (`temp_gym.worlds.robots`): ``point2d``, ``point3d`` or
  ``kuka_iiwa14`` as shipped.
* ``bounds`` is the configuration space as ``[lower, upper]``. A robot with joint limits (the
  iiwa) may leave it out: it then defaults to the limits; it may be narrower, never wider.
* ``obstacles`` are axis-aligned boxes in workspace coordinates (as many numbers each as the
  workspace has dimensions). The iiwa's base sits at the origin with z up.
* ``goal_radius`` is the radius of the goal region, a ball around ``goal`` in configuration
  space (radians for the iiwa).

Start and goal must be free: inside the bounds, clear of the boxes and, for the arm, of
itself (a self-collision error names the link pair). Every violation raises a `ValueError`
that names the field and the reason.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from temp_gym import limits
from temp_gym.problem.parsing import (
    MIN_LENGTH,
    as_float,
    float_vector,
    parse_problem_json,
)
from temp_gym.problem.robots import robot_named
from temp_gym.problem.workspace import Workspace

_KEYS = {"robot", "bounds", "obstacles", "start", "goal", "goal_radius"}
_BOX_KEYS = {"center", "half_extents"}


@dataclass(frozen=True)
class Problem:
    """A planning query: reach the ``goal_radius`` ball around ``goal`` from ``start``.

    Construct one from a `Workspace`, with `Problem.from_dict`, or with `Problem.load`; all
    three validate. Arrays are stored as read-only float64 numpy arrays.

    Examples:
        >>> p = Problem.from_dict({"robot": "point2d", "bounds": [[0, 0], [20, 20]],
        ...     "obstacles": [{"center": [10, 10], "half_extents": [1, 3]}],
        ...     "start": [2, 2], "goal": [18, 18], "goal_radius": 0.5})
        >>> p.dim, p.workspace.num_obstacles
        (2, 1)
    """

    workspace: Workspace
    """The robot, its bounds and the boxes."""
    start: np.ndarray
    """Start configuration, ``(dim,)``."""
    goal: np.ndarray
    """Centre of the goal region, ``(dim,)``."""
    goal_radius: float
    """Radius of the goal region (a closed ball in configuration space)."""

    def __post_init__(self) -> None:
        if not isinstance(self.workspace, Workspace):
            raise ValueError(
                f"workspace: expected a Workspace, got {type(self.workspace).__name__}"
            )
        dim, bounds = self.workspace.dim, self.workspace.bounds
        start = float_vector(self.start, "start", dim)
        goal = float_vector(self.goal, "goal", dim)
        radius = as_float(self.goal_radius, "goal_radius")
        if not math.isfinite(radius) or radius <= 0:
            raise ValueError(f"goal_radius: must be positive and finite, got {radius}")
        if radius < MIN_LENGTH:
            raise ValueError(
                f"goal_radius: {radius:g} is below {MIN_LENGTH:g} (its square would underflow)"
            )
        joints = robot_named(self.workspace.robot).joint_limits is not None
        for name, point in (("start", start), ("goal", goal)):
            if np.any(point < bounds[0]) or np.any(point > bounds[1]):
                raise ValueError(f"{name}: {outside_bounds(point, bounds, joints)}")
        start, goal = start + 0.0, goal + 0.0  # -0.0 as 0.0, as `Workspace` stores its arrays
        for array in (start, goal):
            array.setflags(write=False)
        object.__setattr__(self, "start", start)
        object.__setattr__(self, "goal", goal)
        object.__setattr__(self, "goal_radius", radius)
        robot = robot_named(self.workspace.robot)
        reasons = robot.collision_reasons(self.workspace, np.stack([start, goal]))
        for name, point, reason in zip(("start", "goal"), (start, goal), reasons):
            if reason is not None:
                raise ValueError(f"{name}: {point.tolist()} is in {reason}")

    # ------------------------------------------------------------------ properties
    @property
    def robot(self) -> str:
        """The robot's registered name."""
        return self.workspace.robot

    @property
    def bounds(self) -> np.ndarray:
        """The configuration space ``[lower, upper]``, ``(2, dim)``."""
        return self.workspace.bounds

    @property
    def dim(self) -> int:
        """Dimension of the configuration space."""
        return self.workspace.dim

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Problem):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    def __hash__(self) -> int:
        return hash(json.dumps(self.to_dict(), sort_keys=True))

    def replace(self, **changes: Any) -> Problem:
        """Return a copy with some JSON-format fields changed (validated again)."""
        data = self.to_dict()
        data.update(changes)
        return Problem.from_dict(data)

    def swapped(self) -> Problem:
        """The query backwards: start and goal exchanged, the same workspace and goal radius.

        What a tree grown from the goal plans (`temp_gym.planning.goal_tree`). Both points
        passed the same checks when this problem was made (in bounds, collision-free), so the
        swap is not checked again: on the arm those checks cost a forward kinematics and a
        collision query each, once per plan that grows a goal tree.
        """
        swapped = object.__new__(Problem)
        for name, value in (
            ("workspace", self.workspace),
            ("start", self.goal),
            ("goal", self.start),
            ("goal_radius", self.goal_radius),
        ):
            object.__setattr__(swapped, name, value)
        return swapped

    # ------------------------------------------------------------------ dict / JSON
    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Problem:
        """Build a problem from the JSON-format dictionary, rejecting unknown keys."""
        if not isinstance(data, dict):
            raise ValueError(f"problem: expected a JSON object, got {type(data).__name__}")
        unknown = set(data) - _KEYS
        if unknown:
            raise ValueError(
                f"{_cut(sorted(map(str, unknown))[0])}: unknown key; allowed keys are "
                f"{sorted(_KEYS)}"
            )
        missing = (_KEYS - {"bounds"}) - set(data)
        if missing:
            raise ValueError(f"{sorted(missing)[0]}: missing required key")
        robot = robot_named(data["robot"])
        dim, wdim = robot.dim, robot.workspace_dim
        if "bounds" in data:
            raw = data["bounds"]
            if not isinstance(raw, (list, tuple, np.ndarray)) or len(raw) != 2:
                raise ValueError("bounds: expected [lower, upper]")
            bounds = np.stack(
                [float_vector(raw[0], "bounds[0]", dim), float_vector(raw[1], "bounds[1]", dim)]
            )
        elif robot.joint_limits is not None:
            bounds = robot.joint_limits()
        else:
            raise ValueError(
                f"bounds: missing required key (only a robot with joint limits may leave it "
                f"out, not {robot.name})"
            )
        centers, halves = _boxes(data["obstacles"], wdim)
        start = float_vector(data["start"], "start", dim)
        goal = float_vector(data["goal"], "goal", dim)
        workspace = Workspace(robot.name, bounds, centers, halves)
        return cls(workspace, start, goal, data["goal_radius"])

    def to_dict(self) -> dict[str, Any]:
        """The JSON-format dictionary; ``Problem.from_dict(p.to_dict()) == p`` exactly."""
        workspace = self.workspace
        return {
            "robot": self.robot,
            "bounds": self.bounds.tolist(),
            "obstacles": [
                {"center": c.tolist(), "half_extents": h.tolist()}
                for c, h in zip(workspace.obstacle_centers, workspace.obstacle_half_extents)
            ],
            "start": self.start.tolist(),
            "goal": self.goal.tolist(),
            "goal_radius": self.goal_radius,
        }

    @classmethod
    def load(cls, path: str | Path) -> Problem:
        """Read a problem from a UTF-8 JSON file; any defect raises a `ValueError` naming it.

        A file beyond `MAX_PROBLEM_BYTES` (or a stream without end, such as ``/dev/zero``) is
        refused after reading that much, not read into memory whole.
        """
        with open(path, "rb") as handle:
            raw = handle.read(MAX_PROBLEM_BYTES + 1)
        if len(raw) > MAX_PROBLEM_BYTES:
            raise ValueError(
                f"{path}: larger than {MAX_PROBLEM_BYTES // 2**20} MB, too large to be a problem"
            )
        return cls.from_dict(parse_problem_json(raw, str(path)))

    def save(self, path: str | Path) -> None:
        """Write the problem as JSON (floats are written with full precision)."""
        Path(path).write_text(json.dumps(self.to_dict(), indent=1) + "\n")


def outside_bounds(
    point: np.ndarray, bounds: np.ndarray, joints: bool = False, most: int = 3
) -> str:
    """Which coordinates of ``point`` lie outside ``bounds``, each with its value and limit.

    Names the coordinate (``joint 2`` of an arm, counted from 1 as the URDF does, or ``[1]``)
    rather than printing every bound; at most ``most`` are listed, then how many more.

    Example:
        >>> outside_bounds(np.array([0.0, 3.2]), np.array([[-1, -2.9], [1, 2.9]]), joints=True)
        'outside the bounds: joint 2 = 3.2 is above its limit 2.9'
    """
    below = np.flatnonzero(point < bounds[0])
    above = np.flatnonzero(point > bounds[1])
    name = (lambda i: f"joint {i + 1}") if joints else (lambda i: f"[{i}]")
    limit = "its limit" if joints else "the bound"
    parts = [f"{name(i)} = {point[i]:.6g} is below {limit} {bounds[0, i]:.6g}" for i in below]
    parts += [f"{name(i)} = {point[i]:.6g} is above {limit} {bounds[1, i]:.6g}" for i in above]
    more = f" and {len(parts) - most} more" if len(parts) > most else ""
    return f"outside the bounds: {'; '.join(parts[:most])}{more}"


def _cut(key: str, most: int = 40) -> str:
    """A key for a message, cut short: a hostile file's key may be megabytes long."""
    return key if len(key) <= most else f"{key[:most]}...({len(key)} characters)"


MAX_PROBLEM_BYTES = limits.MAX_PROBLEM_BYTES
"""`Problem.load` refuses larger files (`temp_gym.limits`)."""


def _boxes(obstacles: Any, wdim: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``obstacles`` entry as ``(centers, half_extents)``, each ``(M, wdim)``."""
    if not isinstance(obstacles, (list, tuple)):
        raise ValueError("obstacles: expected a list of boxes")
    if len(obstacles) > limits.MAX_OBSTACLES:
        raise ValueError(
            f"obstacles: {len(obstacles)} boxes, at most {limits.MAX_OBSTACLES} are supported "
            "(docs/security.md)"
        )
    centers, halves = [], []
    for i, box in enumerate(obstacles):
        if not isinstance(box, dict):
            raise ValueError(f"obstacles[{i}]: expected an object with center and half_extents")
        extra = set(box) - _BOX_KEYS
        if extra:
            raise ValueError(
                f"obstacles[{i}].{_cut(sorted(map(str, extra))[0])}: unknown key; a box "
                f"has {' and '.join(sorted(_BOX_KEYS))}"
            )
        if _BOX_KEYS - set(box):
            raise ValueError(f"obstacles[{i}]: needs both center and half_extents")
        centers.append(float_vector(box["center"], f"obstacles[{i}].center", wdim))
        half = float_vector(box["half_extents"], f"obstacles[{i}].half_extents", wdim)
        if np.any(half <= 0):
            raise ValueError(f"obstacles[{i}].half_extents: must be positive, got {half.tolist()}")
        halves.append(half)
    return (
        np.array(centers, dtype=np.float64).reshape(-1, wdim),
        np.array(halves, dtype=np.float64).reshape(-1, wdim),
    )
