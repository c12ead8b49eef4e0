"""Exact collision checking for the KUKA iiwa 14 (python-fcl): boxes and self-collision.

This is the checker that certifies every path a planner returns. Each link's collision mesh
(pybullet_data's ``kuka_iiwa/meshes/link_*.stl``) is an fcl ``BVHModel`` (OBBRSS), posed by
the forward kinematics of `temp_gym.worlds.iiwa14.kinematics` and tested against ``fcl.Box``
obstacles. Self-collision is tested on the links' convex hulls, padded like pybullet's, for the
pairs the allowed-collision matrix enables (`temp_gym.worlds.collision.iiwa_self`).

**States.** A cheap broad phase (each link's mesh AABB, posed as an oriented box, enlarged to
a world AABB) drops the link-box pairs that cannot touch; fcl's narrow phase decides the rest,
then the enabled link pairs are tested (bounding spheres, then GJK on the hulls). A state
outside the bounds or the URDF joint limits, whatever the bounds say, or with NaN/inf
coordinates, is not free. fcl tests the mesh *surface* against boxes: an obstacle entirely
inside a link's hull without touching a triangle is missed, which needs a box smaller than a
link and is not produced by the world generators.

**Motions are certified, not sampled.** For a joint-space segment ``q(t) = a + t (b - a)``,
a point of link ``j`` moves at most ``W_j |dt|`` when ``t`` changes by ``dt``, where
``W_j = sum_i |b_i - a_i| R[i, j]`` and ``R[i, j]`` bounds the distance of link ``j``'s mesh from
joint ``i``'s axis (`temp_gym.worlds.iiwa14.kinematics.motion_radii`). If ``d_j`` is a lower bound
on link ``j``'s distance to every box at ``q(t)``, nothing can touch while ``t`` advances by
less than ``min_j d_j / W_j``. Likewise, the distance between links ``a < b`` changes only
through the joints between them (the others move both links as one rigid body), at most at
rate ``W_ab = sum_{a <= i < b} |b_i - a_i| R[i, b]`` (at most ``W_a + W_b``), so a pair with
padded clearance ``d_ab`` cannot touch while ``t`` advances by less than ``d_ab / W_ab``
(`temp_gym.worlds.iiwa14.kinematics.relative_motion_radii`). The checker walks
the segment with steps of ``0.9`` times the smallest of these; ``d_j`` is the fcl mesh-box
distance where the link is within ``MESH_DISTANCE_BELOW`` of a box, and otherwise a cheaper,
smaller bound: the distance from the link's convex hull, or, for boxes farther than
``EXACT_DISTANCE_BELOW``, from its oriented bounding box (boxes whose world-AABB gap rules
them out are not measured at all); ``d_ab`` is the hull distance or, for far pairs, the
distance between the hulls' bounding spheres. It gives up, returning *not free*, when a
clearance drops to ``MIN_CLEARANCE`` or after ``max_steps`` steps: the answer is then "not
certified", which is what a certifier must say when unsure.
"""

from __future__ import annotations

import functools

import fcl
import numpy as np

from temp_gym.worlds.collision.iiwa_inputs import as_bounds, as_boxes, as_state, as_states
from temp_gym.worlds.collision.iiwa_self import (
    DISTANCE_TOLERANCE,
    SELF_COLLISION_GAP,
    LinkHulls,
    hull_models,
)
from temp_gym.worlds.iiwa14.acm import enabled_pairs, link_name
from temp_gym.worlds.iiwa14.kinematics import (
    NUM_LINKS,
    forward_kinematics,
    joint_limits,
    link_meshes,
    motion_radii,
    relative_motion_radii,
)

MIN_CLEARANCE = 1e-9
"""Clearance (m) at or below which a motion is not certified."""
EXACT_DISTANCE_BELOW = 0.1
"""Bounding-box clearances (m) below this are refined with the link's convex hull."""
MESH_DISTANCE_BELOW = 0.01
"""Hull clearances (m) below this are refined with fcl's mesh distance."""
STEP_SAFETY = 0.9
"""Fraction of the provably safe step taken, so that the motion never reaches a box."""


