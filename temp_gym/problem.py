"""`Problem`: one motion-planning query (robot, bounds, boxes, start, goal) and its JSON format.

The JSON format is fixed, because users and our own test sets are written against it::

    {"robot": "point2d",
     "bounds": [[0, 0], [20, 20]],
     "obstacles": [{"center": [10, 10], "half_extents": [1, 3]}],
     "start": [2, 2], "goal": [18, 18], "goal_radius": 0.5}

* ``robot`` is ``point2d``, ``point3d`` or ``kuka_iiwa14``.
* ``bounds`` is the configuration space as ``[lower, upper]``. For ``kuka_iiwa14`` it may be
  left out and then defaults to the URDF joint limits; it may be narrower, never wider.
* ``obstacles`` are axis-aligned boxes in workspace coordinates (2 numbers each for
  ``point2d``, 3 otherwise). The iiwa's base sits at the origin with z up.
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

ROBOTS: dict[str, tuple[int, int]] = {
    # robot: (configuration-space dimension, workspace dimension)
    "point2d": (2, 2),
    "point3d": (3, 3),
    "kuka_iiwa14": (7, 3),
}
_KEYS = {"robot", "bounds", "obstacles", "start", "goal", "goal_radius"}
_BOX_KEYS = {"center", "half_extents"}


def _joint_limits(robot: str) -> np.ndarray | None:
    """The robot's own ``(2, dim)`` joint limits, which ``bounds`` must lie within, if any."""
    if robot == "kuka_iiwa14":
        from temp_gym.worlds.robots.iiwa14 import joint_limits

        return joint_limits()
    return None


