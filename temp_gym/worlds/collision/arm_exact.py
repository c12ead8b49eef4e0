"""Exact collision checking for any arm (python-fcl): obstacles and self-collision.

This is the checker that certifies every path a planner returns. Each body's collision
elements (`temp_gym.worlds.arm.meshes`) are fcl geometry: meshes as ``BVHModel`` (OBBRSS),
boxes, cylinders and spheres as fcl's own shapes. They are posed by the arm's forward
kinematics and tested against the obstacles, fcl shapes posed by their rotations: ``fcl.Box``,
``fcl.Cylinder`` (along its local z, full length) and ``fcl.Sphere`` (`obstacle_objects`).
Self-collision is tested on the bodies' convex pieces, padded like pybullet's, for the pairs
the allowed-collision matrix enables (`temp_gym.worlds.collision.arm_self`).

**States.** A cheap broad phase (each body's local bounding box, posed, enlarged to a world
AABB) drops the pairs of a body and an obstacle whose world AABBs are apart; fcl's narrow
phase decides the rest, then the enabled body pairs are tested (bounding spheres, then GJK on
the pieces). A state outside the bounds or the joint limits, whatever the bounds say, or with
NaN/inf coordinates, is not free. fcl tests a mesh's *surface* against obstacles, so where it
finds no contact an obstacle small enough to fit in the body's box, with its center in it, is
tested for being wholly inside the mesh (`temp_gym.worlds.collision.arm_enclosure`). A motion
needs no such test between its poses: an obstacle can only get inside a link through its
surface.

**Motions are certified, not sampled.** For a joint-space segment ``q(t) = a + t (b - a)``, a
point of body ``j`` moves at most ``W_j |dt|`` when ``t`` changes by ``dt``, where
``W_j = sum_i |b_i - a_i| L[i, j]`` and ``L[i, j]`` bounds how far body ``j`` gets from joint
``i``'s axis along this segment: measured at both ends on a sphere around the body's pieces,
plus what the joints in between can add, and never more than the arm's bound for every
configuration, ``R[i, j]`` (`temp_gym.worlds.arm.kinematics.segment_levers_into`, as the fast
checker bounds its edges; `ArmModel.motion_radii`). If ``d_j`` is a lower bound on
body ``j``'s distance to every obstacle at ``q(t)``, nothing can touch while ``t`` stays within
``d_j / W_j`` of it, on either side; likewise for a body pair ``(a, b)`` at the rate of
their relative motion, ``sum over a <= i < b of |b_i - a_i| L[i, b]``. The
checker keeps, per body and pair, how far from ``t = 0`` the motion is certified, and measures
poses until every one reaches ``t = 1``, using `STEP_SAFETY` of each span. It measures the next
pose past that frontier (`LOOK_AHEAD`), so that its span covers the gap backwards as well as
the way on: fewer poses than stepping to the frontier each time. When a span falls short of
its frontier, the next pose is the frontier itself, which always moves it on. ``d_j`` is
fcl's element distance where the body is within `MESH_DISTANCE_BELOW` of an obstacle, and
otherwise a cheaper, smaller bound (the distance from its convex pieces, or, farther than
`EXACT_DISTANCE_BELOW`, from its oriented bounding box). A bound found at one
pose, less its rate times the distance in ``t``, still holds at the next, so a body or pair far
from limiting the frontier is measured only when its carried bound could. The poses, the
bounding-box gaps and the bounding-sphere gaps at each pose come from one compiled call, and
so do the carried bounds, the new frontier and the order of measuring
(`temp_gym.worlds.collision.arm_exact_bounds`); Python is left with the loops that call fcl.
It gives up, returning *not free*, when a clearance drops to `MIN_CLEARANCE` or after
``max_steps`` poses: the answer is then "not certified", which is what a certifier must say
when unsure.
"""

from __future__ import annotations

import fcl
import numpy as np

from temp_gym.problem.obstacles import BOX, CYLINDER
from temp_gym.worlds.arm.kinematics import identity_poses, segment_levers_into
from temp_gym.worlds.arm.model import ArmModel
from temp_gym.worlds.arm.sphere_tree import enclosing_sphere
from temp_gym.worlds.collision.arm_enclosure import encloses, mesh_solids
from temp_gym.worlds.collision.arm_exact_bounds import (
    aabb_gaps_into,
    box_center,
    carried_bounds,
    cover_bounds,
    pose_bounds,
)
from temp_gym.worlds.collision.arm_inputs import as_bounds, as_edges, as_path, as_state, as_states
from temp_gym.worlds.collision.arm_obstacles import ArmObstacles, resolve_obstacles
from temp_gym.worlds.collision.arm_self import (
    DISTANCE_TOLERANCE,
    SELF_COLLISION_GAP,
    BodyHulls,
    bounding_spheres,
    fcl_distance,
    piece_models,
    transform,
)