def _transform(pose: np.ndarray) -> fcl.Transform:
    return fcl.Transform(np.ascontiguousarray(pose[:3, :3]), np.ascontiguousarray(pose[:3, 3]))


def _mesh_model(vertices: np.ndarray, faces: np.ndarray) -> fcl.BVHModel:
    mesh = fcl.BVHModel()
    mesh.beginModel(len(vertices), len(faces))
    mesh.addSubModel(vertices, faces)
    mesh.endModel()
    return mesh


@functools.lru_cache(maxsize=1)
def _link_models() -> tuple[fcl.BVHModel, ...]:
    """Each link's mesh as an fcl BVH, built once per process.

    Building them is most of a checker's construction, and `plan` builds an exact checker
    on every call to certify its path. The geometry never changes after ``endModel``; each
    checker wraps it in collision objects of its own, which carry the poses.
    """
    return tuple(_mesh_model(vertices, faces) for vertices, faces in link_meshes())


@functools.lru_cache(maxsize=1)
def _link_bounds() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each link mesh's local bounding box (centers, half extents; 8 x 3) and motion radii.

    Computed once per process from the meshes (read-only arrays): every checker, and `plan`
    makes one per call to certify its path, shares them.
    """
    lows = np.array([vertices.min(axis=0) for vertices, _ in link_meshes()])
    highs = np.array([vertices.max(axis=0) for vertices, _ in link_meshes()])
    mesh_radii = np.array([np.linalg.norm(v, axis=1).max() for v, _ in link_meshes()])
    arrays = ((lows + highs) / 2, (highs - lows) / 2, motion_radii(mesh_radii))
    for array in arrays:
        array.setflags(write=False)
    return arrays


@functools.lru_cache(maxsize=1)
def _base_link() -> fcl.CollisionObject:
    """link_0's mesh at the origin (it never moves)."""
    return fcl.CollisionObject(_link_models()[0], fcl.Transform())


def base_link_collides(box_params: np.ndarray) -> bool:
    """Whether link_0's mesh (at the origin) touches a box ``(cx, cy, cz, hx, hy, hz)``."""
    base = _base_link()
    request = fcl.CollisionRequest()
    for box in box_params:
        obstacle = fcl.CollisionObject(fcl.Box(*(2 * box[3:])), fcl.Transform(box[:3]))
        if fcl.collide(base, obstacle, request, fcl.CollisionResult()) > 0:
            return True
    return False


