"""Fast, conservative collision checking for the KUKA iiwa 14 among axis-aligned boxes.

The planners' hot loop. One numba kernel does forward kinematics and tests the sphere model
of `temp_gym.worlds.robots.sphere_fit` (spheres that provably cover each link's collision
mesh) against the boxes, with early exit. A link's spheres are only tested against a box when
the link's bounding sphere touches it (the broad phase, SIMD over boxes), and link_0, which never
moves, is tested once in ``__init__``. Boxes are closed: touching counts as a collision.

**Speed.** Sines and cosines are computed a block of states at a time by a vectorized
polynomial (`temp_gym.worlds.robots.iiwa14.sincos_into`), FK uses 3x4 poses and the URDF's
signed-permutation joint origins (`joint_step_into`), and the kernels take their arrays
unpacked and index them whole: tuple unpacking and row views cost atomic reference counts.
That FK is within `FAST_FK_MARGIN` (10 nm) of the exact one, so every sphere is grown by it.

**Conservative.** Spheres cover the meshes, so a state this checker calls free is free for
`IiwaExactChecker` too (the tests check it on tens of thousands of states); the converse
fails on a few percent of states, where only a sphere's bulge touches a box.

**Self-collision is not checked, by either checker.** The pybullet model the benchmarks
mirror loads without ``URDF_USE_SELF_COLLISION``, the task definition is about obstacles, and
the joint limits already keep adjacent links apart. A sphere test of non-adjacent pairs would
reject folded but legal poses because sphere bulges overlap near the joints, while the
exact checker would need 21 extra mesh-mesh pairs per state. Leaving it out of both keeps the
guarantee "fast never calls free what exact calls colliding" trivially true for it.

**Invalid states.** A state outside the joint limits, or with a NaN or inf coordinate, is
not free (no exception); wrongly shaped input raises `ValueError`.

**Motion validity (resolution).** An edge is the straight joint-space segment. Rotating joint
``i`` by ``dq_i`` moves any point of link ``j`` by at most ``|dq_i| R[i, j]`` (see
`temp_gym.worlds.robots.iiwa14.motion_radii`), so along the edge link ``j`` moves at most
``W_j = sum_i |dq_i| R[i, j]``. The edge is split into ``n = ceil(max_j W_j / resolution)``
equal steps (``resolution`` = 0.02 m of workspace motion by default) and each of the
``n + 1`` states, endpoints included, is checked with link ``j``'s spheres grown by
``W_j / (2 n)``. Every intermediate pose is within half a step of a checked one, so this
certifies the whole motion against the sphere model, thin boxes included, rather than sampling
it. States are checked in bisection order so that blocked edges fail early.
"""

from __future__ import annotations

import functools
import math

import numba
import numpy as np

from temp_gym.worlds.robots.iiwa14 import (
    FAST_FK_MARGIN,
    NUM_JOINTS,
    NUM_LINKS,
    joint_step_into,
    load_model,
    motion_radii,
    origin_permutations,
    sincos_into,
)
from temp_gym.worlds.robots.sphere_fit import load_mesh_radii, load_sphere_model

DEFAULT_RESOLUTION = 0.02
"""Largest workspace displacement (m) of any link point between two checked states."""


@numba.njit(cache=True, nogil=True, inline="always")
def _sphere_hits_box(x, y, z, radius, box_params, b) -> bool:
    """Closed sphere versus closed box ``box_params[b] = (cx, cy, cz, hx, hy, hz)``."""
    gx = max(abs(x - box_params[b, 0]) - box_params[b, 3], 0.0)
    gy = max(abs(y - box_params[b, 1]) - box_params[b, 4], 0.0)
    gz = max(abs(z - box_params[b, 2]) - box_params[b, 5], 0.0)
    return gx * gx + gy * gy + gz * gz <= radius * radius


