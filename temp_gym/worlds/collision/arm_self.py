"""Exact self-collision of an arm: fcl's GJK on the convex pieces of body pairs.

Two bodies collide when a convex piece of one comes within `SELF_COLLISION_GAP` of a piece of
the other: each piece is grown by `temp_gym.worlds.arm.model.COLLISION_PADDING`, pybullet's
collision margin, so that two bodies collide exactly when pybullet says their links touch.
Only the pairs the allowed-collision matrix enables are tested (`temp_gym.worlds.arm.acm`).
Pieces are solids: a piece inside another counts as a collision.

**Distances are lower bounds.** fcl's GJK distance between two convex pieces can exceed the
true distance by a little (about 1e-6 m), so `DISTANCE_TOLERANCE` is subtracted from every
distance; fcl reports ``-1`` for intersecting pieces, which reads as collision. A pair whose
bodies' bounding spheres are farther apart than the gap needs no GJK call (the broad phase).

**Motions.** Along a joint-space segment the distance between bodies ``a < b`` shrinks at most
at the rate of their relative motion, which only the joints ``a <= i < b`` make (bounded by the
segment's lever arms, at most `ArmModel.relative_motion_radii`), so `BodyHulls.clearances`
gives the lower bounds that `temp_gym.worlds.collision.arm_exact` turns into certified steps.
"""

from __future__ import annotations

import fcl
import numpy as np

from temp_gym.worlds.arm.model import COLLISION_PADDING, ArmModel
from temp_gym.worlds.arm.spheres import hull_planes

DISTANCE_TOLERANCE = 1e-5
"""Subtracted from every fcl piece distance (m), so that a distance is a lower bound."""
SELF_COLLISION_GAP = 2 * COLLISION_PADDING
"""Two bodies whose pieces are this close (m) or closer are in collision."""


_UNWRITTEN = fcl.DistanceResult(-np.inf)
"""The result `fcl_distance` hands to fcl: python-fcl never writes to it (`fcl_distance`)."""


def fcl_distance(first: fcl.CollisionObject, second: fcl.CollisionObject,
                 request: fcl.DistanceRequest) -> float:  # fmt: skip
    """The distance fcl measures between two collision objects (-1 when they intersect).

    python-fcl copies the nearest points and the two geometries into the result object it is
    given whenever the distance beats the result's, and that copy costs more than a box's
    distance itself. A result whose distance is already -inf is never written; the distance
    fcl returns is the same.
    """
    return fcl.distance(first, second, request, _UNWRITTEN)


def transform(pose: np.ndarray) -> fcl.Transform:
    """An fcl transform of a 4x4 (or 3x4) pose."""
    return fcl.Transform(pose[:3, :3], pose[:3, 3])  # it copies them into contiguous arrays


def convex_model(vertices: np.ndarray) -> tuple[fcl.Convex, np.ndarray]:
    """The convex hull of ``vertices`` as an fcl ``Convex``, and the hull's corners."""
    corners, faces, _ = hull_planes(vertices)
    counted = np.hstack([np.full((len(faces), 1), 3), faces]).ravel()
    return fcl.Convex(corners, len(faces), counted), corners


def piece_models(arm: ArmModel) -> tuple:
    """Per body, its convex pieces as fcl geometry and the pieces' corners (cached on the arm).

    The geometry never changes; every `BodyHulls` wraps it in collision objects of its own.
    """
    key = "piece_models"
    if key not in arm._arrays:
        arm._arrays[key] = tuple(
            tuple(convex_model(piece) for piece in geometry.pieces) for geometry in arm.geometry
        )
    return arm._arrays[key]


def bounding_spheres(arm: ArmModel) -> tuple[np.ndarray, np.ndarray]:
    """Each body's pieces' bounding sphere (box center, farthest corner), in the body frame."""
    key = "piece_bounds"
    if key not in arm._arrays:
        centers, radii = [], []
        for models in piece_models(arm):
            corners = np.concatenate([c for _, c in models]) if models else np.zeros((1, 3))
            center = (corners.min(axis=0) + corners.max(axis=0)) / 2
            centers.append(center)
            radii.append(float(np.linalg.norm(corners - center, axis=1).max()))
        arrays = (np.array(centers), np.array(radii))
        for array in arrays:
            array.setflags(write=False)
        arm._arrays[key] = arrays
    return arm._arrays[key]


class BodyHulls:
    """The bodies' convex pieces as fcl objects, and padded distances between body pairs.

    Args:
        arm: the arm.
        pairs: ``(P, 2)`` body indices (0 is the base) of the pairs to test.
    """

    def __init__(self, arm: ArmModel, pairs: np.ndarray) -> None:
        self.arm = arm
        self.pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
        self._objects = [
            [fcl.CollisionObject(model, fcl.Transform()) for model, _ in body]
            for body in piece_models(arm)
        ]
        self._sphere_centers, self._sphere_radii = bounding_spheres(arm)
        self._request = fcl.DistanceRequest()

    def sphere_gaps(self, poses: np.ndarray) -> np.ndarray:
        """``(..., P)`` distances between the pairs' bounding spheres.

        For poses ``(..., bodies, 4, 4)``: lower bounds on the piece distances (negative:
        overlap).
        """
        centers = np.einsum("...jik,jk->...ji", poses[..., :3, :3], self._sphere_centers)
        centers = centers + poses[..., :3, 3]
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        between = np.linalg.norm(centers[..., a, :] - centers[..., b, :], axis=-1)
        return between - self._sphere_radii[a] - self._sphere_radii[b]

    def distance(self, poses: np.ndarray, a: int, b: int) -> float:
        """A lower bound on the distance between bodies ``a`` and ``b``'s pieces (0 if touching).

        ``poses`` are the bodies' world poses in one configuration.
        """
        for body in (a, b):
            posed = transform(poses[body])
            for obj in self._objects[body]:
                obj.setTransform(posed)
        best = np.inf
        for first in self._objects[a]:
            for second in self._objects[b]:
                found = fcl_distance(first, second, self._request)
                best = min(best, max(found - DISTANCE_TOLERANCE, 0.0))
                if best == 0.0:
                    return 0.0
        return float(best)

    def colliding(self, poses: np.ndarray) -> np.ndarray:
        """``bool[P]``: which pairs are in collision in one configuration."""
        out = np.zeros(len(self.pairs), dtype=bool)
        for p in np.flatnonzero(self.sphere_gaps(poses) <= SELF_COLLISION_GAP):
            a, b = self.pairs[p]
            out[p] = self.distance(poses, a, b) <= SELF_COLLISION_GAP
        return out

    def pair_clearance(
        self, poses: np.ndarray, p: int, sphere_clearance: float, exact_below: float
    ) -> float:
        """Pair ``p``'s padded clearance (<= 0: collision).

        Its bounding-sphere clearance when that is at least ``exact_below``, else fcl's piece
        distance less the gap.
        """
        if sphere_clearance >= exact_below:
            return float(sphere_clearance)
        a, b = self.pairs[p]
        return self.distance(poses, a, b) - SELF_COLLISION_GAP


__all__ = [
    "DISTANCE_TOLERANCE",
    "SELF_COLLISION_GAP",
    "BodyHulls",
    "bounding_spheres",
    "convex_model",
    "fcl_distance",
    "piece_models",
    "transform",
]