MIN_CLEARANCE = 1e-9
"""Clearance (m) at or below which a motion is not certified."""
EXACT_DISTANCE_BELOW = 0.1
"""Bounding-box clearances (m) below this are refined with the body's convex pieces."""
MESH_DISTANCE_BELOW = 0.01
"""Piece clearances (m) below this are refined with fcl's element distance."""
STEP_SAFETY = 0.9
"""Fraction of the provably safe span used, so that the motion never reaches an obstacle."""
LOOK_AHEAD = 0.75
"""How far past the certified part of a motion the next pose is measured, at most, as a fraction
of how far the last pose's span reached past that pose (the next pose's span covers the gap
backwards). The fraction shrinks by `AHEAD_SHRINK` when a span falls short and grows back by
`AHEAD_GROWTH` when the spans meet; these three were chosen on planners' paths in
MotionBenchMaker's scenes and on random motions in generated workspaces."""
AHEAD_GROWTH = 1.5
AHEAD_SHRINK = 0.5
_NONE_CARRIED = np.empty(0)
"""`cover_bounds`'s ``carried`` when nothing is carried."""


def _mesh_model(vertices: np.ndarray, faces: np.ndarray) -> fcl.BVHModel:
    mesh = fcl.BVHModel()
    mesh.beginModel(len(vertices), len(faces))
    mesh.addSubModel(vertices, faces)
    mesh.endModel()
    return mesh


def element_models(arm: ArmModel) -> tuple:
    """Per body, ``(fcl geometry, 4x4 pose in the body frame)`` of each collision element.

    Cached on the arm: `plan` builds an exact checker on every call to certify its path.
    """
    key = "element_models"
    if key not in arm._arrays:
        bodies = []
        for geometry in arm.geometry:
            elements = []
            for (vertices, faces), primitive in zip(geometry.meshes, geometry.primitives):
                if primitive is None:
                    elements.append((_mesh_model(vertices, faces), np.eye(4)))
                    continue
                kind, size, pose = primitive
                if kind == "box":
                    shape = fcl.Box(*size)
                elif kind == "cylinder":
                    shape = fcl.Cylinder(float(size[0]), float(size[1]))
                else:
                    shape = fcl.Sphere(float(size[0]))
                elements.append((shape, np.asarray(pose, dtype=np.float64)))
            bodies.append(tuple(elements))
        arm._arrays[key] = tuple(bodies)
    return arm._arrays[key]


def _body_bounds(arm: ArmModel) -> tuple[np.ndarray, np.ndarray]:
    """Each body's local bounding box (centers, half extents), from its pieces (cached)."""
    key = "body_bounds"
    if key not in arm._arrays:
        lows, highs = [], []
        for geometry in arm.geometry:
            if geometry.pieces:
                points = np.concatenate(geometry.pieces)
                lows.append(points.min(axis=0))
                highs.append(points.max(axis=0))
            else:
                lows.append(np.zeros(3))
                highs.append(np.zeros(3))
        lows, highs = np.array(lows), np.array(highs)
        arrays = ((lows + highs) / 2, (highs - lows) / 2)
        for array in arrays:
            array.setflags(write=False)
        arm._arrays[key] = arrays
    return arm._arrays[key]


