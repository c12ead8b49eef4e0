"""Convex hulls of the iiwa's link meshes: the geometry of self-collision.

pybullet (like Bullet in general) collides a URDF's STL meshes as their convex hulls, each
grown by a collision margin of 1 mm. Two links of the iiwa then touch where their meshes do
not: link_5's mesh has a cut-out, and its hull closes it, so with joint 6 near its limits
link_7 enters link_5's hull without touching its mesh (docs/research/collision.md has the
measurements). We check self-collision on the same geometry as pybullet, the hulls grown by
`SELF_COLLISION_PADDING`:

* it is conservative with respect to the meshes (a hull contains its mesh), so a pose we call
  free is free for every other reading of the URDF;
* it is the verdict of the simulator the project renders with and cross-checks against;
* hulls are solids, so containment counts as collision (a mesh-surface test misses it), and
  fcl's GJK distance on them is fast.

The hulls are built here with scipy (Qhull) from the meshes read by
`temp_gym.worlds.iiwa14.kinematics.link_meshes`; obstacles are still checked against the meshes.
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.spatial import ConvexHull

SELF_COLLISION_PADDING = 0.001
"""Every link hull is grown by this much (m) for self-collision: Bullet's default collision
margin for URDF meshes, so that two links collide exactly when pybullet says they touch."""


def convex_hull(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The convex hull of ``vertices`` (V, 3) as ``(hull vertices (H, 3), faces (F, 3))``.

    Faces are triangles ordered counter-clockwise seen from outside (outward normals).
    """
    hull = ConvexHull(vertices)
    corners = vertices[hull.vertices]
    index = np.full(len(vertices), -1, dtype=np.int64)
    index[hull.vertices] = np.arange(len(hull.vertices))
    faces = index[hull.simplices]
    # Qhull's facet equations give outward normals: flip the triangles that point inward.
    a, b, c = corners[faces[:, 0]], corners[faces[:, 1]], corners[faces[:, 2]]
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), hull.equations[:, :3]) < 0
    faces[inward] = faces[inward][:, ::-1]
    return corners, faces


@functools.cache
def link_hulls() -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """The 8 links' convex hulls ``(vertices, faces)`` in their link frames, link_0 first."""
    from temp_gym.worlds.iiwa14.kinematics import link_meshes

    hulls = []
    for vertices, _ in link_meshes():
        corners, faces = convex_hull(vertices)
        corners.setflags(write=False)
        faces.setflags(write=False)
        hulls.append((corners, faces))
    return tuple(hulls)


def hull_tetrahedra(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Tetrahedra ``(F, 4, 3)`` that tile the solid hull: its centroid joined to each face.

    A convex body is the union of the cones from an interior point to its boundary faces, so
    covering these tetrahedra covers the solid, not only its surface.
    """
    center = vertices.mean(axis=0)  # the mean of the hull's vertices lies inside it
    triangles = vertices[faces]
    apex = np.broadcast_to(center, (len(faces), 1, 3))
    return np.concatenate([apex, triangles], axis=1)


__all__ = ["SELF_COLLISION_PADDING", "convex_hull", "hull_tetrahedra", "link_hulls"]
