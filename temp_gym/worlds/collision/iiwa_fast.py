"""Fast, conservative collision checking for the KUKA iiwa 14: boxes and self-collision.

The planners' hot loop. One numba kernel does forward kinematics and tests the sphere model
of `temp_gym.worlds.iiwa14.sphere_fit` (spheres that provably cover each link's solid convex
hull, hence its collision mesh) against the boxes, with early exit, then the link pairs that
the allowed-collision matrix enables against each other (`iiwa_fast_self`). A link's spheres
are only tested against a box when the link's bounding sphere touches it (the broad phase, SIMD
over boxes), and link_0, which never moves, is tested against the boxes once in ``__init__``.
Boxes are closed: touching counts as a collision.

**Speed.** Sines and cosines are computed a block of states at a time by a vectorized
polynomial (`temp_gym.worlds.iiwa14.kinematics.sincos_into`), FK uses 3x4 poses and the URDF's
signed-permutation joint origins (`joint_step_into`), and the kernels take their arrays
unpacked and index them whole: tuple unpacking and row views cost atomic reference counts.
That FK is within `FAST_FK_MARGIN` (10 nm) of the exact one, so every sphere is grown by it.

**Conservative.** Spheres cover the meshes (which the exact checker tests against boxes) and
the padded hulls (which it tests against each other, `iiwa_fast_self` has the proof), so a
state this checker calls free is free for `IiwaExactChecker` too (the tests check it on tens
of thousands of states); the converse fails on a few percent of states, where only a sphere's
bulge touches a box or another link's sphere.

**Self-collision.** Only the pairs enabled by `temp_gym.worlds.iiwa14.acm` are tested (adjacent
pairs and pairs that never come close are not): link_5 - link_7 by a lookup in its joint-space
table before the kinematics, the base against the forearm and wrist sphere against sphere
after the boxes, behind a test of the links' bounding spheres whose world centers the box
broad phase has just computed (`iiwa_fast_self`).

**Invalid states.** A state outside the bounds or the URDF joint limits (bounds wider than the
limits are cut to them), or with a NaN or inf coordinate, is not free (no exception); wrongly
shaped input raises `ValueError`.

**Motion validity (resolution).** An edge is the straight joint-space segment. Rotating joint
``i`` by ``dq_i`` moves any point of link ``j`` by at most ``|dq_i| R[i, j]`` (see
`temp_gym.worlds.iiwa14.kinematics.motion_radii`), so along the edge link ``j`` moves at most
``W_j = sum_i |dq_i| R[i, j]``. The edge is split into ``n = ceil(max_j W_j / resolution)``
equal steps (``resolution`` = 0.02 m of workspace motion by default) and each of the
``n + 1`` states, endpoints included, is checked with link ``j``'s spheres grown by
``W_j / (2 n)``. Every intermediate pose is within half a step of a checked one, so this
certifies the whole motion against the sphere model, thin boxes included, rather than sampling
it; the same grown spheres certify the relative motion of every enabled link pair
(`iiwa_fast_self`). States are checked in bisection order so that blocked edges fail early.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from temp_gym.worlds.collision.compiled import register_motion_kernel
from temp_gym.worlds.collision.iiwa_fast_kernels import (
    _identity_poses,
    colliding_pairs_kernel,
    edges_free_kernel,
    motion_free_kernel,
    states_free_kernel,
)
from temp_gym.worlds.collision.iiwa_fast_self import scratch_for
from temp_gym.worlds.collision.iiwa_inputs import (
    as_bounds,
    as_boxes,
    as_state,
    as_states,
    within_joint_limits,
)
from temp_gym.worlds.iiwa14.acm import enabled_pairs, link_name
from temp_gym.worlds.iiwa14.kinematics import (
    FAST_FK_MARGIN,
    NUM_JOINTS,
    NUM_LINKS,
    load_model,
    motion_radii,
    origin_permutations,
    relative_motion_radii,
)
from temp_gym.worlds.iiwa14.pair_tables import load_pair_tables
from temp_gym.worlds.iiwa14.sphere_fit import load_mesh_radii, load_sphere_model

DEFAULT_RESOLUTION = 0.02
"""Largest workspace displacement (m) of any link point between two checked states."""


def _base_free(box_params: np.ndarray, centers: np.ndarray, radii: np.ndarray) -> bool:
    """Whether link_0, which never moves, misses every box; computed once per checker.

    Boxes its spheres miss are cleared cheaply. The rest (typically a floor slab just below
    the base, which the spheres' bulge reaches) go to fcl on link_0's mesh, the same test the
    exact checker makes, so the two checkers agree on the base exactly.
    """
    # `sphere_hits_box` for every sphere and box at once (the same operations, elementwise).
    gaps = np.maximum(
        np.abs(centers[:, None, :] - box_params[None, :, :3]) - box_params[None, :, 3:], 0.0
    )
    gx, gy, gz = gaps[..., 0], gaps[..., 1], gaps[..., 2]
    hit = gx * gx + gy * gy + gz * gz <= (radii * radii)[:, None]
    suspects = box_params[hit.any(axis=0)]
    if len(suspects) == 0:
        return True
    from temp_gym.worlds.collision.iiwa_exact import base_link_collides

    return not base_link_collides(suspects)


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

    Returns ``(model, kinematics, link_spheres, spheres, motion_radii, self_model)``: the
    kinematic model and its origin permutations, the sphere model per link, the kernel's sphere
    arrays ``(centers, radii, link_start, bound_centers, bound_radii)`` with the radii grown by
    `FAST_FK_MARGIN`, the per-joint motion radii of the meshes, and the self-collision model
    ``(sphere_pairs, table_pairs, table_grid, table_bounds, table_motion)``: the enabled link
    pairs tested sphere against sphere, those with a joint-space table, and how fast each
    tabulated pair's links move relative to each other per radian of each joint
    (`relative_motion_radii`). Callers copy the arrays.
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
    table_pairs, table_grid, table_bounds = load_pair_tables()
    pairs = enabled_pairs()
    tabulated = (pairs[:, None, :] == table_pairs[None, :, :]).all(axis=2).any(axis=1)
    table_motion = relative_motion_radii(mesh_motion, table_pairs)
    self_model = (np.ascontiguousarray(pairs[~tabulated]), table_pairs, table_grid, table_bounds,
                  table_motion)  # fmt: skip
    return model, kinematics, link_spheres, spheres, mesh_motion, self_model


class IiwaSphereChecker:
    """Fast, conservative iiwa checker: sphere-covered links against boxes and each other.

    Args:
        bounds: ``(2, 7)`` joint bounds; states outside them or the URDF joint limits are
            not free.
        box_lower: ``(M, 3)`` lower box corners in the world frame (base at the origin, z up).
        box_upper: ``(M, 3)`` upper box corners.
        resolution: largest workspace motion (m) of any link point between two checked states
            of an edge; checked states use spheres grown by half of it, so edges are certified
            against the sphere model.
        self_collision: test the enabled link pairs against each other. Only switched off to
            measure what self-collision costs (``benchmarks/collision.py``); `make_checker`,
            the planners and the generators always test it.

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
        self_collision: bool = True,
    ) -> None:
        if not (isinstance(resolution, (int, float)) and math.isfinite(resolution)):
            raise ValueError(f"resolution: expected a positive number, got {resolution!r}")
        if resolution <= 0:
            raise ValueError(f"resolution: must be positive, got {resolution}")
        self.dim = NUM_JOINTS
        self.resolution = float(resolution)
        self._bounds = within_joint_limits(as_bounds(bounds))
        self._boxes = as_boxes(box_lower, box_upper)
        model, kinematics, link_spheres, spheres, mesh_motion, self_model = _robot_geometry()
        # Private copies: the cached originals stay as computed whatever a checker does.
        self._kinematics = tuple(array.copy() for array in kinematics)
        self._spheres = tuple(array.copy() for array in spheres)
        self._motion_radii = mesh_motion.copy()
        self._self_model = tuple(
            array.copy() if self_collision else array[:0].copy() for array in self_model
        )
        self._scratch = scratch_for(self._spheres[2])
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
            f"self-collision of {self.num_self_pairs} link pairs, edge resolution "
            f"{self.resolution} m" + ("" if self.base_free else ", base link in collision")
        )

    @property
    def num_self_pairs(self) -> int:
        """Number of link pairs tested for self-collision (spheres and tables)."""
        return len(self._self_model[0]) + len(self._self_model[1])

    @property
    def num_spheres(self) -> int:
        """Number of spheres in the link model (link_0 included)."""
        return len(self._spheres[1])

    def states_free(self, states: np.ndarray, clearance: float = 0.0) -> np.ndarray:
        """Return ``bool[N]``: each state of ``states`` (N x 7) is in bounds and collision-free.

        With ``clearance`` > 0 a state only counts as free when every moving link's spheres,
        grown by that many metres, still miss every box, and the links of every checked pair
        keep that much more than their collision gap between them (the base's spheres are not
        grown: it never moves). ``clearance = resolution / 2`` is what task generators ask of
        a start and a goal: an edge check grows the spheres of its end states, and a pair's
        distance, by up to ``resolution / 2`` (module docstring), so a state closer than that
        to a box, or to itself, is free but no edge of planning length can leave it.

        Raises:
            ValueError: ``clearance`` negative, not finite or above ``resolution / 2`` (the
                broad phase only keeps boxes within that margin of each link).
        """
        if not (isinstance(clearance, (int, float)) and 0 <= clearance <= self.resolution / 2):
            raise ValueError(
                f"clearance: expected a number in [0, resolution / 2 = {self.resolution / 2}], "
                f"got {clearance!r}"
            )
        states = as_states(states)
        if not self.base_free:
            return np.zeros(len(states), dtype=bool)
        return states_free_kernel(states, self._bounds, self._kinematics, self._spheres,
                                  self._boxes, self._self_model, float(clearance),
                                  self._scratch)  # fmt: skip

    def self_collisions(self, state: np.ndarray) -> list[tuple[str, str]]:
        """The link pairs of ``state`` (7,) whose spheres touch, e.g. ``[("link_5", "link_7")]``.

        Empty when the arm is free of self-collision. Tests the same spheres as `states_free`,
        so a state that it rejects for self-collision alone names at least one pair here.
        """
        state = as_state(state, "state")
        spheres_hit, tables_hit = colliding_pairs_kernel(state, self._kinematics, self._spheres,
                                                   self._self_model, self._scratch)  # fmt: skip
        sphere_pairs, table_pairs = self._self_model[:2]
        hits = np.concatenate([sphere_pairs[spheres_hit], table_pairs[tables_hit]])
        return [(link_name(a), link_name(b)) for a, b in sorted(hits.tolist())]

    def compiled_context(self) -> tuple:
        """This checker for `temp_gym.worlds.collision.compiled.motion_free` (compiled loops).

        The same arrays `edges_free` uses, plus private scratch space: one context per loop.
        """
        dim = self.dim
        work = (
            np.empty((1, dim)), np.empty((1, dim)), _identity_poses(dim + 1),
            self._spheres[3].copy(), np.empty(dim + 1), np.empty(len(self._self_model[1])),
            np.empty(dim), np.empty(dim), np.empty(dim),
        )  # fmt: skip
        settings = np.array([1.0 if self.base_free else 0.0, self.resolution])
        context = (settings, self._bounds, self._kinematics, self._spheres, self._boxes,
                   self._self_model, self._motion_radii, scratch_for(self._spheres[2]),
                   work)  # fmt: skip
        register_motion_kernel(context, motion_free_kernel)
        return context

    def edges_free(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """Return ``bool[N]``: whether each joint-space segment ``starts[i] -> ends[i]`` is free."""
        starts = as_states(starts, "starts")
        ends = as_states(ends, "ends")
        if starts.shape != ends.shape:
            try:
                starts, ends = (np.ascontiguousarray(a) for a in np.broadcast_arrays(starts, ends))
            except ValueError:
                raise ValueError(
                    f"starts, ends: shapes {starts.shape} and {ends.shape} do not match"
                ) from None
        if not self.base_free:
            return np.zeros(len(starts), dtype=bool)
        return edges_free_kernel(starts, ends, self._bounds, self._kinematics, self._spheres,
                                 self._boxes, self._self_model, self._motion_radii,
                                 self.resolution, self._scratch)  # fmt: skip

    def edge_free(self, start: np.ndarray, end: np.ndarray) -> bool:
        """Whether the straight joint-space motion ``start -> end`` is free, endpoints included."""
        start = as_state(start, "start")
        end = as_state(end, "end")
        return bool(self.edges_free(start[None], end[None])[0])

    def path_free(self, path: np.ndarray) -> bool:
        """Whether every edge of the polyline ``path`` (K x 7) is free (one state: that state)."""
        path = as_states(path, "path")
        if len(path) == 0:
            raise ValueError("path: expected at least one state")
        if len(path) == 1:
            return bool(self.states_free(path)[0])
        return bool(np.all(self.edges_free(path[:-1], path[1:])))


__all__ = ["DEFAULT_RESOLUTION", "IiwaSphereChecker"]
