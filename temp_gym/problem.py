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


MAX_MAGNITUDE = 1e30
"""Largest magnitude of any coordinate or length. Planners square distances and multiply up
to 7 lengths (volumes): beyond this they would overflow to inf."""
MIN_LENGTH = 1e-30
"""Smallest goal radius and bound side: their squares and volumes must not underflow to 0
(a squared goal radius of 0 made a start outside the goal region count as inside)."""


def _as_float(value: Any, name: str) -> float:
    """``float(value)`` for a real number, or a `ValueError` naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
        raise ValueError(f"{name}: expected a number, got {value!r}")
    if isinstance(value, (complex, np.complexfloating)):
        raise ValueError(f"{name}: expected a real number, got {value!r}")
    try:
        number = float(value)
    except OverflowError:
        raise ValueError(
            f"{name}: {_short(value)} is too large (at most {MAX_MAGNITUDE:g})"
        ) from None
    if math.isfinite(number) and abs(number) > MAX_MAGNITUDE:
        raise ValueError(f"{name}: {number:g} is too large (at most {MAX_MAGNITUDE:g})")
    return number


def _short(value: Any) -> str:
    text = str(value)
    return text if len(text) <= 24 else f"{text[:10]}...({len(text)} digits)"


def _joint_limits(robot: str) -> np.ndarray | None:
    """The robot's own ``(2, dim)`` joint limits, which ``bounds`` must lie within, if any."""
    if robot == "kuka_iiwa14":
        from temp_gym.worlds.robots.iiwa14 import joint_limits

        return joint_limits()
    return None


def _float_vector(value: Any, name: str, length: int) -> np.ndarray:
    """Convert ``value`` to a finite float vector of ``length`` or raise a naming `ValueError`."""
    if isinstance(value, np.ndarray) and value.dtype.kind in "fiu":
        value = value.tolist()
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise ValueError(f"{name}: expected a list of {length} numbers, got {_short(value)}")
    if len(value) != length:
        raise ValueError(f"{name}: expected {length} numbers, got {len(value)}")
    if any(isinstance(v, bool) or not isinstance(v, (int, float, np.number)) for v in value):
        raise ValueError(f"{name}: expected numbers, got {_short(list(value))}")
    array = np.array([_as_float(v, f"{name}[{i}]") for i, v in enumerate(value)])
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name}: contains NaN or inf: {array.tolist()}")
    return array


def _float_array(value: Any, name: str, shape: tuple[int, ...] | None = None) -> np.ndarray:
    """A float64 array of ``value`` (of ``shape``, if given), or a `ValueError` naming it."""
    try:
        array = np.array(value, dtype=np.float64)
    except OverflowError:
        raise ValueError(f"{name}: a number is too large (at most {MAX_MAGNITUDE:g})") from None
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected numbers, got {_short(value)}") from None
    if np.iscomplexobj(value):
        raise ValueError(f"{name}: expected real numbers")
    if shape is not None and array.shape != shape:
        raise ValueError(f"{name}: expected shape {shape}, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name}: contains NaN or inf")
    if array.size and np.max(np.abs(array)) > MAX_MAGNITUDE:
        raise ValueError(f"{name}: a magnitude above {MAX_MAGNITUDE:g} (distances would overflow)")
    return array


def _reject_duplicate_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """``json`` hook: an object may not repeat a key (JSON would silently keep the last)."""
    data: dict[str, Any] = {}
    for key, value in pairs:
        if key in data:
            raise ValueError(f"{key}: duplicate key (a JSON object names each key once)")
        data[key] = value
    return data


def parse_problem_json(raw: bytes, source: str) -> Any:
    """Decode and parse a problem file's bytes: UTF-8 JSON, no duplicate keys.

    Raises:
        ValueError: naming ``source`` and the reason (encoding, syntax, nesting, duplicates).
    """
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        hint = " (it looks like UTF-16)" if raw[:2] in (b"\xff\xfe", b"\xfe\xff") else ""
        raise ValueError(
            f"problem: {source} is not UTF-8 text{hint}: byte {error.start} cannot be decoded; "
            "save it as UTF-8"
        ) from None
    try:
        return json.loads(text, object_pairs_hook=_reject_duplicate_keys)
    except json.JSONDecodeError as error:
        raise ValueError(f"problem: malformed JSON in {source}: {error}") from None
    except RecursionError:
        raise ValueError(f"problem: {source} nests JSON too deeply to be a problem") from None
    except ValueError as error:  # a duplicate key, or an integer of too many digits
        raise ValueError(f"problem: {source}: {error}") from None


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
        bounds = _float_array(self.bounds, "bounds")
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
        limits = _joint_limits(self.robot)
        if limits is not None and (np.any(bounds[0] < limits[0]) or np.any(bounds[1] > limits[1])):
            joint = int(np.argmax((bounds[0] < limits[0]) | (bounds[1] > limits[1])))
            raise ValueError(
                f"bounds: wider than the {self.robot} joint limits at joint {joint + 1}: "
                f"[{bounds[0, joint]}, {bounds[1, joint]}] is not within "
                f"[{limits[0, joint]}, {limits[1, joint]}] (the URDF's limits, radians)"
            )
        centers = _float_array(self.obstacle_centers, "obstacles: center").reshape(-1, wdim)
        halves = _float_array(self.obstacle_half_extents, "obstacles: half_extents")
        halves = halves.reshape(-1, wdim)
        if centers.shape != halves.shape:
            raise ValueError("obstacles: centers and half_extents differ in count")
        if np.any(halves <= 0):
            bad = int(np.argmax(np.any(halves <= 0, axis=1)))
            raise ValueError(
                f"obstacles[{bad}].half_extents: must be positive, got {halves[bad].tolist()}"
            )
        start = _float_vector(self.start, "start", dim)
        goal = _float_vector(self.goal, "goal", dim)
        radius = _as_float(self.goal_radius, "goal_radius")
        if not math.isfinite(radius) or radius <= 0:
            raise ValueError(f"goal_radius: must be positive and finite, got {radius}")
        if radius < MIN_LENGTH:
            raise ValueError(
                f"goal_radius: {radius:g} is below {MIN_LENGTH:g} (its square would underflow)"
            )
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
        """Read a problem from a UTF-8 JSON file; any defect raises a `ValueError` naming it."""
        raw = Path(path).read_bytes()
        return cls.from_dict(parse_problem_json(raw, str(path)))

    def save(self, path: str | Path) -> None:
        """Write the problem as JSON (floats are written with full precision)."""
        Path(path).write_text(json.dumps(self.to_dict(), indent=1) + "\n")