@numba.njit(cache=True, nogil=True, inline="always")
def _in_bounds(states, i, bounds) -> bool:
    """Whether ``states[i]`` is within ``bounds`` (indexed whole: row views cost refcounts)."""
    for k in range(states.shape[1]):
        # Written so that NaN fails the test.
        if not (states[i, k] >= bounds[0, k] and states[i, k] <= bounds[1, k]):
            return False
    return True


@numba.njit(cache=True, nogil=True)
def _pose_free(sines, cosines, base, perm, sign, shift, centers, radii, link_start,
               bound_centers, bound_radii, box_params, link_boxes, link_box_count, link_lower,
               link_upper, inflation, poses) -> bool:  # fmt: skip
    """Whether the moving links' spheres (grown by ``inflation[j]``) miss every box.

    ``sines[base + i]``, ``cosines[base + i]`` are joint ``i``'s; ``poses`` (8, 3, 4) is
    scratch whose first entry is the identity. Arrays come unpacked and are indexed whole,
    never sliced: tuple unpacking and views cost atomic reference counting per call.
    """
    for j in range(perm.shape[0]):
        joint_step_into(poses, j, perm, sign, shift, cosines[base + j], sines[base + j])
    # Distal links first: they sweep the most space, so collisions are found sooner.
    for j in range(poses.shape[0] - 1, 0, -1):
        count = link_box_count[j]
        grow = inflation[j]
        c0, c1, c2 = bound_centers[j, 0], bound_centers[j, 1], bound_centers[j, 2]
        bx = poses[j, 0, 0] * c0 + poses[j, 0, 1] * c1 + poses[j, 0, 2] * c2 + poses[j, 0, 3]
        by = poses[j, 1, 0] * c0 + poses[j, 1, 1] * c1 + poses[j, 1, 2] * c2 + poses[j, 1, 3]
        bz = poses[j, 2, 0] * c0 + poses[j, 2, 1] * c1 + poses[j, 2, 2] * c2 + poses[j, 2, 3]
        bound = bound_radii[j] + grow
        # Broad phase, branch-free so that LLVM makes it SIMD over the link's candidates.
        hits = 0
        for n in range(count):
            gx = max(max(link_lower[j, 0, n] - bx, bx - link_upper[j, 0, n]), 0.0)
            gy = max(max(link_lower[j, 1, n] - by, by - link_upper[j, 1, n]), 0.0)
            gz = max(max(link_lower[j, 2, n] - bz, bz - link_upper[j, 2, n]), 0.0)
            hits += gx * gx + gy * gy + gz * gz <= bound * bound
        if hits == 0:
            continue
        for n in range(count):
            b = link_boxes[j, n]
            if not _sphere_hits_box(bx, by, bz, bound, box_params, b):
                continue
            for k in range(link_start[j], link_start[j + 1]):
                c0, c1, c2 = centers[k, 0], centers[k, 1], centers[k, 2]
                x = poses[j, 0, 0] * c0 + poses[j, 0, 1] * c1 + poses[j, 0, 2] * c2 + poses[j, 0, 3]
                y = poses[j, 1, 0] * c0 + poses[j, 1, 1] * c1 + poses[j, 1, 2] * c2 + poses[j, 1, 3]
                z = poses[j, 2, 0] * c0 + poses[j, 2, 1] * c1 + poses[j, 2, 2] * c2 + poses[j, 2, 3]
                if _sphere_hits_box(x, y, z, radii[k] + grow, box_params, b):
                    return False
    return True


@numba.njit(cache=True, nogil=True)
def _identity_poses(count):
    poses = np.zeros((count, 3, 4))
    for r in range(3):
        poses[0, r, r] = 1.0
    return poses


_BLOCK = 256
"""States per block: sines and cosines are computed a block at a time, vectorized."""


