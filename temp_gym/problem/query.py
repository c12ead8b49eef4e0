"""`Problem`: one motion-planning query (a workspace, start, goal, goal region) and its JSON format.

The JSON format is versioned, because users and our own test sets are written against it::

    {"robot": "point2d",
     "bounds": [[0, 0], [20, 20]],
     "obstacles": [{"center": [10, 10], "half_extents": [1, 3]}],
     "start": [2, 2], "goal": [18, 18], "goal_radius": 0.5}

is version 1 (axis-aligned boxes), and still reads unchanged. Version 2 (``"version": 2``,
optional when reading, though a file that declares ``"version": 1`` must hold only
axis-aligned boxes) adds obstacle kinds, each named by ``"type"`` (a missing ``"type"``
is ``"box"``)::

    {"type": "box", "center": [0.6, 0, 0.4], "half_extents": [0.3, 0.2, 0.02],
     "orientation": [0, 0, 0.3826834, 0.9238795]}
    {"type": "cylinder", "center": [0.5, 0.3, 0.5], "radius": 0.04, "length": 0.2}
    {"type": "sphere", "center": [0.4, -0.3, 0.6], "radius": 0.05}

``orientation`` is optional: a unit quaternion ``[x, y, z, w]`` in 3D, an angle in radians
in 2D; a cylinder's axis is its local z (3D workspaces only); a sphere is a disc in 2D.
`Problem.to_dict` writes version 1 when every obstacle is an axis-aligned box, version 2
otherwise.

* ``robot`` names a registered robot (`temp_gym.worlds.robots`): ``point2d``, ``point3d`` or
  ``kuka_iiwa14`` as shipped.
* ``bounds`` is the configuration space as ``[lower, upper]``. A robot with joint limits (the
  iiwa) may leave it out: it then defaults to the limits; it may be narrower, never wider.
* ``obstacles`` are in workspace coordinates (as many numbers per center and half extents as
  the workspace has dimensions). An arm's base sits at the origin with z up.
* ``goal_radius`` is the radius of the goal region, a ball around ``goal`` in configuration
  space (radians for the iiwa).

Start and goal must be free: inside the bounds, clear of the obstacles and, for an arm, of
itself (a self-collision error names the link pair). Every violation raises a `ValueError`
that names the field and the reason. `Problem.unchecked` skips the collision test alone, for
benchmark sets whose problems are taken as they are.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from temp_gym import limits
from temp_gym.problem.obstacles import (
    BOX,
    CYLINDER,
    KIND_NAMES,
    SPHERE,
    identity_orientations,
    orientation_width,
)
from temp_gym.problem.parsing import (
    MIN_LENGTH,
    as_float,
    float_vector,
    parse_problem_json,
    positive_length,
)
from temp_gym.problem.robots import robot_named
from temp_gym.problem.workspace import Workspace

PATH_END_SLACK = 1e-9
"""How far a path's first state may be from the start, and its last outside the goal ball."""

