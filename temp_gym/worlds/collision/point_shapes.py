"""Exact collision checking for point robots among obstacles of every kind.

`point_checker` picks a workspace's checker: `PointBoxChecker`'s slab test when every
obstacle is an axis-aligned box (the worlds made before there were other kinds, whose results
stay the same to the bit), else `PointShapeChecker`, which tests each obstacle by its kind:

* an axis-aligned box: the same closed slab test on its box;
* a rotated box: the slab test in the box's frame;
* a sphere (a disc in 2D): the distance from its center to the point or segment;
* a cylinder (3D): in its frame, the segment clipped to its length, then the least distance
  from its axis over what is left.

Each is analytic, with no interpolation resolution, and obstacles are closed (touching
collides). Rotated and curved obstacles are tested in their own frame, and the rounding of
that change of frame is answered towards collision
(`temp_gym.worlds.collision.shape_geometry`): a point within about ``1e-12`` of the scene's
size from such a surface counts as touching it.
"""

from __future__ import annotations

import numba
import numpy as np

from temp_gym.problem import Workspace
from temp_gym.problem.obstacles import KIND_NAMES
from temp_gym.worlds.collision.arm_inputs import as_edges, as_path, as_state, as_states
from temp_gym.worlds.collision.compiled import register_motion_kernel
from temp_gym.worlds.collision.point import (
    UNION_SAMPLES,
    PointBoxChecker,
    _finite_rows,
    _segment_hits_box,
)
from temp_gym.worlds.collision.shape_geometry import (
    AXIS_BOX,
    ROTATED_BOX,
    obstacle_arrays,
    point_in_shape,
    segment_meets_shape,
)

PLURALS = {"box": "boxes", "cylinder": "cylinders", "sphere": "spheres"}
"""The kinds' names in the plural, for the description."""
FLOOR_MARGIN = 1e-9
"""Share of the bounds' volume `PointShapeChecker.free_volume_floor` keeps below its sum, as
`PointBoxChecker`'s does, for rounding."""


def point_checker(workspace: Workspace) -> PointBoxChecker | PointShapeChecker:
    """The exact checker of a point robot's workspace (fast and exact alike).

    `PointBoxChecker` when every obstacle is an axis-aligned box, else `PointShapeChecker`.
    """
    if workspace.axis_aligned:
        return PointBoxChecker(workspace.bounds, workspace.obstacle_lower, workspace.obstacle_upper)
    return PointShapeChecker(workspace)


@numba.njit(cache=True, nogil=True)
def _point_free(point, low, high, codes, centers, halves, rotations, lower, upper) -> bool:
    dim = point.shape[0]
    for k in range(dim):
        if point[k] < low[k] or point[k] > high[k]:
            return False
    for b in range(codes.shape[0]):
        inside = True
        for k in range(dim):
            if point[k] < lower[b, k] or point[k] > upper[b, k]:
                inside = False
                break
        if inside and (
            codes[b] == AXIS_BOX or point_in_shape(point, codes, centers, halves, rotations, b)
        ):
            return False
    return True


@numba.njit(cache=True, nogil=True)
def _segment_free(start, end, low, high, codes, centers, halves, rotations, lower, upper) -> bool:
    # The configuration space is a box, so a segment with both ends in bounds stays in bounds.
    for k in range(start.shape[0]):
        if start[k] < low[k] or start[k] > high[k] or end[k] < low[k] or end[k] > high[k]:
            return False
    for b in range(codes.shape[0]):
        if not _segment_hits_box(start, end, lower[b], upper[b]):
            continue
        if codes[b] == AXIS_BOX or segment_meets_shape(
            start, end, codes, centers, halves, rotations, b
        ):
            return False
    return True


@numba.njit(cache=True, nogil=True)
def _context_segment_free(context, start, end) -> bool:
    """`_segment_free` for the compiled context of `PointShapeChecker.compiled_context`."""
    low, high, codes, centers, halves, rotations, lower, upper = context
    return _segment_free(start, end, low, high, codes, centers, halves, rotations, lower, upper)


@numba.njit(cache=True, nogil=True)
def _states_free(states, low, high, codes, centers, halves, rotations, lower, upper):
    out = np.empty(states.shape[0], dtype=np.bool_)
    for i in range(states.shape[0]):
        out[i] = _point_free(states[i], low, high, codes, centers, halves, rotations, lower, upper)
    return out


@numba.njit(cache=True, nogil=True)
def _edges_free(starts, ends, low, high, codes, centers, halves, rotations, lower, upper):
    out = np.empty(starts.shape[0], dtype=np.bool_)
    for i in range(starts.shape[0]):
        out[i] = _segment_free(
            starts[i], ends[i], low, high, codes, centers, halves, rotations, lower, upper
        )
    return out


@numba.njit(cache=True, nogil=True)
def _path_free(path, low, high, codes, centers, halves, rotations, lower, upper) -> bool:
    if path.shape[0] == 1:
        return _point_free(path[0], low, high, codes, centers, halves, rotations, lower, upper)
    for i in range(path.shape[0] - 1):
        if not _segment_free(
            path[i], path[i + 1], low, high, codes, centers, halves, rotations, lower, upper
        ):
            return False
    return True


