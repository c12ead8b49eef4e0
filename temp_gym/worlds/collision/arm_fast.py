"""Fast, conservative collision checking for any arm: obstacles and self-collision.

The planners' hot loop. One numba kernel does forward kinematics and walks each body's tree of
covering spheres (`temp_gym.worlds.arm.sphere_tree`) against the obstacles, with early exit,
then the body pairs that the allowed-collision matrix enables against each other
(`arm_fast_self`). A body's tree is only walked for an obstacle its root sphere touches (the
broad phase, SIMD over the obstacles' world bounding boxes), and the base, which never moves,
is tested against the obstacles once in ``__init__``, by the exact checker's own test.
Obstacles are closed: touching counts.

**Obstacle kinds** (`arm_fast_obstacles`). Each body lists the obstacles it can reach,
axis-aligned boxes first, tested as they always were; then oriented boxes, cylinders and
spheres, tested in each obstacle's frame. A world of axis-aligned boxes only runs the same
arithmetic, and gets the same verdicts, as before obstacles had kinds.

**Conservative, and close.** The leaves cover each convex piece of each body, bulging out of it
by at most about the robot's sphere tolerance (`temp_gym.worlds.arm.spheres`), so a state this
checker calls free is free for `ArmExactChecker` too. Within that bulge of a surface the
spheres cannot tell, and the body's convex pieces decide by a separating plane
(`arm_fast_hulls`): the converse then fails only where a piece's hull covers a hollow of its
link, or against self-collision's tables. A state the exact checker calls free but this one
does not is named by `collision_reasons` as the fast model's verdict.

**Invalid states.** A state outside the bounds or the joint limits (bounds wider than the
limits are cut to them), or with a NaN or inf coordinate, is not free (no exception); wrongly
shaped input raises `ValueError`.

**Motion validity (resolution), adaptive near surfaces.** An edge is the straight joint-space
segment. Moving joint ``i`` by ``dq_i`` moves any point of body ``j`` by at most
``|dq_i| L[i, j]``, where the lever arm ``L[i, j]`` bounds how far the point gets from the
joint's axis along this edge: the distances measured at the two ends, plus what the joints in
between can add (`temp_gym.worlds.arm.kinematics.segment_levers_into`), and never more than
the arm's bound over all configurations (`ArmModel.motion_radii`). So along the edge body
``j`` moves at most
``W_j = sum_i |dq_i| L[i, j]``. The edge is cut into ``n = ceil(max_j W_j / resolution)``
intervals. The last and the first are checked first (an edge whose new end collides is refused
at once), then the ones between in chunks of up to `COARSE_INTERVALS`. An interval of
half-width ``h`` (in the edge's parameter) is certified by the state at its middle with body
``j``'s spheres grown by ``W_j h`` against obstacles: every pose of the interval is within that
of the checked one. (A chunk grows them past half the resolution, the margin of each body's
obstacle list beyond the body's reach: an obstacle the list leaves out is beyond the body at
every pose, so the certificate needs it no more than before.) An interval whose grown check
fails while its middle state is free is split in two, and so on until the growth is below
`GROWTH_FLOOR`: an
edge that runs a few millimetres from a surface is certified with small steps there and large
ones elsewhere, so a start or goal near a surface can be left and reached. A body pair is
certified by its relative motion instead, which only the joints between its two bodies make
(`arm_fast_self`): a sweep of the shoulder moves the forearm and the hand as one.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from temp_gym.worlds.arm.kinematics import FAST_FK_MARGIN
from temp_gym.worlds.arm.model import ArmModel
from temp_gym.worlds.arm.pair_tables import table_arrays
from temp_gym.worlds.arm.sphere_tree import SphereTrees, build_trees
from temp_gym.worlds.collision.arm_fast_fields import body_fields
from temp_gym.worlds.collision.arm_fast_hulls import hull_arrays
from temp_gym.worlds.collision.arm_fast_kernels import (
    GROWTH_FLOOR,
    _edge_work,
    colliding_pairs_kernel,
    edges_free_kernel,
    motion_free_kernel,
    states_free_kernel,
)
from temp_gym.worlds.collision.arm_fast_obstacles import obstacle_tables
from temp_gym.worlds.collision.arm_fast_self import scratch_for
from temp_gym.worlds.collision.arm_inputs import (
    as_bounds,
    as_edges,
    as_path,
    as_state,
    as_states,
    within_limits,
)
from temp_gym.worlds.collision.arm_obstacles import ArmObstacles, resolve_obstacles
from temp_gym.worlds.collision.compiled import register_motion_kernel

DEFAULT_RESOLUTION = 0.02
"""Largest workspace displacement (m) of any body point between two checked states, before
any interval is split."""


INNER_BALLS = 8
"""Inner balls kept per body: the largest balls around leaf centers that its pieces hold."""


def _inner_balls(arm: ArmModel, body: int, centers: np.ndarray) -> tuple[np.ndarray, ...]:
    """Up to `INNER_BALLS` balls inside body ``body``'s pieces, centred on leaf centers.

    An obstacle that touches one touches the body, so a deep collision is found without a tree walk.
    Each is shrunk by `FAST_FK_MARGIN`, so the fast kinematics keeps it inside.
    """
    from temp_gym.worlds.arm.spheres import depth, hull_planes

    if len(centers) == 0:
        return np.zeros((0, 3)), np.zeros(0)
    inside = np.zeros(len(centers))
    for piece in arm.geometry[body].pieces:
        inside = np.maximum(inside, depth(centers, hull_planes(piece)[2]))
    chosen: list[int] = []
    for k in np.argsort(-inside, kind="stable"):
        if inside[k] <= 2 * FAST_FK_MARGIN or len(chosen) == INNER_BALLS:
            break
        if all(np.linalg.norm(centers[k] - centers[m]) > 0.5 * inside[m] for m in chosen):
            chosen.append(int(k))
    return centers[chosen], inside[chosen] - FAST_FK_MARGIN


def sphere_trees(arm: ArmModel) -> SphereTrees:
    """The arm's sphere trees from its derived data, with each body's inner balls (cached).

    The trees are grown by `FAST_FK_MARGIN`.
    """
    key = "sphere_trees"
    if key not in arm._arrays:
        bodies = [(np.array(b["centers"], dtype=np.float64).reshape(-1, 3),
                   np.array(b["radii"], dtype=np.float64))
                  for b in arm.derived_data()["spheres"]["bodies"]]  # fmt: skip
        inner = [_inner_balls(arm, j, centers) for j, (centers, _) in enumerate(bodies)]
        trees = dataclasses.replace(
            build_trees(bodies).grown(FAST_FK_MARGIN),
            inner_centers=np.concatenate([c for c, _ in inner]).reshape(-1, 3),
            inner_radii=np.concatenate([r for _, r in inner]),
            inner_start=np.cumsum([0] + [len(r) for _, r in inner]).astype(np.int64),
        )
        for name in vars(trees):  # shared by every checker of the arm: nobody may write them
            value = getattr(trees, name)
            if isinstance(value, np.ndarray):
                value.setflags(write=False)
        arm._arrays[key] = trees
    return arm._arrays[key]


def _self_model(arm: ArmModel) -> tuple[np.ndarray, ...]:
    """``(sphere_pairs, table_grid, table_bounds, table_motion, table_pairs)`` (cached)."""
    key = "fast_self_model"
    if key not in arm._arrays:
        table_pairs, grid, bounds = table_arrays(arm.derived_data()["pair_tables"])
        pairs = arm.enabled_pairs()
        tabulated = (pairs[:, None, :] == table_pairs[None, :, :]).all(axis=2).any(axis=1)
        motion = arm.relative_motion_radii(table_pairs)
        arrays = (np.ascontiguousarray(pairs[~tabulated]), grid, bounds,
                  np.ascontiguousarray(motion), table_pairs)  # fmt: skip
        for array in arrays:
            array.setflags(write=False)
        arm._arrays[key] = arrays
    return arm._arrays[key]


def _self_fields(arm: ArmModel, enabled: bool) -> tuple[np.ndarray, np.ndarray]:
    """``(values, layout)``: the bodies' distance fields (`arm_fast_fields`; cached).

    Fields of the bodies that come first in a sphere pair; when not ``enabled``, none.
    """
    key = "fast_self_fields" if enabled else "fast_self_no_fields"
    if key not in arm._arrays:
        trees = sphere_trees(arm)
        if enabled:
            arrays = body_fields(trees, _self_model(arm)[0][:, 0])
        else:
            arrays = (np.zeros(0, dtype=np.float32), np.full((len(trees.body_start) - 1, 6), -1.0))
        for array in arrays:
            array.setflags(write=False)
        arm._arrays[key] = arrays
    return arm._arrays[key]


def _body_reaches(arm: ArmModel) -> tuple[np.ndarray, np.ndarray]:
    """The first joint's origin (which never moves) and how far from it each body reaches.

    A body's reach is the joint offsets before it, its prismatic joints' longest slides and its
    root sphere's farthest point; -inf for a body without spheres (the base, one never checked).
    Depends on the arm alone: cached on it, since a checker is built for every plan.
    """
    key = "body_reaches"
    if key not in arm._arrays:
        trees = sphere_trees(arm)
        anchor = arm.chain.joint_origins[0, :3, 3].copy()
        shift = arm.chain.joint_origins[:, :3, 3]
        slides = np.where(arm.chain.joint_types == 1, np.abs(arm.chain.joint_limits).max(axis=0),
                          0.0)  # fmt: skip
        reaches = np.full(arm.num_bodies, -np.inf)
        for j in range(1, arm.num_bodies):
            root = trees.body_start[j]
            if root == trees.body_start[j + 1]:
                continue
            extent = float(np.linalg.norm(trees.node_centers[root]) + trees.node_radii[root])
            reaches[j] = (float(np.linalg.norm(shift[1:j], axis=1).sum())
                          + float(slides[:j].sum()) + extent)  # fmt: skip
        for array in (anchor, reaches):
            array.setflags(write=False)
        arm._arrays[key] = (anchor, reaches)
    return arm._arrays[key]


class ArmSphereChecker:
    """Fast, conservative arm checker: sphere trees against obstacles and each other.

    Args:
        arm: the arm (`temp_gym.worlds.arm.load_arm`).
        bounds: ``(2, dim)`` joint bounds; states outside them or the joint limits are not
            free.
        box_lower: ``(M, 3)`` lower corners of axis-aligned boxes in the world frame (base at
            the origin, z up); or None with ``obstacles``.
        box_upper: ``(M, 3)`` upper box corners.
        resolution: largest workspace motion (m) of any body point between two checked states
            of an edge before intervals are split (module docstring).
        self_collision: test the enabled body pairs against each other. Only switched off to
            measure what self-collision costs; planners and generators always test it.
        distance_fields: walk close body pairs against distance fields (`arm_fast_fields`).
            The verdicts are the same either way; only switched off to measure the speed-up
            and to test that sameness.
        near_surfaces: decide a body whose leaves touch an obstacle only within their bulge
            by its convex pieces (`arm_fast_hulls`), so a link a millimetre from a surface is
            free. Switched off, the spheres alone decide (more refusals, never fewer); only
            to measure what it changes.
        obstacles: obstacles of every kind (`arm_obstacles` of a workspace), instead of
            ``box_lower`` and ``box_upper``.
    """

    def __init__(
        self,
        arm: ArmModel,
        bounds: np.ndarray,
        box_lower: np.ndarray | None = None,
        box_upper: np.ndarray | None = None,
        resolution: float = DEFAULT_RESOLUTION,
        self_collision: bool = True,
        *,
        obstacles: ArmObstacles | None = None,
        distance_fields: bool = True,
        near_surfaces: bool = True,
    ) -> None:
        if not (isinstance(resolution, (int, float)) and math.isfinite(resolution)):
            raise ValueError(f"resolution: expected a positive number, got {resolution!r}")
        if resolution <= 0:
            raise ValueError(f"resolution: must be positive, got {resolution}")
        self.arm = arm
        self.dim = arm.dim
        self.resolution = float(resolution)
        self._bounds = within_limits(as_bounds(bounds, arm.dim), arm.joint_limits())
        obstacles = resolve_obstacles(box_lower, box_upper, obstacles)
        self.obstacles = obstacles
        """The obstacles checked (`ArmObstacles`)."""
        trees = sphere_trees(arm)
        self._trees = trees.arrays()
        self._kinematics = arm.kinematic_arrays()
        self._motion_radii = arm.motion_radii()
        self_model = _self_model(arm)
        self._table_pairs = self_model[4]
        self._self_model = tuple(array if self_collision else array[:0] for array in (
            *self_model[:4], *_self_fields(arm, distance_fields)))  # fmt: skip
        self._scratch = scratch_for(trees)
        from temp_gym.worlds.collision.arm_exact import base_collides

        self.base_free = not base_collides(arm, obstacles)
        self._obstacle_arrays = (obstacle_tables(obstacles), *self._candidates(obstacles),
                                 hull_arrays(arm, near_surfaces))  # fmt: skip
        self.description = (
            f"{arm.name} sphere model ({len(trees.radii)} spheres), {obstacles.summary()}, "
            f"self-collision of {self.num_self_pairs} body pairs, edge resolution "
            f"{self.resolution} m" + ("" if self.base_free else ", base link in collision")
        )

    def _candidates(self, obstacles: ArmObstacles) -> tuple[np.ndarray, ...]:
        """Per body, the obstacles it can reach: ``(lists, counts, lowers, uppers)``.

        Those whose world bounding box is within the body's reach of the first joint's origin
        (which never moves), plus half the resolution (the most clearance a state check grows
        it by; no pose of the body reaches the others, however an edge check grows it). A
        body's list holds ``counts[j, 0]`` rows of the box table, then ``counts[j, 1]`` rows of
        the other obstacles' table (`obstacle_tables`).
        """
        anchor, reaches = _body_reaches(self.arm)
        bodies = len(reaches)
        lower, upper = obstacles.lower, obstacles.upper
        center, half = (lower + upper) / 2, (upper - lower) / 2
        gaps = np.linalg.norm(np.maximum(np.abs(anchor - center) - half, 0.0), axis=1)
        body_lists = np.zeros((bodies, max(len(center), 1)), dtype=np.int64)
        counts = np.zeros((bodies, 2), dtype=np.int64)
        body_lower = np.zeros((bodies, 3, body_lists.shape[1]))
        body_upper = np.zeros((bodies, 3, body_lists.shape[1]))
        aligned = obstacles.axis_aligned
        # Each obstacle's row in its own table; a body lists the boxes first, then the others.
        rank = np.where(aligned, np.cumsum(aligned) - 1, np.cumsum(~aligned) - 1)
        order = np.concatenate([np.flatnonzero(aligned), np.flatnonzero(~aligned)])
        near = gaps[order] <= reaches[:, None] + self.resolution / 2 + 1e-9  # (bodies, M)
        counts[:, 0] = near[:, : int(aligned.sum())].sum(axis=1)
        counts[:, 1] = near.sum(axis=1) - counts[:, 0]
        for j in np.flatnonzero(counts.sum(axis=1)):
            chosen = order[near[j]]
            body_lists[j, : len(chosen)] = rank[chosen]
            body_lower[j, :, : len(chosen)] = lower[chosen].T
            body_upper[j, :, : len(chosen)] = upper[chosen].T
        return body_lists, counts, body_lower, body_upper

    @property
    def num_self_pairs(self) -> int:
        """Number of body pairs tested for self-collision (spheres and tables)."""
        return len(self._self_model[0]) + len(self._self_model[1])

    @property
    def num_spheres(self) -> int:
        """Number of leaf spheres in the model (the base's included)."""
        return len(self._trees[7])

    def states_free(self, states: np.ndarray, clearance: float = 0.0) -> np.ndarray:
        """Return ``bool[N]``: each state of ``states`` (N x dim) is in bounds and free.

        With ``clearance`` > 0 a state only counts as free when every moving body's spheres,
        grown by that many metres, still miss every obstacle, and the bodies of every checked
        pair keep that much more than their collision gap between them.

        Raises:
            ValueError: ``clearance`` negative, not finite or above ``resolution / 2`` (the
                broad phase only keeps obstacles within that margin of each body).
        """
        if not (isinstance(clearance, (int, float)) and 0 <= clearance <= self.resolution / 2):
            raise ValueError(
                f"clearance: expected a number in [0, resolution / 2 = {self.resolution / 2}], "
                f"got {clearance!r}"
            )
        states = as_states(states, self.dim)
        if not self.base_free:
            return np.zeros(len(states), dtype=bool)
        return states_free_kernel(states, self._bounds, self._kinematics, self._trees,
                                  self._obstacle_arrays, self._self_model, float(clearance),
                                  self._scratch)  # fmt: skip

    def self_collisions(self, state: np.ndarray) -> list[tuple[str, str]]:
        """The body pairs of ``state`` whose spheres touch, by chain link name."""
        state = as_state(state, "state", self.dim)
        spheres_hit, tables_hit = colliding_pairs_kernel(state, self._kinematics, self._trees,
                                                         self._self_model,
                                                         self._scratch)  # fmt: skip
        pairs = np.concatenate([self._self_model[0][spheres_hit],
                                self._table_pairs[: len(tables_hit)][tables_hit]])  # fmt: skip
        return [self.arm.pair_name(a, b) for a, b in sorted(pairs.tolist())]

    def compiled_context(self) -> tuple:
        """This checker for `temp_gym.worlds.collision.compiled.motion_free` (compiled loops).

        The same arrays `edges_free` uses, plus private scratch space: one context per loop.
        """
        dim, bodies = self.dim, self.dim + 1
        steps = max(1, int(math.ceil(float(np.max(self._motion_radii.sum(axis=0))) * 2.0
                                     / self.resolution)))  # fmt: skip
        work = (np.empty((1, dim)), np.empty((1, dim)),
                *_edge_work(dim, bodies, len(self._self_model[1]), len(self._self_model[0]),
                            steps))  # fmt: skip
        work[3][0] = self._trees[0][self._trees[5][0]] if self._trees[5][1] > 0 else 0.0
        settings = np.array([1.0 if self.base_free else 0.0, self.resolution])
        context = (settings, self._bounds, self._kinematics, self._trees, self._obstacle_arrays,
                   self._self_model, self._motion_radii, scratch_for(sphere_trees(self.arm)),
                   work)  # fmt: skip
        register_motion_kernel(context, motion_free_kernel)
        return context

    def edges_free(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """Return ``bool[N]``: whether each segment ``starts[i] -> ends[i]`` is free."""
        starts, ends = as_edges(starts, ends, self.dim)
        if not self.base_free:
            return np.zeros(len(starts), dtype=bool)
        return edges_free_kernel(starts, ends, self._bounds, self._kinematics, self._trees,
                                 self._obstacle_arrays, self._self_model, self._motion_radii,
                                 self.resolution, self._scratch)  # fmt: skip

    def edge_free(self, start: np.ndarray, end: np.ndarray) -> bool:
        """Whether the straight joint-space motion ``start -> end`` is free, endpoints included."""
        start = as_state(start, "start", self.dim)
        end = as_state(end, "end", self.dim)
        return bool(self.edges_free(start[None], end[None])[0])

    def path_free(self, path: np.ndarray) -> bool:
        """Whether every edge of the polyline ``path`` (K x dim) is free (one state: that one)."""
        path = as_path(path, self.dim)
        if len(path) == 1:
            return bool(self.states_free(path)[0])
        return bool(np.all(self.edges_free(path[:-1], path[1:])))


__all__ = ["DEFAULT_RESOLUTION", "GROWTH_FLOOR", "ArmSphereChecker", "sphere_trees"]