_KEYS = {"robot", "bounds", "obstacles", "start", "goal", "goal_radius", "version"}
_OPTIONAL = {"bounds", "version"}
VERSIONS = (1, 2)
"""The problem-format versions this library reads; it writes the lowest that holds a problem."""
_OBSTACLE_KEYS = {
    "box": ({"center", "half_extents"}, {"type", "orientation"}),
    "cylinder": ({"type", "center", "radius", "length"}, {"orientation"}),
    "sphere": ({"type", "center", "radius"}, set()),
}
"""Per ``"type"``: the keys an obstacle must have, and those it may have."""


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
        self._validate()
        robot = robot_named(self.workspace.robot)
        reasons = robot.collision_reasons(self.workspace, np.stack([self.start, self.goal]))
        for name, point, reason in zip(("start", "goal"), (self.start, self.goal), reasons):
            if reason is not None:
                raise ValueError(f"{name}: {point.tolist()} is in {reason}")

    @classmethod
    def unchecked(cls, workspace: Workspace, start: Any, goal: Any, goal_radius: float) -> Problem:
        """A problem validated like any other except that start and goal may be in collision.

        For benchmark sets made elsewhere, whose problems must be loaded as they are and the
        ones in collision reported rather than refused (`temp_gym.benchmarks`). The workspace,
        shapes, bounds and goal radius are still checked. Such a problem does not survive
        `replace` or ``Problem.from_dict(p.to_dict())``, which check collisions again.
        """
        problem = object.__new__(cls)
        for name, value in (
            ("workspace", workspace),
            ("start", start),
            ("goal", goal),
            ("goal_radius", goal_radius),
        ):
            object.__setattr__(problem, name, value)
        problem._validate()
        return problem

    def _validate(self) -> None:
        """Check and store every field, the collision test aside (`unchecked` stops here)."""
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

    def path_ends_error(self, path: Any) -> str | None:
        """Why ``path`` does not run from the start into the goal region; None when it does.

        ``path`` must be ``(K, dim)`` states with ``K >= 2``, the first the start and the last
        in the closed goal ball, each to 1e-9 (rounding in stored files). Collisions are the
        checkers' to find (`temp_gym.worlds.checkers.certify_path`).
        """
        try:
            path = np.asarray(path, dtype=np.float64)
        except (TypeError, ValueError):
            return "it is no array of numbers"
        if path.ndim != 2 or path.shape[1] != self.dim or len(path) < 2:
            return f"expected at least 2 states of {self.dim} numbers, got shape {path.shape}"
        if not np.allclose(path[0], self.start, rtol=0.0, atol=PATH_END_SLACK):
            return f"it starts at {np.round(path[0], 6).tolist()}, not at the problem's start"
        if not np.linalg.norm(path[-1] - self.goal) <= self.goal_radius + PATH_END_SLACK:
            return "its last state is outside the goal region"
        return None

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
        missing = (_KEYS - _OPTIONAL) - set(data)
        if missing:
            raise ValueError(f"{sorted(missing)[0]}: missing required key")
        version = data.get("version", 1)
        if isinstance(version, bool) or version not in VERSIONS:
            raise ValueError(
                f"version: {_cut(repr(version))} is not a problem-format version this temp-gym "
                f"reads ({', '.join(map(str, VERSIONS))})"
            )
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
        centers, halves, kinds, orientations = obstacle_arrays(data["obstacles"], wdim)
        start = float_vector(data["start"], "start", dim)
        goal = float_vector(data["goal"], "goal", dim)
        workspace = Workspace(robot.name, bounds, centers, halves, kinds, orientations)
        if "version" in data and version == 1 and not workspace.axis_aligned:
            b = int(np.argmax((workspace.obstacle_kinds != BOX) | ~workspace.unrotated))
            what = ("an oriented box" if workspace.obstacle_kinds[b] == BOX
                    else f"a {KIND_NAMES[workspace.obstacle_kinds[b]]}")  # fmt: skip
            raise ValueError(
                f'obstacles[{b}]: {what} needs "version": 2; the file declares version 1, '
                "which has axis-aligned boxes only"
            )
        return cls(workspace, start, goal, data["goal_radius"])

    def to_dict(self) -> dict[str, Any]:
        """The JSON-format dictionary; ``Problem.from_dict(p.to_dict()) == p`` exactly."""
        workspace = self.workspace
        version = 1 if workspace.axis_aligned else 2
        data: dict[str, Any] = {} if version == 1 else {"version": 2}
        data.update(
            {
                "robot": self.robot,
                "bounds": self.bounds.tolist(),
                "obstacles": obstacle_dicts(workspace),
                "start": self.start.tolist(),
                "goal": self.goal.tolist(),
                "goal_radius": self.goal_radius,
            }
        )
        return data

    @classmethod
    def load(cls, path: str | Path) -> Problem:
        """Read a problem from a UTF-8 JSON file; any defect raises a `ValueError` naming it.

        A file that cannot be read raises the `OSError` that `open` raises, with one line
        naming the file and the reason.

        A file beyond `MAX_PROBLEM_BYTES` (or a stream without end, such as ``/dev/zero``) is
        refused after reading that much, not read into memory whole.
        """
        try:
            with open(path, "rb") as handle:
                raw = handle.read(MAX_PROBLEM_BYTES + 1)
        except OSError as error:  # the same kind of error, with a line a user can read
            reason = (error.strerror or type(error).__name__).lower()
            raise type(error)(f"{path}: cannot read the problem file ({reason})") from None
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

    parts = []
    for side, word, indices in ((0, "below", below), (1, "above", above)):
        for i in indices:
            value, bound = f"{point[i]:.6g}", f"{bounds[side, i]:.6g}"
            if value == bound:  # a hair outside: print every digit, or the two read alike
                value, bound = repr(float(point[i])), repr(float(bounds[side, i]))
            parts.append(f"{name(i)} = {value} is {word} {limit} {bound}")
    more = f" and {len(parts) - most} more" if len(parts) > most else ""
    return f"outside the bounds: {'; '.join(parts[:most])}{more}"


def _cut(key: str, most: int = 40) -> str:
    """A key for a message, cut short: a hostile file's key may be megabytes long."""
    return key if len(key) <= most else f"{key[:most]}...({len(key)} characters)"


MAX_PROBLEM_BYTES = limits.MAX_PROBLEM_BYTES
"""`Problem.load` refuses larger files (`temp_gym.limits`)."""