class PointShapeChecker:
    """Fast *and* exact checker for a point robot among obstacles of every kind.

    Boxes (rotated or not), cylinders and spheres, each by its own test (the module
    docstring); `point_checker` builds it for the workspaces that are not all axis-aligned.

    Args:
        workspace: a point robot's workspace (its configuration is its position).
    """

    def __init__(self, workspace: Workspace) -> None:
        bounds = np.array(workspace.bounds, dtype=np.float64)
        self.dim = bounds.shape[1]
        self._low = bounds[0].copy()
        self._high = bounds[1].copy()
        self._codes, self._centers, self._halves, self._rotations, self._lower, self._upper = (
            obstacle_arrays(workspace)
        )
        self._volumes = np.array(workspace.obstacle_volumes, dtype=np.float64)
        counts = {name: int(np.sum(workspace.obstacle_kinds == kind))
                  for kind, name in enumerate(KIND_NAMES)}  # fmt: skip
        kinds = ", ".join(
            f"{count} {name if count == 1 else PLURALS[name]}"
            for name, count in counts.items()
            if count
        )
        self.description = f"analytic point test, {kinds}"
        self._context: tuple[np.ndarray, ...] | None = None

    def _arrays(self) -> tuple[np.ndarray, ...]:
        return (self._low, self._high, self._codes, self._centers, self._halves,
                self._rotations, self._lower, self._upper)  # fmt: skip

    def free_volume_floor(self) -> float:
        """A lower bound of `free_volume`: the bounds less each obstacle's volume.

        An obstacle counts the smaller of its volume and its bounding box's within the bounds
        (overlaps are subtracted twice), less ``FLOOR_MARGIN`` of the bounds. May be negative.
        """
        low = np.clip(self._lower, self._low, self._high)
        high = np.clip(self._upper, self._low, self._high)
        boxed = np.prod(np.maximum(high - low, 0.0), axis=1)
        total = float(np.prod(self._high - self._low))
        return total - float(np.sum(np.minimum(self._volumes, boxed))) - FLOOR_MARGIN * total

    def free_volume(self) -> float:
        """The volume of the free space, estimated: the bounds less the obstacles.

        The share of `UNION_SAMPLES` seeded uniform samples of the bounds that are free (the
        same number on every call), and never less than `free_volume_floor`, which is a true
        lower bound: so the floor stays below what this returns.
        """
        rng = np.random.default_rng(0)
        samples = rng.uniform(self._low, self._high, size=(UNION_SAMPLES, self.dim))
        free = np.count_nonzero(_states_free(samples, *self._arrays()))
        total = float(np.prod(self._high - self._low))
        return max(float(free / UNION_SAMPLES * total), self.free_volume_floor())

    def compiled_context(self) -> tuple[np.ndarray, ...]:
        """Bounds and obstacles for `temp_gym.worlds.collision.compiled.motion_free` (made once)."""
        if self._context is None:
            context = self._arrays()
            register_motion_kernel(context, _context_segment_free)
            self._context = context
        return self._context

    def collision_reason(self, state: np.ndarray) -> str:
        """Which obstacle a state in bounds lies in, in words (for a refused start or goal)."""
        point = np.ascontiguousarray(state, dtype=np.float64)
        for b in range(len(self._codes)):
            alone = (self._low, self._high, *(a[b : b + 1] for a in self._arrays()[2:]))
            if not _point_free(point, *alone):
                code = int(self._codes[b])
                kind = "box" if code == ROTATED_BOX else KIND_NAMES[code]
                return f"collision with obstacle {b} (a {kind})"
        return "collision"

    def _as_states(self, states: np.ndarray) -> np.ndarray:
        return as_states(states, self.dim)

    def states_free(self, states: np.ndarray) -> np.ndarray:
        """Return ``bool[N]``: each state is inside the bounds and outside every obstacle."""
        states = self._as_states(states)
        return _states_free(states, *self._arrays()) & _finite_rows(states)

    def edge_free(self, start: np.ndarray, end: np.ndarray) -> bool:
        """Whether the closed segment ``start``-``end`` misses every obstacle (exact)."""
        start = as_state(start, "start", self.dim)
        end = as_state(end, "end", self.dim)
        if not (np.all(np.isfinite(start)) and np.all(np.isfinite(end))):
            return False  # NaN passes every comparison: never free
        return bool(_segment_free(start, end, *self._arrays()))

    def edges_free(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """Return ``bool[N]``: `edge_free` for each row pair of ``starts`` and ``ends``."""
        starts, ends = as_edges(starts, ends, self.dim)
        free = _edges_free(starts, ends, *self._arrays())
        return free & _finite_rows(starts) & _finite_rows(ends)

    def path_free(self, path: np.ndarray) -> bool:
        """Whether every segment of the polyline ``path`` (K x d, K >= 1) is free."""
        path = as_path(path, self.dim)
        return bool(_finite_rows(path).all()) and bool(_path_free(path, *self._arrays()))


__all__ = ["PointShapeChecker", "point_checker"]