def lever_spheres(arm: ArmModel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A sphere around each body's convex pieces, in `segment_levers_into`'s layout (cached).

    Returns ``(body_start, centers, radii)``: body ``j``'s sphere is row ``body_start[j]``
    when ``body_start[j] < body_start[j + 1]``, and a body without pieces has none. The pieces
    hold the body's collision elements, so every point of the body lies in its sphere. Smaller
    than `arm_self.bounding_spheres` (a box's center and farthest corner), which the pair
    screen uses: a lever arm grows with the radius.
    """
    key = "lever_spheres"
    if key not in arm._arrays:
        centers, radii, counts = [], [], []
        for geometry in arm.geometry:
            counts.append(1 if geometry.pieces else 0)
            if geometry.pieces:
                points = np.concatenate(geometry.pieces)
                center, radius = enclosing_sphere(points, np.zeros(len(points)))
                centers.append(center)
                radii.append(radius)
        arrays = (np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
                  np.array(centers, dtype=np.float64).reshape(-1, 3),
                  np.array(radii, dtype=np.float64))  # fmt: skip
        for array in arrays:
            array.setflags(write=False)
        arm._arrays[key] = arrays
    return arm._arrays[key]


def obstacle_objects(obstacles: ArmObstacles,
                     which: np.ndarray | None = None) -> list[fcl.CollisionObject]:  # fmt: skip
    """Each obstacle (or those of the indices ``which``) as a posed fcl object.

    A box, a cylinder or a sphere; fcl's cylinder lies along its local z with its full length,
    as a workspace's does.
    """
    objects = []
    for b in range(len(obstacles)) if which is None else which:
        center, half, kind = obstacles.centers[b], obstacles.half_extents[b], obstacles.kinds[b]
        if kind == BOX:
            shape = fcl.Box(*(2 * half))
        elif kind == CYLINDER:
            shape = fcl.Cylinder(float(half[0]), float(2 * half[2]))
        else:
            shape = fcl.Sphere(float(half[0]))
        if obstacles.axis_aligned[b]:
            pose = fcl.Transform(center)
        else:
            pose = fcl.Transform(np.array(obstacles.rotations[b]), center)
        objects.append(fcl.CollisionObject(shape, pose))
    return objects


def _element_bounds(arm: ArmModel, body: int) -> np.ndarray:
    """``(2, 3)``: a box around body ``body``'s collision elements, in its frame (cached).

    Meshes by their vertices; primitives by their exact shape (a cylinder by its box), not by
    the polytopes that stand in for them elsewhere.
    """
    key = f"element_bounds_{body}"
    if key not in arm._arrays:
        geometry = arm.geometry[body]
        points = [np.zeros((0, 3))]
        for (vertices, _), primitive in zip(geometry.meshes, geometry.primitives):
            if primitive is None:
                points.append(np.asarray(vertices, dtype=np.float64).reshape(-1, 3))
                continue
            kind, size, pose = primitive
            pose = np.asarray(pose, dtype=np.float64)
            if kind == "sphere":
                corners = np.zeros((1, 3)) + np.array([[-1.0], [1.0]]) * float(size[0])
            else:
                half = (np.asarray(size[:3], dtype=np.float64) / 2 if kind == "box" else
                        np.array([size[0], size[0], size[1] / 2], dtype=np.float64))  # fmt: skip
                signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
                corners = (signs * half) @ pose[:3, :3].T
            points.append(corners + pose[:3, 3])
        points = np.concatenate(points)
        bounds = (np.stack([points.min(axis=0), points.max(axis=0)]) if len(points)
                  else np.full((2, 3), np.nan))  # fmt: skip
        bounds.setflags(write=False)
        arm._arrays[key] = bounds
    return arm._arrays[key]


BASE_SCREEN_MARGIN = 1e-6
"""Slack (m) of the bounding-box screen before fcl tests the base against an obstacle."""


def base_collides(arm: ArmModel, obstacles: ArmObstacles) -> bool:
    """Whether the base body (at the origin) touches an obstacle.

    fcl tests only the obstacles whose bounding box meets the base's (`_element_bounds`).
    """
    bounds = _element_bounds(arm, 0)
    if np.isnan(bounds).any():  # a base without collision geometry
        return False
    meets = np.all((obstacles.lower <= bounds[1] + BASE_SCREEN_MARGIN)
                   & (obstacles.upper >= bounds[0] - BASE_SCREEN_MARGIN), axis=1)  # fmt: skip
    if not meets.any():
        return False
    request = fcl.CollisionRequest()
    objects = [fcl.CollisionObject(shape, transform(pose))
               for shape, pose in element_models(arm)[0]]  # fmt: skip
    solids = mesh_solids(arm)[0]
    pose = np.eye(4)
    indices = np.flatnonzero(meets)
    for index, obstacle in zip(indices, obstacle_objects(obstacles, indices)):
        for obj in objects:
            if fcl.collide(obj, obstacle, request, fcl.CollisionResult()) > 0:
                return True
        if encloses(solids, pose, obstacles.centers[index]):  # inside, touching no triangle
            return True
    return False


class ArmExactChecker:
    """Exact arm checker: fcl on the collision elements and pieces, certified motions.

    Args:
        arm: the arm (`temp_gym.worlds.arm.load_arm`).
        bounds: ``(2, dim)`` joint bounds; states outside them or the joint limits are not
            free.
        box_lower: ``(M, 3)`` lower corners of axis-aligned boxes in the world frame (base at
            the origin, z up); or None with ``obstacles``.
        box_upper: ``(M, 3)`` upper box corners.
        max_steps: most poses measured per edge before giving up.
        self_collision: test the enabled body pairs against each other. Only switched off to
            measure what self-collision costs; `certify_path` always tests it.
        obstacles: obstacles of every kind (`arm_obstacles` of a workspace), instead of
            ``box_lower`` and ``box_upper``.
    """

    def __init__(
        self,
        arm: ArmModel,
        bounds: np.ndarray,
        box_lower: np.ndarray | None = None,
        box_upper: np.ndarray | None = None,
        max_steps: int = 20_000,
        self_collision: bool = True,
        *,
        obstacles: ArmObstacles | None = None,
    ) -> None:
        self.arm = arm
        self.dim = arm.dim
        self.max_steps = int(max_steps)
        self._bounds = as_bounds(bounds, arm.dim)
        self._limits = arm.joint_limits()
        pairs = arm.enabled_pairs() if self_collision else np.zeros((0, 2), dtype=np.int64)
        self._hulls = BodyHulls(arm, pairs)
        self.obstacles = resolve_obstacles(box_lower, box_upper, obstacles)
        """The obstacles checked (`ArmObstacles`)."""
        # The obstacles' world AABBs: the broad phase and the cheapest clearance bounds.
        lower, upper = self.obstacles.lower, self.obstacles.upper
        self._aabb_center = (lower + upper) / 2
        self._aabb_half = (upper - lower) / 2
        self._obstacles = obstacle_objects(self.obstacles)
        # fcl measures curved and turned obstacles by GJK: their distances get its tolerance.
        # A list: read one obstacle at a time, Python floats are faster than numpy scalars.
        self._tolerance = np.where(self.obstacles.axis_aligned, 0.0, DISTANCE_TOLERANCE).tolist()
        self._elements = [
            [(fcl.CollisionObject(shape, fcl.Transform()), pose) for shape, pose in body]
            for body in element_models(arm)
        ]
        # Elements placed at their body's frame take the body's transform as it is.
        self._element_at_frame = [
            [bool(np.array_equal(pose, np.eye(4))) for _, pose in body] for body in self._elements
        ]
        self._pieces = [
            [fcl.CollisionObject(model, fcl.Transform()) for model, _ in body]
            for body in piece_models(arm)
        ]
        self._local_center, self._local_half = _body_bounds(arm)
        self._solids = mesh_solids(arm)
        # Which obstacles fit in a body's box however it turns (a world box's half side is at
        # most the local box's half diagonal): only those can be wholly inside it.
        diagonal = np.linalg.norm(self._local_half, axis=1)
        self._may_hold = np.all(self._aabb_half[None] <= diagonal[:, None, None], axis=2)
        self._motion_radii = arm.motion_radii()
        self._body_boxes = [
            fcl.CollisionObject(fcl.Box(*np.maximum(2 * half, 1e-9)), fcl.Transform())
            for half in self._local_half
        ]
        # Joints i that move a pair's second body relative to its first (a <= i < b).
        joints = np.arange(arm.dim)
        self._pair_joints = ((joints >= self._hulls.pairs[:, :1])
                             & (joints < self._hulls.pairs[:, 1:])).astype(np.float64)  # fmt: skip
        self._lever_spheres = lever_spheres(arm)
        self._lever = np.empty(self._motion_radii.shape)
        self._lever_scratch = (identity_poses(arm.num_bodies), np.empty(arm.dim),
                               np.empty(arm.dim), np.empty(arm.dim))  # fmt: skip
        self._kinematics = arm.kinematic_arrays()
        self._sphere_centers, self._sphere_radii = bounding_spheres(arm)
        self._has_geometry = np.array([bool(g.pieces) for g in arm.geometry])
        self.base_free = not base_collides(arm, self.obstacles)
        self._request = fcl.DistanceRequest()
        self.poses_measured = 0
        """Poses of motions measured so far (a diagnostic: what certification costs)."""
        self.description = (
            f"fcl on the {arm.name} collision geometry, {self.obstacles.summary()}, self-collision "
            f"of {len(self._hulls.pairs)} body pairs (padded convex pieces), certified motions"
            + ("" if self.base_free else ", base link in collision")
        )

    # ------------------------------------------------------------------ helpers
    def _pose_body(self, poses: np.ndarray, j: int, body: fcl.Transform | None = None) -> None:
        """Pose body ``j``'s elements; ``body`` is ``transform(poses[j])`` when known."""
        for (obj, pose), at_frame in zip(self._elements[j], self._element_at_frame[j]):
            if at_frame:
                if body is None:
                    body = transform(poses[j])
                obj.setTransform(body)
            else:
                obj.setTransform(transform(poses[j] @ pose))

    def _body_touches(self, j: int, obstacle: int) -> bool:
        request = fcl.CollisionRequest()
        return any(
            fcl.collide(obj, self._obstacles[obstacle], request, fcl.CollisionResult()) > 0
            for obj, _ in self._elements[j]
        )

    def _encloses(self, poses: np.ndarray, j: int, obstacle: int) -> bool:
        """Whether body ``j`` holds obstacle ``obstacle`` wholly inside a mesh (module doc)."""
        solids = self._solids[j]
        if not solids:
            return False
        pose = poses[j]
        local = pose[:3, :3].T @ (self.obstacles.centers[obstacle] - pose[:3, 3])
        if np.any(np.abs(local - self._local_center[j]) > self._local_half[j]):
            return False
        return any(solid.encloses(local) for solid in solids)

    def _world_boxes(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(centers, halves)`` (..., B, 3): the world AABBs of the bodies' posed local boxes."""
        rotations = poses[..., :3, :3]
        centers = np.einsum("...ij,...j->...i", rotations, self._local_center) + poses[..., :3, 3]
        return centers, np.einsum("...ij,...j->...i", np.abs(rotations), self._local_half)

    def _candidate_pairs(self, poses: np.ndarray) -> np.ndarray:
        """``bool (..., B, M)``: world AABBs of the bodies' local boxes overlap the obstacles'."""
        centers, halves = self._world_boxes(poses)
        gap = np.abs(centers[..., None, :] - self._aabb_center) - halves[..., None, :]
        return np.all(gap <= self._aabb_half, axis=-1) & self._has_geometry[:, None]

    def _pose_free(self, poses: np.ndarray, candidates: np.ndarray) -> bool:
        posed = set()
        for j, b in zip(*np.nonzero(candidates[1:])):
            if j + 1 not in posed:
                self._pose_body(poses, j + 1)
                posed.add(j + 1)
            if self._body_touches(j + 1, b):
                return False
            if self._may_hold[j + 1, b] and self._encloses(poses, j + 1, b):
                return False
        return True

    def _in_bounds(self, states: np.ndarray) -> np.ndarray:
        """Within the bounds and, whatever the bounds say, within the joint limits."""
        with np.errstate(invalid="ignore"):
            inside = (states >= self._bounds[0]) & (states <= self._bounds[1])
            inside &= (states >= self._limits[0]) & (states <= self._limits[1])
        return np.all(inside, axis=1)

    def _aabb_gaps(self, poses: np.ndarray) -> np.ndarray:
        """``(B, M)`` distances from each body's world AABB to each obstacle's: lower bounds."""
        gaps = np.empty((len(poses), len(self._obstacles)))
        aabb_gaps_into(poses, self._local_center, self._local_half, self._aabb_center,
                       self._aabb_half, gaps)  # fmt: skip
        return gaps

    def _body_clearance(self, poses: np.ndarray, j: int, gaps: np.ndarray) -> float:
        """A lower bound on body ``j``'s distance to the nearest obstacle.

        Given its world-AABB ``gaps`` (M,): per obstacle the cheapest informative bound of
        three nested shapes (the body's bounding box, its convex pieces less fcl's tolerance,
        its elements), obstacles visited nearest first and the visit stopped once no obstacle
        left can lower it.
        """
        request = self._request
        posed = [False, False, False]
        body = None  # transform(poses[j]), made once
        best = np.inf
        gap = gaps.tolist()  # Python floats and ints: faster to read one by one
        for b in np.argsort(gaps, kind="stable").tolist():
            if gap[b] - DISTANCE_TOLERANCE >= best:
                break
            piece_distances: list[float] = []  # tier 1's, per piece, which tier 2 reads
            for tier in range(3):
                if tier == 0:
                    objects, tolerance, enough = [self._body_boxes[j]], 0.0, EXACT_DISTANCE_BELOW
                    if not posed[0]:
                        self._body_boxes[j].setRotation(poses[j, :3, :3])
                        self._body_boxes[j].setTranslation(box_center(poses, j, self._local_center))
                elif tier == 1:
                    objects, tolerance, enough = self._pieces[j], DISTANCE_TOLERANCE, \
                        MESH_DISTANCE_BELOW  # fmt: skip
                    if not posed[1]:
                        body = transform(poses[j]) if body is None else body
                        for obj in objects:
                            obj.setTransform(body)
                else:
                    tolerance, enough = 0.0, 0.0
                    if not posed[2]:
                        body = transform(poses[j]) if body is None else body
                        self._pose_body(poses, j, body)
                posed[tier] = True
                if tier == 2:
                    found = self._element_distance(j, b, piece_distances, best)
                else:
                    distances = [fcl_distance(obj, self._obstacles[b], request) for obj in objects]
                    found = min(distances)
                    if tier == 1:
                        piece_distances = distances
                # fcl reports -1 for intersecting shapes.
                bound = max(found - tolerance - self._tolerance[b], 0.0)
                if bound >= best:
                    break
                if bound >= enough:
                    best = bound
                    break
        return best

    def _element_distance(self, j: int, b: int, piece_distances: list[float],
                          best: float) -> float:  # fmt: skip
        """The least fcl distance from body ``j``'s elements to obstacle ``b``, where it matters.

        Each element's convex piece holds it, so the piece's distance (``piece_distances``,
        one per element, less fcl's tolerances) bounds the element's from below: elements are
        measured nearest piece first, and the rest skipped once their bound reaches the
        nearest element measured, or once the answer cannot lower ``best`` (then the caller
        keeps ``best`` whatever the skipped elements measure). The minimum, or what the
        caller reads from it, is the one every element's distance gives: mesh distances cost
        up to milliseconds on detailed grippers, piece distances microseconds.
        """
        elements = self._elements[j]
        if len(piece_distances) != len(elements):
            lower = np.zeros(len(elements))
        else:
            # fcl reports -1 for intersecting shapes: a bound of 0.
            lower = np.maximum(
                np.asarray(piece_distances) - 2 * DISTANCE_TOLERANCE - self._tolerance[b], 0.0
            )
        request = self._request
        nearest = np.inf
        for e in np.argsort(lower, kind="stable"):
            if lower[e] >= nearest or min(nearest, lower[e]) - self._tolerance[b] >= best:
                break
            found = fcl_distance(elements[e][0], self._obstacles[b], request)
            nearest = min(nearest, found)
        return nearest

    def _cover(self, poses, t, frontier, rates, carried, moving, moving_pairs, gaps,
               all_spheres) -> tuple[np.ndarray, float, np.ndarray, bool]:  # fmt: skip
        """``(frontier, closest, known, joined)`` after measuring at the pose ``q(t)``.

        Items are the moving bodies (to the obstacles), then the moving pairs. Item ``i`` is
        certified on ``[0, frontier[i]]``; a lower bound ``K`` on its clearance at ``q(t)``
        certifies it on ``t +- STEP_SAFETY * K / rates[i]`` too, which extends its frontier when
        the two meet. ``carried`` holds lower bounds brought from poses measured before (or
        None); each item's cheap bound is the larger of it and the bounding boxes' or spheres'
        gap. Items are measured (fcl) lowest new frontier first, and only while one could
        still be the least: every item left unmeasured already reaches at least as far. The
        new frontiers return with the smallest clearance measured, ``known`` (each item's best
        lower bound here) and ``joined``: False when a measured item's span at ``t`` still
        leaves a gap after its frontier (then measuring stops: ``t`` was too far ahead).
        ``gaps`` and ``all_spheres`` are this pose's AABB gaps (B, M) and the pairs'
        bounding-sphere gaps (P,) (`pose_bounds`).
        """
        bounds, spheres, frontier, order = cover_bounds(
            t, frontier, rates, _NONE_CARRIED if carried is None else carried, moving,
            moving_pairs, gaps, all_spheres, DISTANCE_TOLERANCE, SELF_COLLISION_GAP, STEP_SAFETY
        )  # fmt: skip
        bodies = len(moving)
        closest = least = np.inf
        for k in order.tolist():
            if frontier[k] >= least:
                break  # sorted: every item left reaches at least as far
            if k < bodies:
                j = moving[k]
                value = self._body_clearance(poses, j, gaps[j])
            else:
                pair = k - bodies
                value = self._hulls.pair_clearance(poses, moving_pairs[pair], spheres[pair],
                                                   EXACT_DISTANCE_BELOW)  # fmt: skip
            closest = min(closest, value)
            if value <= MIN_CLEARANCE:
                return frontier, closest, bounds, False
            bounds[k] = max(bounds[k], value)
            span = STEP_SAFETY * bounds[k] / rates[k]
            if t - span > frontier[k]:
                return frontier, closest, bounds, False
            frontier[k] = max(frontier[k], t + span)
            least = min(least, frontier[k])
        return frontier, closest, bounds, True

    # ------------------------------------------------------------------ protocol
    def states_free(self, states: np.ndarray) -> np.ndarray:
        """Return ``bool[N]``: each state of ``states`` (N x dim) is in bounds and free."""
        states = as_states(states, self.dim)
        free = self._in_bounds(states)
        if not self.base_free:
            return np.zeros(len(states), dtype=bool)
        if not free.any():
            return free
        index = np.flatnonzero(free)
        poses = self.arm.forward_kinematics(states[index])
        if self._obstacles:
            candidates = self._candidate_pairs(poses)
            for k in np.flatnonzero(candidates[:, 1:].any(axis=(1, 2))):
                free[index[k]] = self._pose_free(poses[k], candidates[k])
        near = self._hulls.sphere_gaps(poses) <= SELF_COLLISION_GAP
        for k, p in zip(*np.nonzero(near)):
            if free[index[k]]:
                a, b = self._hulls.pairs[p]
                free[index[k]] = self._hulls.distance(poses[k], a, b) > SELF_COLLISION_GAP
        return free

    def self_collisions(self, state: np.ndarray) -> list[tuple[str, str]]:
        """The enabled body pairs of ``state`` that collide, by chain link name."""
        poses = self.arm.forward_kinematics(as_state(state, "state", self.dim))[0]
        colliding = self._hulls.colliding(poses)
        return [self.arm.pair_name(a, b) for a, b in self._hulls.pairs[colliding]]

    def obstacle_report(self, state: np.ndarray) -> list[tuple[str, int, float]]:
        """Per body near an obstacle: ``(link, obstacle index, distance)``, nearest first.

        The distance is in metres (0 or less: touching, with fcl's penetration depth negated
        where fcl gives one, at most `_depth_bound`). Bodies farther than
        `MESH_DISTANCE_BELOW` from every obstacle are left out. `obstacle_name` names an index
        in words.
        """
        poses = self.arm.forward_kinematics(as_state(state, "state", self.dim))[0]
        if not self._obstacles:
            return []
        gaps = self._aabb_gaps(poses)
        report = []
        for j in range(1, self.arm.num_bodies):
            if not self._has_geometry[j]:
                continue
            self._pose_body(poses, j)
            for b in np.flatnonzero(gaps[j] <= MESH_DISTANCE_BELOW):
                obstacle = self._obstacles[b]
                distance = min(
                    fcl.distance(obj, obstacle, fcl.DistanceRequest(), fcl.DistanceResult())
                    for obj, _ in self._elements[j]
                )
                # fcl may report a mesh overlapping a sphere or a cylinder as 0 apart, not -1.
                aligned = self.obstacles.axis_aligned[b]
                if distance > 0 and self._encloses(poses, j, b):  # at least that deep
                    distance = -distance
                elif distance <= 0 or (not aligned and self._body_touches(j, b)):
                    request = fcl.CollisionRequest(num_max_contacts=8, enable_contact=True)
                    depth = 0.0
                    for obj, _ in self._elements[j]:
                        result = fcl.CollisionResult()
                        if fcl.collide(obj, self._obstacles[b], request, result):
                            depth = max([depth] + [c.penetration_depth for c in result.contacts])
                    distance = -min(depth, self._depth_bound(poses, j, b))
                if distance <= MESH_DISTANCE_BELOW:
                    report.append((self.arm.body_names[j], int(b), float(distance)))
        return sorted(report, key=lambda entry: entry[2])

    def _depth_bound(self, poses: np.ndarray, j: int, b: int) -> float:
        """An upper bound on how deep body ``j`` is in obstacle ``b``.

        Their world boxes' least overlap along an axis: moving the body that far along it
        separates the boxes, so the shapes. fcl's contact depths between a mesh and a box can
        be far larger (a metre for a link 5 cm into a 10 cm slab).
        """
        centers, halves = self._world_boxes(poses)
        overlap = halves[j] + self._aabb_half[b] - np.abs(centers[j] - self._aabb_center[b])
        return float(max(overlap.min(), 0.0))

    def obstacle_name(self, index: int) -> str:
        """Obstacle ``index`` as messages name it: its kind and index, e.g. ``"cylinder 3"``."""
        return self.obstacles.name(index)

    def edge_free(self, start: np.ndarray, end: np.ndarray) -> bool:
        """Certify the straight joint-space motion ``start -> end`` (module docstring)."""
        start = as_state(start, "start", self.dim)
        end = as_state(end, "end", self.dim)
        return bool(np.all(self.states_free(np.stack([start, end])))) and self._motion_free(
            start, end
        )

    def _motion_rates(self, start: np.ndarray, end: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """How fast the motion ``start -> end`` moves things, per unit of ``t``.

        Returns ``(bodies,)``: how far a point of each body moves at most, and ``(P,)``: how
        far a point of each enabled pair's second body moves at most relative to the first.
        Both from the motion's lever arms (module docstring).
        """
        body_start, centers, radii = self._lever_spheres
        poses, q, sines, cosines = self._lever_scratch
        kind, rotation, shift = self._kinematics
        lever = self._lever
        segment_levers_into(np.ascontiguousarray(start).reshape(1, -1),
                            np.ascontiguousarray(end).reshape(1, -1), 0, kind, rotation, shift,
                            self._motion_radii, body_start, centers, radii, poses, q, sines,
                            cosines, lever)  # fmt: skip
        speed = np.abs(end - start)
        return speed @ lever, (self._pair_joints * lever[:, self._hulls.pairs[:, 1]].T) @ speed

    def _motion_free(self, start: np.ndarray, end: np.ndarray) -> bool:
        """`edge_free` for a motion whose ends are known to be free."""
        delta = end - start
        sweep, pair_sweep = self._motion_rates(start, end)
        moving = (np.flatnonzero((sweep > 0) & self._has_geometry) if self._obstacles
                  else np.zeros(0, dtype=np.int64))  # fmt: skip
        moving_pairs = np.flatnonzero(pair_sweep > 0)
        if len(moving) == 0 and len(moving_pairs) == 0:
            return True
        rates = np.concatenate([sweep[moving], pair_sweep[moving_pairs]])
        poses = identity_poses(self.arm.num_bodies)
        gaps = np.empty((self.arm.num_bodies, len(self._obstacles)))
        spheres = np.empty(len(self._hulls.pairs))
        frontier = np.zeros(len(rates))
        # (t, known) of the last pose measured and of the one before (none: empty bounds).
        last, before = None, (0.0, _NONE_CARRIED)
        pending = None  # (t, spans) of a pose ahead whose spans fell short of the frontier
        t, ahead = 0.0, LOOK_AHEAD
        for _ in range(self.max_steps):
            pose_bounds(start, delta, t, *self._kinematics, self._local_center,
                        self._local_half, self._aabb_center, self._aabb_half,
                        self._sphere_centers, self._sphere_radii, self._hulls.pairs, poses, gaps,
                        spheres)  # fmt: skip
            # Nothing comes nearer than its rate times the distance in t: bounds carried here.
            carried = None if last is None else carried_bounds(t, rates, *last, *before)
            frontier, closest, known, joined = self._cover(
                poses, t, frontier, rates, carried, moving, moving_pairs, gaps, spheres
            )
            self.poses_measured += 1
            if closest <= MIN_CLEARANCE:
                return False
            before, last = last or before, (t, known)
            if pending is not None:  # the frontier may now meet that pose's spans
                when, spans = pending
                meets = when - spans <= frontier
                frontier = np.where(meets, np.maximum(frontier, when + spans), frontier)
                pending = None if meets.all() else pending
            if not joined:
                pending = (t, STEP_SAFETY * known / rates)
            reached = frontier.min()
            if reached >= 1.0:
                return True
            # The next pose: past the frontier by `ahead` times how far this pose's span reached
            # past this pose, so that its span may meet the frontier from beyond. When a span
            # fell short, the next pose is the frontier itself, which always moves it on.
            if joined:
                ahead = min(LOOK_AHEAD, AHEAD_GROWTH * ahead)
                t = min(1.0, reached + ahead * max(reached - t, 0.0))
            else:
                ahead *= AHEAD_SHRINK
                t = reached
        return False

    def edges_free(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """Return ``bool[N]``: `edge_free` for each row pair of ``starts`` and ``ends``."""
        starts, ends = as_edges(starts, ends, self.dim)
        # Each end checked once, in one call.
        ends_free = self.states_free(np.concatenate([starts, ends])).reshape(2, -1).all(axis=0)
        return np.array([free and self._motion_free(a, b)
                         for a, b, free in zip(starts, ends, ends_free)], dtype=bool)  # fmt: skip

    def path_free(self, path: np.ndarray) -> bool:
        """Certify every edge of the polyline ``path`` (K x dim); one state: that state."""
        path = as_path(path, self.dim)
        if len(path) == 1:
            return bool(self.states_free(path)[0])
        # Each waypoint checked once, in one call.
        return bool(self.states_free(path).all()) and all(
            self._motion_free(a, b) for a, b in zip(path[:-1], path[1:])
        )


__all__ = [
    "EXACT_DISTANCE_BELOW",
    "MESH_DISTANCE_BELOW",
    "MIN_CLEARANCE",
    "ArmExactChecker",
    "base_collides",
    "element_models",
    "obstacle_objects",
]