@numba.njit(cache=True, nogil=True)
def _states_free(states, bounds, kinematics, spheres, boxes, clearance):
    perm, sign, shift = kinematics
    centers, radii, link_start, bound_centers, bound_radii = spheres
    box_params, link_boxes, link_box_count, link_lower, link_upper = boxes
    num, dim = states.shape
    out = np.zeros(num, dtype=np.bool_)
    poses = _identity_poses(dim + 1)
    inflation = np.full(dim + 1, clearance)
    flat = states.reshape(-1)
    sines = np.empty(_BLOCK * dim)
    cosines = np.empty(_BLOCK * dim)
    for first in range(0, num, _BLOCK):
        last = min(first + _BLOCK, num)
        sincos_into(flat[first * dim : last * dim], sines, cosines)
        for i in range(first, last):
            if _in_bounds(states, i, bounds):
                out[i] = _pose_free(sines, cosines, (i - first) * dim, perm, sign, shift,
                                    centers, radii, link_start, bound_centers, bound_radii,
                                    box_params, link_boxes, link_box_count, link_lower,
                                    link_upper, inflation, poses)  # fmt: skip
    return out


@numba.njit(cache=True, nogil=True)
def _edge_free(starts, ends, e, bounds, perm, sign, shift, centers, radii, link_start,
               bound_centers, bound_radii, box_params, link_boxes, link_box_count, link_lower,
               link_upper, motion, resolution, poses, inflation, q, sines,
               cosines) -> bool:  # fmt: skip
    """Whether edge ``starts[e] -> ends[e]`` is free (arrays unpacked, as in `_pose_free`)."""
    # The configuration space is a box: a segment with both ends in bounds stays in bounds.
    if not (_in_bounds(starts, e, bounds) and _in_bounds(ends, e, bounds)):
        return False
    dim = starts.shape[1]
    worst = 0.0
    for j in range(inflation.shape[0]):
        sweep = 0.0
        for i in range(dim):
            sweep += abs(ends[e, i] - starts[e, i]) * motion[i, j]
        inflation[j] = sweep
        worst = max(worst, sweep)
    steps = max(1, int(math.ceil(worst / resolution)))
    for j in range(inflation.shape[0]):
        inflation[j] /= 2.0 * steps
    # Endpoints first, then bisection order: k = stride * odd visits each 0 < k < steps once.
    order = np.empty(steps + 1, dtype=np.int64)
    order[0], order[1] = 0, steps
    count = 2
    stride = 1
    while stride < steps:
        stride *= 2
    stride //= 2
    while stride >= 1:
        for k in range(stride, steps, 2 * stride):
            order[count] = k
            count += 1
        stride //= 2
    for k in order:
        t = k / steps
        for i in range(dim):
            q[i] = starts[e, i] + t * (ends[e, i] - starts[e, i])
        sincos_into(q, sines, cosines)
        if not _pose_free(sines, cosines, 0, perm, sign, shift, centers, radii, link_start,
                          bound_centers, bound_radii, box_params, link_boxes, link_box_count,
                          link_lower, link_upper, inflation, poses):  # fmt: skip
            return False
    return True


@numba.njit(cache=True, nogil=True)
def _edges_free(starts, ends, bounds, kinematics, spheres, boxes, motion, resolution):
    perm, sign, shift = kinematics
    centers, radii, link_start, bound_centers, bound_radii = spheres
    box_params, link_boxes, link_box_count, link_lower, link_upper = boxes
    dim = starts.shape[1]
    poses = _identity_poses(dim + 1)
    inflation = np.empty(dim + 1)
    q, sines, cosines = np.empty(dim), np.empty(dim), np.empty(dim)
    out = np.empty(starts.shape[0], dtype=np.bool_)
    for e in range(starts.shape[0]):
        out[e] = _edge_free(starts, ends, e, bounds, perm, sign, shift, centers, radii,
                            link_start, bound_centers, bound_radii, box_params, link_boxes,
                            link_box_count, link_lower, link_upper, motion, resolution, poses,
                            inflation, q, sines, cosines)  # fmt: skip
    return out