def _float_vector(value: Any, name: str, length: int) -> np.ndarray:
    """Convert ``value`` to a finite float vector of ``length`` or raise a naming `ValueError`."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise ValueError(f"{name}: expected a list of {length} numbers, got {value!r}")
    if len(value) != length:
        raise ValueError(f"{name}: expected {length} numbers, got {len(value)}")
    if any(isinstance(v, bool) or not isinstance(v, (int, float, np.number)) for v in value):
        raise ValueError(f"{name}: expected numbers, got {list(value)!r}")
    array = np.asarray(value, dtype=np.float64)
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name}: contains NaN or inf: {array.tolist()}")
    return array


@dataclass(frozen=True)
class Problem:
    """A planning query: reach the ``goal_radius`` ball around ``goal`` from ``start``.

    Construct one directly, with `Problem.from_dict`, or with `Problem.load`; all three
    validate. Arrays are stored as read-only float64 numpy arrays.

    Example:
        >>> p = Problem.from_dict({"robot": "point2d", "bounds": [[0, 0], [20, 20]],
        ...     "obstacles": [{"center": [10, 10], "half_extents": [1, 3]}],
        ...     "start": [2, 2], "goal": [18, 18], "goal_radius": 0.5})
        >>> p.dim
        2
    """

    robot: str
    bounds: np.ndarray
    obstacle_centers: np.ndarray
    obstacle_half_extents: np.ndarray
    start: np.ndarray
    goal: np.ndarray
    goal_radius: float

    def __post_init__(self) -> None:
        if not isinstance(self.robot, str) or self.robot not in ROBOTS:
            raise ValueError(f"robot: unknown robot {self.robot!r}; expected one of {list(ROBOTS)}")
        dim, wdim = ROBOTS[self.robot]
        bounds = np.asarray(self.bounds, dtype=np.float64)
        if bounds.shape != (2, dim):
            raise ValueError(
                f"bounds: expected shape (2, {dim}) for {self.robot}, got {bounds.shape}"
            )
        if not np.all(np.isfinite(bounds)):
            raise ValueError("bounds: contains NaN or inf")
        if np.any(bounds[0] >= bounds[1]):
            raise ValueError(
                f"bounds: lower must be below upper in every dimension, got {bounds.tolist()}"
            )
        limits = _joint_limits(self.robot)
        if limits is not None and (np.any(bounds[0] < limits[0]) or np.any(bounds[1] > limits[1])):
            joint = int(np.argmax((bounds[0] < limits[0]) | (bounds[1] > limits[1])))
            raise ValueError(
                f"bounds: wider than the {self.robot} joint limits at joint {joint + 1}: "
                f"[{bounds[0, joint]}, {bounds[1, joint]}] is not within "
                f"[{limits[0, joint]}, {limits[1, joint]}] (the URDF's limits, radians)"
            )
        centers = np.asarray(self.obstacle_centers, dtype=np.float64).reshape(-1, wdim)
        halves = np.asarray(self.obstacle_half_extents, dtype=np.float64).reshape(-1, wdim)
        if centers.shape != halves.shape:
            raise ValueError("obstacles: centers and half_extents differ in count")
        if not (np.all(np.isfinite(centers)) and np.all(np.isfinite(halves))):
            raise ValueError("obstacles: contains NaN or inf")
        if np.any(halves <= 0):
            bad = int(np.argmax(np.any(halves <= 0, axis=1)))
            raise ValueError(
                f"obstacles[{bad}].half_extents: must be positive, got {halves[bad].tolist()}"
            )
        start = _float_vector(self.start, "start", dim)
        goal = _float_vector(self.goal, "goal", dim)
        radius = self.goal_radius
        if isinstance(radius, bool) or not isinstance(radius, (int, float, np.number)):
            raise ValueError(f"goal_radius: expected a number, got {radius!r}")
        radius = float(radius)
        if not math.isfinite(radius) or radius <= 0:
            raise ValueError(f"goal_radius: must be positive and finite, got {radius}")
        for name, point in (("start", start), ("goal", goal)):
            if np.any(point < bounds[0]) or np.any(point > bounds[1]):
                raise ValueError(
                    f"{name}: {point.tolist()} is outside the bounds {bounds.tolist()}"
                )
        for array in (bounds, centers, halves, start, goal):
            array.setflags(write=False)
        object.__setattr__(self, "bounds", bounds)
        object.__setattr__(self, "obstacle_centers", centers)
        object.__setattr__(self, "obstacle_half_extents", halves)
        object.__setattr__(self, "start", start)
        object.__setattr__(self, "goal", goal)
        object.__setattr__(self, "goal_radius", radius)
        self._check_collisions()

    def _check_collisions(self) -> None:
        from temp_gym.worlds.collision import SelfCollisionChecker, make_checker

        checker = make_checker(self)
        free = checker.states_free(np.stack([self.start, self.goal]))
        for name, ok in zip(("start", "goal"), free):
            if ok:
                continue
            point = getattr(self, name)
            pairs = (
                checker.self_collisions(point) if isinstance(checker, SelfCollisionChecker) else []
            )
            reason = (
                "self-collision between " + ", ".join(f"{a} and {b}" for a, b in pairs)
                if pairs
                else "collision"
            )
            raise ValueError(f"{name}: {point.tolist()} is in {reason} ({checker.description})")

    # ------------------------------------------------------------------ properties
    @property
    def dim(self) -> int:
        """Dimension of the configuration space."""
        return ROBOTS[self.robot][0]

    @property
    def workspace_dim(self) -> int:
        """Dimension of the workspace the boxes live in."""
        return ROBOTS[self.robot][1]

    @property
    def num_obstacles(self) -> int:
        """Number of boxes."""
        return len(self.obstacle_centers)

    @property
    def obstacle_lower(self) -> np.ndarray:
        """Lower corners of the boxes, shape (M, workspace_dim)."""
        return self.obstacle_centers - self.obstacle_half_extents

    @property
    def obstacle_upper(self) -> np.ndarray:
        """Upper corners of the boxes, shape (M, workspace_dim)."""
        return self.obstacle_centers + self.obstacle_half_extents

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Problem):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    def __hash__(self) -> int:
        return hash(json.dumps(self.to_dict(), sort_keys=True))

    def replace(self, **changes: Any) -> Problem:
        """Return a copy with some fields changed (validated again)."""
        data = self.to_dict()
        data.update(changes)
        return Problem.from_dict(data)

    # ------------------------------------------------------------------ dict / JSON
    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Problem:
        """Build a problem from the JSON-format dictionary, rejecting unknown keys."""
        if not isinstance(data, dict):
            raise ValueError(f"problem: expected a JSON object, got {type(data).__name__}")
        unknown = set(data) - _KEYS
        if unknown:
            raise ValueError(f"{sorted(unknown)[0]}: unknown key; allowed keys are {sorted(_KEYS)}")
        missing = (_KEYS - {"bounds"}) - set(data)
        if missing:
            raise ValueError(f"{sorted(missing)[0]}: missing required key")
        robot = data["robot"]
        if not isinstance(robot, str) or robot not in ROBOTS:
            raise ValueError(f"robot: unknown robot {robot!r}; expected one of {list(ROBOTS)}")
        dim, wdim = ROBOTS[robot]
        if "bounds" in data:
            raw = data["bounds"]
            if not isinstance(raw, (list, tuple)) or len(raw) != 2:
                raise ValueError("bounds: expected [lower, upper]")
            bounds = np.stack(
                [_float_vector(raw[0], "bounds[0]", dim), _float_vector(raw[1], "bounds[1]", dim)]
            )
        elif _joint_limits(robot) is not None:
            bounds = _joint_limits(robot)
        else:
            raise ValueError("bounds: missing required key (only kuka_iiwa14 may leave it out)")
        obstacles = data["obstacles"]
        if not isinstance(obstacles, (list, tuple)):
            raise ValueError("obstacles: expected a list of boxes")
        centers, halves = [], []
        for i, box in enumerate(obstacles):
            if not isinstance(box, dict):
                raise ValueError(f"obstacles[{i}]: expected an object with center and half_extents")
            extra = set(box) - _BOX_KEYS
            if extra:
                raise ValueError(f"obstacles[{i}].{sorted(extra)[0]}: unknown key")
            if _BOX_KEYS - set(box):
                raise ValueError(f"obstacles[{i}]: needs both center and half_extents")
            centers.append(_float_vector(box["center"], f"obstacles[{i}].center", wdim))
            half = _float_vector(box["half_extents"], f"obstacles[{i}].half_extents", wdim)
            if np.any(half <= 0):
                raise ValueError(
                    f"obstacles[{i}].half_extents: must be positive, got {half.tolist()}"
                )
            halves.append(half)
        return cls(
            robot=robot,
            bounds=bounds,
            obstacle_centers=np.array(centers, dtype=np.float64).reshape(-1, wdim),
            obstacle_half_extents=np.array(halves, dtype=np.float64).reshape(-1, wdim),
            start=_float_vector(data["start"], "start", dim),
            goal=_float_vector(data["goal"], "goal", dim),
            goal_radius=data["goal_radius"],
        )

    def to_dict(self) -> dict[str, Any]:
        """The JSON-format dictionary; ``Problem.from_dict(p.to_dict()) == p`` exactly."""
        return {
            "robot": self.robot,
            "bounds": self.bounds.tolist(),
            "obstacles": [
                {"center": c.tolist(), "half_extents": h.tolist()}
                for c, h in zip(self.obstacle_centers, self.obstacle_half_extents)
            ],
            "start": self.start.tolist(),
            "goal": self.goal.tolist(),
            "goal_radius": self.goal_radius,
        }

    @classmethod
    def load(cls, path: str | Path) -> Problem:
        """Read a problem from a JSON file; malformed JSON raises a `ValueError`."""
        text = Path(path).read_text()
        try:
            data = json.loads(text)
        except json.JSONDecodeError as error:
            raise ValueError(f"problem: malformed JSON in {path}: {error}") from None
        return cls.from_dict(data)

    def save(self, path: str | Path) -> None:
        """Write the problem as JSON (floats are written with full precision)."""
        Path(path).write_text(json.dumps(self.to_dict(), indent=1) + "\n")
