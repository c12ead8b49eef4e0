"""`Workspace`: a robot's bounds and obstacles, shared by the many tasks planned in them."""

from __future__ import annotations

import functools
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from temp_gym.limits import MAX_OBSTACLES
from temp_gym.problem.obstacles import (
    BOX,
    CYLINDER,
    KIND_NAMES,
    SPHERE,
    UNIT_TOLERANCE,
    Box,
    Cylinder,
    Obstacle,
    Sphere,
    as_obstacle,
    identity_orientations,
    is_identity,
    kind_volumes,
    obstacle_entry,
    orientation_width,
    rotation_matrices,
    world_half_extents,
)
from temp_gym.problem.parsing import MIN_LENGTH, float_array
from temp_gym.problem.robots import robot_named


def _rows(value: object, name: str, width: int, robot: str) -> np.ndarray:
    """``value`` as ``(M, width)`` float64 rows (nothing at all is zero rows).

    A wrong width is refused rather than reshaped: rows of another robot's workspace would
    otherwise be read as different obstacles.
    """
    array = float_array(value, name)
    if array.size == 0:
        return array.reshape(0, width)
    if array.ndim != 2 or array.shape[1] != width:
        raise ValueError(
            f"{name}: expected one row of {width} numbers per obstacle ({robot}'s workspace is "
            f"{width}D), shape (M, {width}), got {array.shape}"
        )
    return array


def canonical_quaternions(quaternions: np.ndarray) -> np.ndarray:
    """Each quaternion ``[x, y, z, w]`` as whichever of ``q`` and ``-q`` (one rotation) leads.

    The one kept has its first nonzero component, read from ``w`` then ``x, y, z``, positive.
    So one rotation is stored one way: workspaces equal as rotations compare and hash equal,
    and a file written from one loads back equal.
    """
    order = quaternions[:, [3, 0, 1, 2]]
    first = np.argmax(order != 0.0, axis=1)
    negative = order[np.arange(len(order)), first] < 0.0
    return np.where(negative[:, None], -quaternions, quaternions)