def _as_boxes(box_lower: np.ndarray, box_upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Validated ``(M, 3)`` float64 box corners."""
    lower = np.ascontiguousarray(box_lower, dtype=np.float64)
    upper = np.ascontiguousarray(box_upper, dtype=np.float64)
    if lower.size == 0 and upper.size == 0:
        return np.zeros((0, 3)), np.zeros((0, 3))
    if lower.ndim != 2 or lower.shape[1] != 3 or lower.shape != upper.shape:
        raise ValueError(
            f"box_lower, box_upper: expected two (M, 3) arrays, got {lower.shape}, {upper.shape}"
        )
    if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
        raise ValueError("box_lower, box_upper: contain NaN or inf")
    if np.any(lower > upper):
        raise ValueError("box_lower, box_upper: a lower corner is above its upper corner")
    return lower, upper


def _as_bounds(bounds: np.ndarray) -> np.ndarray:
    bounds = np.ascontiguousarray(bounds, dtype=np.float64)
    if bounds.shape != (2, NUM_JOINTS):
        raise ValueError(f"bounds: expected shape (2, {NUM_JOINTS}), got {bounds.shape}")
    if not np.all(np.isfinite(bounds)) or np.any(bounds[0] > bounds[1]):
        raise ValueError("bounds: must be finite with lower <= upper")
    return bounds


def _as_states(states: np.ndarray, name: str = "states") -> np.ndarray:
    states = np.ascontiguousarray(states, dtype=np.float64)
    if states.ndim == 1:
        states = states.reshape(1, -1)
    if states.ndim != 2 or states.shape[1] != NUM_JOINTS:
        raise ValueError(f"{name}: expected shape (N, {NUM_JOINTS}), got {states.shape}")
    return states


def _as_state(state: np.ndarray, name: str) -> np.ndarray:
    state = np.ascontiguousarray(state, dtype=np.float64)
    if state.shape != (NUM_JOINTS,):
        raise ValueError(f"{name}: expected shape ({NUM_JOINTS},), got {state.shape}")
    return state


def _base_free(box_params: np.ndarray, centers: np.ndarray, radii: np.ndarray) -> bool:
    """Whether link_0, which never moves, misses every box; computed once per checker.

    Boxes its spheres miss are cleared cheaply. The rest (typically a floor slab just below
    the base, which the spheres' bulge reaches) go to fcl on link_0's mesh, the same test the
    exact checker makes, so the two checkers agree on the base exactly.
    """
    suspects = [
        box_params[b]
        for b in range(len(box_params))
        if any(_sphere_hits_box(*c, r, box_params, b) for c, r in zip(centers, radii))
    ]
    if not suspects:
        return True
    from temp_gym.worlds.collision.iiwa_exact import base_link_collides

    return not base_link_collides(np.array(suspects))


def _bounding_center(centers: np.ndarray, radii: np.ndarray, iterations: int = 300) -> np.ndarray:
    """A center for a small ball enclosing the given spheres (Badoiu-Clarkson iterations).

    Any center is valid (the radius is computed from it); this one just keeps it small.
    """
    center = centers.mean(axis=0)
    for step in range(1, iterations + 1):
        reach = np.linalg.norm(centers - center, axis=1) + radii
        far = int(np.argmax(reach))
        direction = centers[far] - center
        length = np.linalg.norm(direction)
        point = centers[far] + (direction / length * radii[far] if length > 0 else 0.0)
        center = center + (point - center) / (step + 1)
    return center


@functools.lru_cache(maxsize=1)
def _robot_geometry():
    """The robot's part of a checker, computed once per process (~40 ms, mostly the bounds).

    Returns ``(model, kinematics, link_spheres, spheres, motion_radii)``: the kinematic model
    and its origin permutations, the sphere model per link, the kernel's sphere arrays
    ``(centers, radii, link_start, bound_centers, bound_radii)`` with the radii grown by
    `FAST_FK_MARGIN`, and the per-joint motion radii of the meshes. Callers copy the arrays.
    """
    model = load_model()
    kinematics = origin_permutations(model.joint_origins)
    link_spheres = load_sphere_model()
    if len(link_spheres) != NUM_LINKS:
        raise ValueError(f"sphere model: expected {NUM_LINKS} links, got {len(link_spheres)}")
    centers = np.concatenate([c for c, _ in link_spheres])
    radii = np.concatenate([r for _, r in link_spheres])
    link_start = np.cumsum([0] + [len(r) for _, r in link_spheres]).astype(np.int64)
    bound_centers = np.array([_bounding_center(c, r) for c, r in link_spheres])
    bound_radii = np.array(
        [np.max(np.linalg.norm(c - m, axis=1) + r)
         for (c, r), m in zip(link_spheres, bound_centers)]
    )  # fmt: skip
    # The kernel's FK is within FAST_FK_MARGIN of the exact one: grow the spheres by it.
    spheres = (centers, radii + FAST_FK_MARGIN, link_start, bound_centers,
               bound_radii + FAST_FK_MARGIN)  # fmt: skip
    mesh_motion = np.ascontiguousarray(motion_radii(load_mesh_radii()))
    return model, kinematics, link_spheres, spheres, mesh_motion


class IiwaSphereChecker:
    """Fast, conservative iiwa checker: sphere-covered links against axis-aligned boxes.

    Args:
        bounds: ``(2, 7)`` joint limits; states outside are not free.
        box_lower: ``(M, 3)`` lower box corners in the world frame (base at the origin, z up).
        box_upper: ``(M, 3)`` upper box corners.
        resolution: largest workspace motion (m) of any link point between two checked states
            of an edge; checked states use spheres grown by half of it, so edges are certified
            against the sphere model.

    Example:
        >>> checker = IiwaSphereChecker(joint_limits(), [[0.5, -1, 0]], [[0.6, 1, 1]])
        >>> checker.states_free(np.zeros((1, 7)))
        array([ True])
    """

    def __init__(
        self,
        bounds: np.ndarray,
        box_lower: np.ndarray,
        box_upper: np.ndarray,
        resolution: float = DEFAULT_RESOLUTION,
    ) -> None:
        if not (isinstance(resolution, (int, float)) and math.isfinite(resolution)):
            raise ValueError(f"resolution: expected a positive number, got {resolution!r}")
        if resolution <= 0:
            raise ValueError(f"resolution: must be positive, got {resolution}")
        self.dim = NUM_JOINTS
        self.resolution = float(resolution)
        self._bounds = _as_bounds(bounds)
        self._boxes = _as_boxes(box_lower, box_upper)
        model, kinematics, link_spheres, spheres, mesh_motion = _robot_geometry()
        # Private copies: the cached originals stay as computed whatever a checker does.
        self._kinematics = tuple(array.copy() for array in kinematics)
        self._spheres = tuple(array.copy() for array in spheres)
        self._motion_radii = mesh_motion.copy()
        lower, upper = self._boxes
        box_params = np.ascontiguousarray(np.hstack([(lower + upper) / 2, (upper - lower) / 2]))
        self.base_free = _base_free(box_params, *link_spheres[0])
        # Per-link candidate boxes. Link_1's origin never moves, and link j's spheres stay
        # within reach[j] of it (triangle inequality along the chain); edge checks grow the
        # spheres by at most resolution / 2.
        anchor = model.joint_origins[0, :3, 3]
        offsets = np.linalg.norm(model.joint_origins[1:, :3, 3], axis=1)
        link_boxes = np.zeros((NUM_LINKS, max(len(box_params), 1)), dtype=np.int64)
        link_box_count = np.zeros(NUM_LINKS, dtype=np.int64)
        gaps = np.linalg.norm(np.maximum(np.abs(anchor - box_params[:, :3]) - box_params[:, 3:],
                                         0.0), axis=1)  # fmt: skip
        for j in range(1, NUM_LINKS):
            link_centers, link_radii = link_spheres[j]
            reach = offsets[: j - 1].sum() + np.max(
                np.linalg.norm(link_centers, axis=1) + link_radii
            )
            near = np.flatnonzero(gaps <= reach + self.resolution / 2 + 1e-9)
            link_boxes[j, : len(near)] = near
            link_box_count[j] = len(near)
        # The same candidates' corners, per link and axis, for the SIMD broad phase.
        link_lower = np.zeros((NUM_LINKS, 3, link_boxes.shape[1]))
        link_upper = np.zeros((NUM_LINKS, 3, link_boxes.shape[1]))
        for j in range(NUM_LINKS):
            near = link_boxes[j, : link_box_count[j]]
            link_lower[j, :, : len(near)] = lower[near].T
            link_upper[j, :, : len(near)] = upper[near].T
        self._boxes = (box_params, link_boxes, link_box_count, link_lower, link_upper)
        self._num_boxes = len(box_params)
        self.description = (
            f"iiwa sphere model ({self.num_spheres} spheres), {self._num_boxes} boxes, "
            f"edge resolution {self.resolution} m"
            + ("" if self.base_free else ", base link in collision")
        )

    @property
    def num_spheres(self) -> int:
        """Number of spheres in the link model (link_0 included)."""
        return len(self._spheres[1])

    def states_free(self, states: np.ndarray, clearance: float = 0.0) -> np.ndarray:
        """Return ``bool[N]``: each state of ``states`` (N x 7) is in bounds and collision-free.

        With ``clearance`` > 0 a state only counts as free when every sphere, grown by that
        many metres, still misses every box. ``clearance = resolution / 2`` is what task
        generators ask of a start and a goal: an edge check grows the spheres of its end
        states by up to ``resolution / 2`` (module docstring), so a state closer to a box than
        that is free but no edge of planning length can leave it.

        Raises:
            ValueError: ``clearance`` negative, not finite or above ``resolution / 2`` (the
                broad phase only keeps boxes within that margin of each link).
        """
        if not (isinstance(clearance, (int, float)) and 0 <= clearance <= self.resolution / 2):
            raise ValueError(
                f"clearance: expected a number in [0, resolution / 2 = {self.resolution / 2}], "
                f"got {clearance!r}"
            )
        states = _as_states(states)
        if not self.base_free:
            return np.zeros(len(states), dtype=bool)
        return _states_free(states, self._bounds, self._kinematics, self._spheres, self._boxes,
                            float(clearance))  # fmt: skip

    def edges_free(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """Return ``bool[N]``: whether each joint-space segment ``starts[i] -> ends[i]`` is free."""
        starts = _as_states(starts, "starts")
        ends = _as_states(ends, "ends")
        if starts.shape != ends.shape:
            try:
                starts, ends = (np.ascontiguousarray(a) for a in np.broadcast_arrays(starts, ends))
            except ValueError:
                raise ValueError(
                    f"starts, ends: shapes {starts.shape} and {ends.shape} do not match"
                ) from None
        if not self.base_free:
            return np.zeros(len(starts), dtype=bool)
        return _edges_free(starts, ends, self._bounds, self._kinematics, self._spheres, self._boxes,
                           self._motion_radii, self.resolution)  # fmt: skip

    def edge_free(self, start: np.ndarray, end: np.ndarray) -> bool:
        """Whether the straight joint-space motion ``start -> end`` is free, endpoints included."""
        start = _as_state(start, "start")
        end = _as_state(end, "end")
        return bool(self.edges_free(start[None], end[None])[0])

    def path_free(self, path: np.ndarray) -> bool:
        """Whether every edge of the polyline ``path`` (K x 7) is free (one state: that state)."""
        path = _as_states(path, "path")
        if len(path) == 0:
            raise ValueError("path: expected at least one state")
        if len(path) == 1:
            return bool(self.states_free(path)[0])
        return bool(np.all(self.edges_free(path[:-1], path[1:])))


__all__ = ["DEFAULT_RESOLUTION", "IiwaSphereChecker"]