class IiwaExactChecker:
    """Exact iiwa checker: fcl on the link meshes and hulls, with certified motion checks.

    Args:
        bounds: ``(2, 7)`` joint bounds; states outside them or the URDF joint limits are
            not free.
        box_lower: ``(M, 3)`` lower box corners in the world frame (base at the origin, z up).
        box_upper: ``(M, 3)`` upper box corners.
        max_steps: largest number of certification steps per edge before giving up.
        self_collision: test the enabled link pairs against each other. Only switched off to
            measure what self-collision costs; `certify_path` always tests it.

    Example:
        >>> checker = IiwaExactChecker(joint_limits(), [[0.5, -1, 0]], [[0.6, 1, 1]])
        >>> checker.edge_free(np.zeros(7), np.full(7, 0.3))
        True
    """

    def __init__(
        self,
        bounds: np.ndarray,
        box_lower: np.ndarray,
        box_upper: np.ndarray,
        max_steps: int = 20_000,
        self_collision: bool = True,
    ) -> None:
        self.dim = 7
        self.max_steps = int(max_steps)
        self._bounds = as_bounds(bounds)
        self._limits = joint_limits()
        self._hulls = LinkHulls(enabled_pairs() if self_collision else np.zeros((0, 2)))
        lower, upper = as_boxes(box_lower, box_upper)
        self._box_center = (lower + upper) / 2
        self._box_half = (upper - lower) / 2
        self._boxes = [
            fcl.CollisionObject(fcl.Box(*(2 * h)), fcl.Transform(c))
            for c, h in zip(self._box_center, self._box_half)
        ]
        self._link_hulls = [fcl.CollisionObject(model, fcl.Transform()) for model in hull_models()]
        self._links = [fcl.CollisionObject(model, fcl.Transform()) for model in _link_models()]
        self._local_center, self._local_half, self._motion_radii = _link_bounds()
        self._link_boxes = [
            fcl.CollisionObject(fcl.Box(*(2 * half)), fcl.Transform()) for half in self._local_half
        ]
        self._pair_motion = relative_motion_radii(self._motion_radii, self._hulls.pairs)
        # link_0 never moves (its pose is the identity): test it once.
        self.base_free = not any(self._pair_collides(0, b) for b in range(len(self._boxes)))
        self.description = (
            f"fcl on the iiwa collision meshes, {len(self._boxes)} boxes, self-collision of "
            f"{len(self._hulls.pairs)} link pairs (padded hulls), certified motions"
            + ("" if self.base_free else ", base link in collision")
        )

    # ------------------------------------------------------------------ helpers
    def _pair_collides(self, link: int, box: int) -> bool:
        request = fcl.CollisionRequest()
        return fcl.collide(self._links[link], self._boxes[box], request, fcl.CollisionResult()) > 0

    def _pose_links(self, poses: np.ndarray, links) -> None:
        for j in links:
            self._links[j].setTransform(_transform(poses[j]))

    def _candidate_pairs(self, poses: np.ndarray) -> np.ndarray:
        """``bool (..., 8, M)``: world AABBs of the links' local boxes overlap the obstacles."""
        rotations = poses[..., :3, :3]
        centers = np.einsum("...ij,...j->...i", rotations, self._local_center) + poses[..., :3, 3]
        halves = np.einsum("...ij,...j->...i", np.abs(rotations), self._local_half)
        gap = np.abs(centers[..., None, :] - self._box_center) - halves[..., None, :]
        return np.all(gap <= self._box_half, axis=-1)

    def _pose_free(self, poses: np.ndarray, candidates: np.ndarray) -> bool:
        for j, b in zip(*np.nonzero(candidates[1:])):
            self._links[j + 1].setTransform(_transform(poses[j + 1]))
            if self._pair_collides(j + 1, b):
                return False
        return True

    def _in_bounds(self, states: np.ndarray) -> np.ndarray:
        """Within the bounds and, whatever the bounds say, within the URDF joint limits."""
        with np.errstate(invalid="ignore"):
            inside = (states >= self._bounds[0]) & (states <= self._bounds[1])
            inside &= (states >= self._limits[0]) & (states <= self._limits[1])
        return np.all(inside, axis=1)

    def _aabb_gaps(self, poses: np.ndarray) -> np.ndarray:
        """``(8, M)`` distances from each link's world AABB to each box: cheap lower bounds.

        The world AABB of a link's oriented bounding box contains that box, so its distance
        to an obstacle is at most the oriented box's, and at most the mesh's.
        """
        rotations = poses[:, :3, :3]
        centers = np.einsum("jik,jk->ji", rotations, self._local_center) + poses[:, :3, 3]
        halves = np.einsum("jik,jk->ji", np.abs(rotations), self._local_half)
        gap = np.abs(centers[:, None, :] - self._box_center) - halves[:, None, :]
        gap = np.maximum(gap - self._box_half, 0.0)
        return np.sqrt(np.einsum("jbk,jbk->jb", gap, gap))

    def _clearances(self, poses: np.ndarray, links: np.ndarray) -> np.ndarray:
        """Lower bounds on each link's distance to the nearest box (``inf`` without boxes).

        Per box, the cheapest of three nested bounds that is informative: the fcl distance
        of the link's oriented bounding box when it is at least `EXACT_DISTANCE_BELOW`, else
        that of the link's convex hull (less fcl's GJK tolerance) when it is at least
        `MESH_DISTANCE_BELOW`, else fcl's mesh distance. Each is a lower bound on the mesh
        distance (box contains hull contains mesh), and where a link comes close to a box the
        mesh distance itself is used, so certification still fails only on the meshes.
        Link ``j``'s clearance is the minimum over the boxes. They are visited nearest first by
        the world-AABB gap (`_aabb_gaps`, a lower bound on all three), and the visit stops at
        the first box whose gap is no less than the clearance so far: the boxes left out
        could not lower it, so fcl is called on the few boxes near the link.
        """
        clearance = np.full(NUM_LINKS, np.inf)
        if not self._boxes:
            return clearance
        gaps = self._aabb_gaps(poses)
        for j in links:
            clearance[j] = self._link_clearance(poses, j, gaps[j])
        return clearance

    def _link_clearance(self, poses: np.ndarray, j: int, gaps: np.ndarray) -> float:
        """Link ``j``'s clearance of `_clearances`, given its world-AABB ``gaps`` (M,)."""
        box_pose = poses[j].copy()
        box_pose[:3, 3] += box_pose[:3, :3] @ self._local_center[j]
        # (shape, its pose, what fcl may overshoot by, the bound that needs no finer shape)
        tiers = (
            (self._link_boxes[j], box_pose, 0.0, EXACT_DISTANCE_BELOW),
            (self._link_hulls[j], poses[j], DISTANCE_TOLERANCE, MESH_DISTANCE_BELOW),
            (self._links[j], poses[j], 0.0, 0.0),
        )
        posed = [False, False, False]
        request = fcl.DistanceRequest()
        best = np.inf
        for b in np.argsort(gaps, kind="stable"):
            # Every tier's bound is at least the gap less fcl's tolerance: stop once no box
            # left can lower the clearance.
            if gaps[b] - DISTANCE_TOLERANCE >= best:
                break
            for tier, (shape, pose, tolerance, enough) in enumerate(tiers):
                if not posed[tier]:
                    shape.setTransform(_transform(pose))
                    posed[tier] = True
                found = fcl.distance(shape, self._boxes[b], request, fcl.DistanceResult())
                bound = max(found - tolerance, 0.0)  # fcl reports -1 for intersecting shapes
                if bound >= best:  # finer shapes are farther still: this box cannot lower it
                    break
                if bound >= enough:
                    best = bound
                    break
        return best

    def _advance(
        self,
        poses: np.ndarray,
        moving: np.ndarray,
        sweep: np.ndarray,
        moving_pairs: np.ndarray,
        pair_sweep: np.ndarray,
    ) -> tuple[float, float]:
        """``(advance, closest)`` at one pose of a segment: the largest safe step in ``t``.

        ``advance`` is the minimum of clearance over motion rate over the moving links
        (`_clearances`) and link pairs (`LinkHulls.clearances`); ``closest`` is the smallest
        of those clearances, or a value above `MIN_CLEARANCE` when none is at or below it.
        Both are what measuring every link and pair gives, but a link or pair is measured
        only when its cheap lower bound (world-AABB gap, bounding spheres, less fcl's
        tolerance) could still lower ``advance`` or reach `MIN_CLEARANCE`: most links are
        far from every box compared with the one that limits the step.
        """
        bounds, rates, which = [], [], []
        if len(moving):
            gaps = self._aabb_gaps(poses)
            bounds.extend(gaps[moving].min(axis=1) - DISTANCE_TOLERANCE)
            rates.extend(sweep[moving])
            which.extend(int(j) for j in moving)
        if len(moving_pairs):
            spheres = self._hulls.sphere_gaps(poses)[moving_pairs] - SELF_COLLISION_GAP
            bounds.extend(spheres - DISTANCE_TOLERANCE)
            rates.extend(pair_sweep[moving_pairs])
            which.extend(-1 - k for k in range(len(moving_pairs)))
        bounds, rates = np.asarray(bounds), np.asarray(rates)
        advance = closest = np.inf
        for k in np.argsort(bounds / rates, kind="stable"):
            if bounds[k] > MIN_CLEARANCE and bounds[k] / rates[k] >= advance:
                continue
            if which[k] >= 0:
                value = self._link_clearance(poses, which[k], gaps[which[k]])
            else:
                pair = -1 - which[k]
                value = self._hulls.pair_clearance(
                    poses, moving_pairs[pair], spheres[pair], EXACT_DISTANCE_BELOW
                )
            closest = min(closest, value)
            advance = min(advance, value / rates[k])
        return float(advance), float(closest)

    # ------------------------------------------------------------------ protocol
    def states_free(self, states: np.ndarray) -> np.ndarray:
        """Return ``bool[N]``: each state of ``states`` (N x 7) is in bounds and collision-free."""
        states = as_states(states)
        free = self._in_bounds(states)
        if not self.base_free:
            return np.zeros(len(states), dtype=bool)
        if not free.any():
            return free
        index = np.flatnonzero(free)
        poses = forward_kinematics(states[index])
        if self._boxes:
            candidates = self._candidate_pairs(poses)
            for k in np.flatnonzero(candidates[:, 1:].any(axis=(1, 2))):
                free[index[k]] = self._pose_free(poses[k], candidates[k])
        # Self-collision of the states still free; pairs whose bounding spheres are apart skip GJK.
        near = self._hulls.sphere_gaps(poses) <= SELF_COLLISION_GAP
        for k, p in zip(*np.nonzero(near)):
            if free[index[k]]:
                a, b = self._hulls.pairs[p]
                free[index[k]] = self._hulls.distance(poses[k], a, b) > SELF_COLLISION_GAP
        return free

    def self_collisions(self, state: np.ndarray) -> list[tuple[str, str]]:
        """The enabled link pairs of ``state`` (7,) that collide: ``[("link_5", "link_7")]``."""
        poses = forward_kinematics(as_state(state, "state"))[0]
        colliding = self._hulls.colliding(poses)
        return [(link_name(a), link_name(b)) for a, b in self._hulls.pairs[colliding]]

    def edge_free(self, start: np.ndarray, end: np.ndarray) -> bool:
        """Certify the straight joint-space motion ``start -> end`` (see the module docstring)."""
        start = as_state(start, "start")
        end = as_state(end, "end")
        if not np.all(self.states_free(np.stack([start, end]))):
            return False
        delta = end - start
        sweep = np.abs(delta) @ self._motion_radii  # W_j: link j's motion bound per unit t
        moving = np.flatnonzero(sweep > 0) if self._boxes else np.zeros(0, dtype=np.int64)
        pair_sweep = self._pair_motion @ np.abs(delta)  # W_ab: relative motion per unit t
        moving_pairs = np.flatnonzero(pair_sweep > 0)
        if len(moving) == 0 and len(moving_pairs) == 0:
            return True
        t = 0.0
        for _ in range(self.max_steps):
            poses = forward_kinematics(start + t * delta)[0]
            advance, closest = self._advance(poses, moving, sweep, moving_pairs, pair_sweep)
            if closest <= MIN_CLEARANCE:
                return False
            t += STEP_SAFETY * advance
            if t >= 1.0:
                return True
        return False

    def edges_free(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """Return ``bool[N]``: `edge_free` for each row pair of ``starts`` and ``ends``."""
        starts = as_states(starts, "starts")
        ends = as_states(ends, "ends")
        if starts.shape != ends.shape:
            raise ValueError(f"starts, ends: shapes {starts.shape} and {ends.shape} do not match")
        return np.array([self.edge_free(a, b) for a, b in zip(starts, ends)], dtype=bool)

    def path_free(self, path: np.ndarray) -> bool:
        """Certify every edge of the polyline ``path`` (K x 7); one state: that state."""
        path = as_states(path, "path")
        if len(path) == 0:
            raise ValueError("path: expected at least one state")
        if len(path) == 1:
            return bool(self.states_free(path)[0])
        return all(self.edge_free(a, b) for a, b in zip(path[:-1], path[1:]))


__all__ = [
    "EXACT_DISTANCE_BELOW",
    "MESH_DISTANCE_BELOW",
    "MIN_CLEARANCE",
    "IiwaExactChecker",
    "base_link_collides",
]