@dataclass(frozen=True, eq=False)
class Workspace:
    """A robot's configuration bounds and obstacles, without a task.

    Obstacles are boxes (optionally oriented), cylinders and spheres, stored as arrays with a
    row per obstacle (`temp_gym.problem.obstacles` explains the layout). The four positional
    fields alone make axis-aligned boxes, as before there were other kinds.

    Generators draw one workspace and then many tasks in it, as the paper does (200
    start-goal pairs per workspace); the occupancy encoding and other per-workspace work are
    done once per workspace. Every field is validated (a `ValueError` names the field) and
    stored as a read-only float64 array. Two workspaces are equal when their robot, bounds and
    obstacles are (a quaternion is stored as the one of ``q`` and ``-q`` with the first nonzero
    of ``w, x, y, z`` positive), and equal workspaces hash alike, so a workspace can key a cache.

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
    """Half sides of each obstacle's box in its own frame, ``(M, workspace_dim)``, positive
    (a cylinder's ``(r, r, length / 2)``, a sphere's ``(r, r, r)``)."""
    obstacle_kinds: np.ndarray | None = None
    """`BOX`, `CYLINDER` or `SPHERE` per obstacle, ``int8 (M,)``; None means all boxes."""
    obstacle_orientations: np.ndarray | None = None
    """Quaternions ``[x, y, z, w]`` ``(M, 4)`` in 3D, angles ``(M, 1)`` in 2D; None: identity."""
    _key: tuple = field(init=False, repr=False)
    _rotations: np.ndarray = field(init=False, repr=False)

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
        centers = _rows(self.obstacle_centers, "obstacles: center", wdim, self.robot)
        halves = _rows(self.obstacle_half_extents, "obstacles: half_extents", wdim, self.robot)
        if centers.shape != halves.shape:
            raise ValueError("obstacles: centers and half_extents differ in count")
        if len(centers) > MAX_OBSTACLES:
            raise ValueError(
                f"obstacles: {len(centers)} obstacles, at most {MAX_OBSTACLES} are supported "
                "(temp_gym.limits)"
            )
        if np.any(halves <= 0):
            bad = int(np.argmax(np.any(halves <= 0, axis=1)))
            raise ValueError(
                f"obstacles[{bad}].half_extents: must be positive, got {halves[bad].tolist()}"
            )
        if np.any(2 * halves < MIN_LENGTH):  # as the bounds': volumes must not underflow
            bad = int(np.argmax(np.any(2 * halves < MIN_LENGTH, axis=1)))
            raise ValueError(
                f"obstacles[{bad}].half_extents: every side must be at least {MIN_LENGTH:g} "
                f"long, got {halves[bad].tolist()}"
            )
        kinds = self._kinds(len(centers))
        orientations = self._orientations(len(centers), wdim)
        for b in np.flatnonzero(kinds == CYLINDER):
            if halves[b, 0] != halves[b, 1]:
                raise ValueError(
                    f"obstacles[{b}].half_extents: a cylinder's first two are its radius and "
                    f"must be equal, got {halves[b].tolist()}"
                )
        for b in np.flatnonzero(kinds == SPHERE):
            if np.any(halves[b] != halves[b, 0]):
                raise ValueError(
                    f"obstacles[{b}].half_extents: a sphere's are all its radius, got "
                    f"{halves[b].tolist()}"
                )
            if not is_identity(orientations[b : b + 1])[0]:
                raise ValueError(f"obstacles[{b}].orientation: a sphere has no orientation")
        # -0.0 becomes 0.0: equal workspaces must have equal bytes, which equality and hash read
        bounds, centers, halves = bounds + 0.0, centers + 0.0, halves + 0.0
        orientations = orientations + 0.0
        rotations = rotation_matrices(orientations)
        for array in (bounds, centers, halves, kinds, orientations, rotations):
            array.setflags(write=False)
        object.__setattr__(self, "bounds", bounds)
        object.__setattr__(self, "obstacle_centers", centers)
        object.__setattr__(self, "obstacle_half_extents", halves)
        object.__setattr__(self, "obstacle_kinds", kinds)
        object.__setattr__(self, "obstacle_orientations", orientations)
        object.__setattr__(self, "_rotations", rotations)
        key = (self.robot, bounds.tobytes(), centers.shape, centers.tobytes(), halves.tobytes(),
               kinds.tobytes(), orientations.tobytes())  # fmt: skip
        object.__setattr__(self, "_key", key)

    def _kinds(self, count: int) -> np.ndarray:
        """The validated ``obstacle_kinds`` (all boxes when None)."""
        if self.obstacle_kinds is None:
            return np.zeros(count, dtype=np.int8)
        raw = np.asarray(self.obstacle_kinds)
        if raw.shape != (count,) or raw.dtype.kind not in "iu":
            raise ValueError(
                f"obstacle_kinds: expected {count} integers (0 box, 1 cylinder, 2 sphere), got "
                f"shape {raw.shape} of {raw.dtype}"
            )
        if np.any((raw < 0) | (raw >= len(KIND_NAMES))):
            bad = int(np.argmax((raw < 0) | (raw >= len(KIND_NAMES))))
            raise ValueError(
                f"obstacles[{bad}].type: unknown kind {int(raw[bad])} (0 box, 1 cylinder, 2 sphere)"
            )
        kinds = raw.astype(np.int8)
        if self.workspace_dim == 2 and np.any(kinds == CYLINDER):
            bad = int(np.argmax(kinds == CYLINDER))
            raise ValueError(
                f"obstacles[{bad}].type: a cylinder needs a 3D workspace ({self.robot}'s is 2D; "
                "a disc is a 'sphere')"
            )
        return kinds

    def _orientations(self, count: int, wdim: int) -> np.ndarray:
        """The validated ``obstacle_orientations`` (identity when None)."""
        width = orientation_width(wdim)
        if self.obstacle_orientations is None:
            return identity_orientations(count, wdim)
        orientations = float_array(self.obstacle_orientations, "obstacles: orientation")
        if orientations.shape != (count, width):
            what = "an angle" if width == 1 else "a quaternion [x, y, z, w]"
            raise ValueError(
                f"obstacles: orientation: expected {what} per obstacle, shape ({count}, {width}), "
                f"got {orientations.shape}"
            )
        if width == 4:
            norms = np.linalg.norm(orientations, axis=1)
            bad = np.abs(norms - 1.0) > UNIT_TOLERANCE
            if np.any(bad):
                b = int(np.argmax(bad))
                raise ValueError(
                    f"obstacles[{b}].orientation: a quaternion [x, y, z, w] of unit length is "
                    f"expected, got {orientations[b].tolist()} (length {norms[b]:.6g})"
                )
            orientations = canonical_quaternions(orientations)
        return orientations

    @classmethod
    def from_obstacles(
        cls, robot: str, bounds: np.ndarray, obstacles: Iterable[Obstacle]
    ) -> Workspace:
        """A workspace of `Box`, `Cylinder` and `Sphere` objects (`Workspace.obstacles`).

        Each object is checked as a problem file's entry is: a bad value is refused with a
        one-line `ValueError` naming it (``obstacles[2].radius: ...``).
        """
        from temp_gym.problem.query import obstacle_arrays

        wdim = robot_named(robot).workspace_dim
        if isinstance(obstacles, (Box, Cylinder, Sphere, str, bytes, dict)) or not isinstance(
            obstacles, Iterable
        ):
            raise ValueError(f"obstacles: expected a list of Box, Cylinder or Sphere objects, "
                             f"got {type(obstacles).__name__}")  # fmt: skip
        entries = [obstacle_entry(obstacle, f"obstacles[{i}]")
                   for i, obstacle in enumerate(obstacles)]  # fmt: skip
        centers, halves, kinds, orientations = obstacle_arrays(entries, wdim)
        return cls(robot, bounds, centers, halves, kinds, orientations)

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
        """Number of obstacles."""
        return len(self.obstacle_centers)

    @property
    def axis_aligned(self) -> bool:
        """Whether every obstacle is a box with the identity orientation (version-1 worlds)."""
        return bool(np.all(self.obstacle_kinds == BOX) and np.all(self.unrotated))

    @property
    def unrotated(self) -> np.ndarray:
        """``bool[M]``: which obstacles have exactly the identity orientation."""
        return is_identity(self.obstacle_orientations)

    @property
    def obstacle_rotations(self) -> np.ndarray:
        """Each obstacle's rotation matrix, ``(M, w, w)``: its frame's axes as columns."""
        return self._rotations

    @functools.cached_property
    def obstacle_world_half_extents(self) -> np.ndarray:
        """Half sides of each obstacle's axis-aligned bounding box, ``(M, workspace_dim)``.

        Computed once per workspace (read-only): the corners below and every checker read it.
        """
        extents = world_half_extents(self.obstacle_kinds, self.obstacle_half_extents,
                                     self._rotations)  # fmt: skip
        extents.setflags(write=False)
        return extents

    @property
    def obstacle_lower(self) -> np.ndarray:
        """Lower corners of the obstacles' axis-aligned bounding boxes, (M, workspace_dim).

        For an axis-aligned box, the box itself.
        """
        return self.obstacle_centers - self.obstacle_world_half_extents

    @property
    def obstacle_upper(self) -> np.ndarray:
        """Upper corners of the obstacles' axis-aligned bounding boxes, (M, workspace_dim)."""
        return self.obstacle_centers + self.obstacle_world_half_extents

    @property
    def obstacle_volumes(self) -> np.ndarray:
        """Each obstacle's volume (area in 2D), ``(M,)``."""
        return kind_volumes(self.obstacle_kinds, self.obstacle_half_extents)

    @property
    def obstacles(self) -> list[Obstacle]:
        """The obstacles as `Box`, `Cylinder` and `Sphere` objects."""
        return [
            as_obstacle(int(k), c, h, o)
            for k, c, h, o in zip(
                self.obstacle_kinds,
                self.obstacle_centers,
                self.obstacle_half_extents,
                self.obstacle_orientations,
            )
        ]

    def grown(self, margin: float) -> Workspace:
        """This workspace with every obstacle grown by ``margin`` on every side.

        Every half extent grows: a box's sides, a cylinder's radius and half length, a
        sphere's radius.
        """
        return Workspace(
            self.robot,
            self.bounds,
            self.obstacle_centers,
            self.obstacle_half_extents + margin,
            self.obstacle_kinds,
            self.obstacle_orientations,
        )

    def with_obstacles(self, keep: np.ndarray) -> Workspace:
        """This workspace with only the obstacles ``keep`` selects (a mask or indices)."""
        return Workspace(
            self.robot,
            self.bounds,
            self.obstacle_centers[keep],
            self.obstacle_half_extents[keep],
            self.obstacle_kinds[keep],
            self.obstacle_orientations[keep],
        )