def obstacle_dicts(workspace: Workspace) -> list[dict[str, Any]]:
    """The workspace's obstacles as problem-format entries.

    Version 1's boxes when every obstacle is an axis-aligned box, else version 2's typed
    entries (an orientation only where it is not the identity).
    """
    if workspace.axis_aligned:
        return [
            {"center": c.tolist(), "half_extents": h.tolist()}
            for c, h in zip(workspace.obstacle_centers, workspace.obstacle_half_extents)
        ]
    entries = []
    unrotated = workspace.unrotated
    for b, kind in enumerate(workspace.obstacle_kinds):
        center = workspace.obstacle_centers[b].tolist()
        half = workspace.obstacle_half_extents[b]
        entry: dict[str, Any] = {"type": KIND_NAMES[kind], "center": center}
        if kind == BOX:
            entry["half_extents"] = half.tolist()
        elif kind == CYLINDER:
            entry["radius"] = float(half[0])
            entry["length"] = float(2.0 * half[2])
        else:
            entry["radius"] = float(half[0])
        if kind != SPHERE and not unrotated[b]:
            orientation = workspace.obstacle_orientations[b]
            entry["orientation"] = (
                float(orientation[0]) if len(orientation) == 1 else orientation.tolist()
            )
        entries.append(entry)
    return entries


def obstacle_arrays(obstacles: Any, wdim: int) -> tuple[np.ndarray, ...]:
    """The ``obstacles`` entry as ``(centers, half_extents, kinds, orientations)`` arrays."""
    if not isinstance(obstacles, (list, tuple)):
        raise ValueError("obstacles: expected a list of obstacles")
    if len(obstacles) > limits.MAX_OBSTACLES:
        raise ValueError(
            f"obstacles: {len(obstacles)} obstacles, at most {limits.MAX_OBSTACLES} are "
            "supported (docs/security.md)"
        )
    count = len(obstacles)
    centers = np.empty((count, wdim))
    halves = np.empty((count, wdim))
    kinds = np.zeros(count, dtype=np.int8)
    orientations = identity_orientations(count, wdim)
    for i, entry in enumerate(obstacles):
        where = f"obstacles[{i}]"
        if not isinstance(entry, dict):
            raise ValueError(f"{where}: expected an object (a box, cylinder or sphere)")
        kind_name = entry.get("type", "box")
        if not isinstance(kind_name, str) or kind_name not in _OBSTACLE_KEYS:
            raise ValueError(
                f"{where}.type: {_cut(repr(kind_name))} is not an obstacle type; expected one "
                f"of {list(_OBSTACLE_KEYS)}"
            )
        required, optional = _OBSTACLE_KEYS[kind_name]
        extra = set(entry) - required - optional
        if extra:
            named = " and ".join(sorted(required - {"type"}))
            others = sorted(optional | {"type"}) if kind_name == "box" else sorted(optional)
            also = f" (optional: {', '.join(others)})" if others else ""
            raise ValueError(
                f"{where}.{_cut(sorted(map(str, extra))[0])}: unknown key; a {kind_name} has "
                f"{named}{also}"
            )
        absent = required - set(entry)
        if absent:
            raise ValueError(
                f"{where}: a {kind_name} needs {' and '.join(sorted(required - {'type'}))}; "
                f"{sorted(absent)[0]} is missing"
            )
        kind = KIND_NAMES.index(kind_name)
        if kind == CYLINDER and wdim != 3:
            raise ValueError(
                f"{where}.type: a cylinder needs a 3D workspace (this robot's is {wdim}D; a "
                "disc is a 'sphere')"
            )
        kinds[i] = kind
        centers[i] = float_vector(entry["center"], f"{where}.center", wdim)
        if kind == BOX:
            half = float_vector(entry["half_extents"], f"{where}.half_extents", wdim)
            if np.any(half <= 0):
                raise ValueError(f"{where}.half_extents: must be positive, got {half.tolist()}")
            halves[i] = half
        else:
            radius = positive_length(entry["radius"], f"{where}.radius")
            halves[i] = radius
            if kind == CYLINDER:
                halves[i, 2] = 0.5 * positive_length(entry["length"], f"{where}.length")
        if "orientation" in entry:
            orientations[i] = _orientation(entry["orientation"], f"{where}.orientation", wdim)
    return centers, halves, kinds, orientations


def _orientation(value: Any, name: str, wdim: int) -> np.ndarray:
    """An orientation entry: an angle in 2D, a quaternion ``[x, y, z, w]`` in 3D."""
    if orientation_width(wdim) == 1:
        if isinstance(value, (list, tuple)):
            raise ValueError(f"{name}: in 2D an orientation is one angle (radians), got {value!r}")
        angle = as_float(value, name)
        if not math.isfinite(angle):
            raise ValueError(f"{name}: must be finite, got {value!r}")
        return np.array([angle])
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"{name}: expected a quaternion [x, y, z, w], got {_cut(repr(value))}")
    return float_vector(value, name, 4)
