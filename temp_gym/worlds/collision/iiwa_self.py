"""Exact self-collision of the iiwa: fcl's GJK on the padded convex hulls of link pairs.

Two links collide when their convex hulls, each grown by `SELF_COLLISION_PADDING`, touch:
when the distance between the hulls is at most ``2 * SELF_COLLISION_PADDING``
(`temp_gym.worlds.iiwa14.convex_hulls` says why hulls). Only the pairs that the allowed-collision
matrix enables are tested (`temp_gym.worlds.iiwa14.acm`).

**Distances are lower bounds.** fcl's GJK distance between two hulls can exceed the true
distance by a little (by about 1e-6 m on these hulls, against a quadratic program's), so
`DISTANCE_TOLERANCE` is subtracted from every distance: a pair is in collision when its
distance minus the tolerance is at most the padding gap. fcl reports ``-1`` for intersecting
hulls, which reads as collision. A pair whose hulls' bounding spheres are farther apart than
the gap needs no GJK call (the broad phase).

**Motions.** Along a joint-space segment, a point of link ``b`` moves relative to link ``a``
at most at rate ``W_ab`` per unit of ``t``
(`temp_gym.worlds.iiwa14.kinematics.relative_motion_radii`;
hull points are convex combinations of mesh vertices, so the mesh's bound holds for them), so
the distance between the links shrinks at most at that rate. `LinkHulls.clearances` gives
the lower bounds that `temp_gym.worlds.collision.iiwa_exact` turns into certified steps.
"""

from __future__ import annotations

import functools

import fcl
import numpy as np

from temp_gym.worlds.iiwa14.convex_hulls import SELF_COLLISION_PADDING, link_hulls

DISTANCE_TOLERANCE = 1e-5
"""Subtracted from every fcl hull distance (m), so that a distance is a lower bound."""
SELF_COLLISION_GAP = 2 * SELF_COLLISION_PADDING
"""Two links whose hulls are this close (m) or closer are in collision."""


def _hull_model(vertices: np.ndarray, faces: np.ndarray) -> fcl.Convex:
    counted = np.hstack([np.full((len(faces), 1), 3), faces]).ravel()
    return fcl.Convex(vertices, len(faces), counted)


@functools.lru_cache(maxsize=1)
def hull_models() -> tuple[fcl.Convex, ...]:
    """Each link's convex hull as fcl geometry, built once per process.

    The geometry never changes; every `LinkHulls` wraps it in collision objects of its own,
    which carry the poses.
    """
    return tuple(_hull_model(vertices, faces) for vertices, faces in link_hulls())


@functools.lru_cache(maxsize=1)
def _bounding_spheres() -> tuple[np.ndarray, np.ndarray]:
    """Each hull's bounding sphere (box center, farthest vertex), for the broad phase.

    ``(8, 3)`` centers and ``(8,)`` radii in the link frames, computed once per process
    (read-only arrays).
    """
    hulls = link_hulls()
    centers = np.array([(v.min(axis=0) + v.max(axis=0)) / 2 for v, _ in hulls])
    radii = np.array([np.linalg.norm(v - c, axis=1).max() for (v, _), c in zip(hulls, centers)])
    centers.setflags(write=False)
    radii.setflags(write=False)
    return centers, radii


def _transform(pose: np.ndarray) -> fcl.Transform:
    return fcl.Transform(np.ascontiguousarray(pose[:3, :3]), np.ascontiguousarray(pose[:3, 3]))


class LinkHulls:
    """The links' convex hulls as fcl objects, and padded distances between link pairs.

    Args:
        pairs: ``(P, 2)`` link indices (0 is the base) of the pairs to test.

    Example:
        >>> hulls = LinkHulls(np.array([[5, 7]]))
        >>> hulls.colliding(forward_kinematics(np.zeros(7))[0])
        array([False])
    """

    def __init__(self, pairs: np.ndarray) -> None:
        self.pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
        self._objects = [fcl.CollisionObject(model, fcl.Transform()) for model in hull_models()]
        self._sphere_centers, self._sphere_radii = _bounding_spheres()
        self._request = fcl.DistanceRequest()

    def sphere_gaps(self, poses: np.ndarray) -> np.ndarray:
        """``(..., P)`` distances between the pairs' bounding spheres, for poses ``(..., 8, 4, 4)``.

        Lower bounds on the hull distances; negative where the spheres overlap.
        """
        centers = np.einsum("...jik,jk->...ji", poses[..., :3, :3], self._sphere_centers)
        centers = centers + poses[..., :3, 3]
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        between = np.linalg.norm(centers[..., a, :] - centers[..., b, :], axis=-1)
        return between - self._sphere_radii[a] - self._sphere_radii[b]

    def distance(self, poses: np.ndarray, a: int, b: int) -> float:
        """A lower bound on the distance between the hulls of links ``a`` and ``b`` (0 if touching).

        ``poses`` is ``(8, 4, 4)``, the world poses of the links in one configuration.
        """
        self._objects[a].setTransform(_transform(poses[a]))
        self._objects[b].setTransform(_transform(poses[b]))
        found = fcl.distance(self._objects[a], self._objects[b], self._request,
                             fcl.DistanceResult())  # fmt: skip
        return max(found - DISTANCE_TOLERANCE, 0.0)

    def colliding(self, poses: np.ndarray) -> np.ndarray:
        """``bool[P]``: which pairs are in collision (padded hulls touch) in one configuration."""
        out = np.zeros(len(self.pairs), dtype=bool)
        for p in np.flatnonzero(self.sphere_gaps(poses) <= SELF_COLLISION_GAP):
            a, b = self.pairs[p]
            out[p] = self.distance(poses, a, b) <= SELF_COLLISION_GAP
        return out

    def clearances(self, poses: np.ndarray, exact_below: float) -> np.ndarray:
        """``(P,)`` lower bounds on each pair's padded distance (<= 0: in collision).

        Pairs whose bounding spheres are at least ``exact_below`` apart get that cheaper
        bound; the others get fcl's hull distance.
        """
        clearance = self.sphere_gaps(poses) - SELF_COLLISION_GAP
        for p in np.flatnonzero(clearance < exact_below):
            clearance[p] = self.pair_clearance(poses, p, clearance[p], exact_below)
        return clearance

    def pair_clearance(
        self, poses: np.ndarray, p: int, sphere_clearance: float, exact_below: float
    ) -> float:
        """Pair ``p``'s entry of `clearances`, given its padded bounding-sphere clearance.

        For callers that measure pairs one at a time (the exact checker's lazy step).
        """
        if sphere_clearance >= exact_below:
            return float(sphere_clearance)
        a, b = self.pairs[p]
        return self.distance(poses, a, b) - SELF_COLLISION_GAP


__all__ = ["DISTANCE_TOLERANCE", "SELF_COLLISION_GAP", "LinkHulls", "hull_models"]
