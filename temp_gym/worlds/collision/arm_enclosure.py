"""Obstacles a link encloses: what fcl's surface tests cannot see.

fcl tests a mesh's *surface* (its triangles) against an obstacle, so an obstacle wholly inside
a link's mesh, touching no triangle, is no collision to it. The exact checker asks this module
whenever fcl finds no contact. An obstacle that touches no triangle is wholly inside the mesh's
solid or wholly outside it, and its center is one of its points (boxes, cylinders and spheres
are symmetric about it), so the question is whether that one point is inside the solid:

* outside the mesh's convex hull (its planes): not enclosed, the common answer, at once;
* inside the hull: enclosed where the mesh's generalized winding number
  there (the solid angle its triangles subtend, over 4 pi) is above one half in size. It is
  1 inside a closed mesh and 0 outside, and degrades gracefully over the small holes and
  inconsistent windings of meshes that are not closed, as many URDF meshes are not
  (Jacobson et al., "Robust inside-outside segmentation using generalized winding numbers",
  SIGGRAPH 2013).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from temp_gym.worlds.arm.model import ArmModel

PLANE_TOLERANCE = 1e-12
"""Slack (m) of the hull's planes: a point on the hull counts as inside."""


@dataclass(frozen=True)
class MeshSolid:
    """A link mesh's solid as the enclosure test reads it (module docstring)."""

    planes: np.ndarray
    """``(F, 4)`` hull planes ``(n, d)``: ``n . x + d <= 0`` inside."""
    triangles: np.ndarray
    """``(T, 3, 3)`` the mesh's triangles."""

    def encloses(self, point: np.ndarray) -> bool:
        """Whether ``point`` (in the mesh's frame) is inside the solid (module docstring)."""
        if np.any(self.planes[:, :3] @ point + self.planes[:, 3] > PLANE_TOLERANCE):
            return False
        return abs(winding_number(self.triangles, point)) > 0.5


def winding_number(triangles: np.ndarray, point: np.ndarray) -> float:
    """The generalized winding number of ``triangles`` ``(T, 3, 3)`` at ``point``.

    The sum of the solid angles the triangles subtend there (Van Oosterom and Strackee's
    formula), over 4 pi: 1 inside a closed, outward-wound mesh, 0 outside it.
    """
    a, b, c = (triangles[:, k] - point for k in range(3))
    la, lb, lc = (np.sqrt(np.einsum("ij,ij->i", v, v)) for v in (a, b, c))
    det = np.einsum("ij,ij->i", a, np.cross(b, c))
    div = (la * lb * lc + np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", b, c) * la
           + np.einsum("ij,ij->i", c, a) * lb)  # fmt: skip
    return float(np.sum(np.arctan2(det, div)) / (2 * np.pi))


def mesh_solid(vertices: np.ndarray, faces: np.ndarray) -> MeshSolid:
    """The `MeshSolid` of one mesh ``(vertices (V, 3), faces (F, 3))``."""
    from temp_gym.worlds.arm.spheres import hull_planes

    vertices = np.asarray(vertices, dtype=np.float64)
    _, _, planes = hull_planes(vertices)
    triangles = np.ascontiguousarray(vertices[np.asarray(faces)], dtype=np.float64)
    for array in (planes, triangles):
        array.setflags(write=False)
    return MeshSolid(planes, triangles)


def mesh_solids(arm: ArmModel) -> tuple[tuple[MeshSolid, ...], ...]:
    """Per body, the `MeshSolid` of each of its mesh elements (cached on the arm).

    Primitive elements are fcl's solid shapes and need none.
    """
    key = "mesh_solids"
    if key not in arm._arrays:
        arm._arrays[key] = tuple(
            tuple(
                mesh_solid(vertices, faces)
                for (vertices, faces), primitive in zip(geometry.meshes, geometry.primitives)
                if primitive is None
            )  # fmt: skip
            for geometry in arm.geometry
        )
    return arm._arrays[key]


def encloses(solids: tuple[MeshSolid, ...], pose: np.ndarray, point: np.ndarray) -> bool:
    """Whether a body posed at ``pose`` (4x4) holds the world ``point`` inside a mesh's solid."""
    if not solids:
        return False
    local = pose[:3, :3].T @ (np.asarray(point, dtype=np.float64) - pose[:3, 3])
    return any(solid.encloses(local) for solid in solids)


__all__ = ["MeshSolid", "encloses", "mesh_solid", "mesh_solids", "winding_number"]
