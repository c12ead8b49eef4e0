"""Obstacles as the pictures draw them: 3D solids of every kind, and their surfaces as polygons.

`Solids` holds a scene's obstacles in 3D (kind, center, half extents in the obstacle's own
frame, rotation, and the world bounding box), which the camera's ray tests
(`temp_gym.worlds.rendering.camera`) and the browser viewer (`temp_gym.viewer`) read. The
polygon functions give the surfaces the matplotlib pictures draw: `outline` a 2D obstacle's
boundary (a rectangle, turned or not, or a disc), `surface` a 3D obstacle's faces (a box's six
quadrilaterals, a cylinder's side strips and two caps, a sphere's latitude-longitude patches).

Curved surfaces are polygons of `CURVE_SEGMENTS` sides around (a disc's outline of
`OUTLINE_SEGMENTS`): fine enough to look round at the pictures' sizes, few enough to draw fast.

Example:
    >>> solids = Solids.of_workspace(problem.workspace)  # a 3D workspace
    >>> polygons = surface(solids.kinds[0], solids.centers[0], solids.half_extents[0],
    ...                    solids.rotations[0])  # a list of (k, 3) faces
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from temp_gym.problem.obstacles import BOX, CYLINDER, SPHERE

if TYPE_CHECKING:
    from temp_gym.problem import Workspace

CURVE_SEGMENTS = 24
"""Facets around a cylinder, and around a sphere's equator (half as many from pole to pole)."""
OUTLINE_SEGMENTS = 72
"""Sides of a disc's outline in a 2D picture."""
_BOX_QUADS = np.array(
    [(0, 2, 6, 4), (1, 3, 7, 5), (0, 1, 5, 4), (2, 3, 7, 6), (0, 1, 3, 2), (4, 5, 7, 6)]
)
"""A box's six faces as corner indices; corner k has bit ``axis`` set on that axis's upper side."""


@dataclass(frozen=True)
class Solids:
    """A scene's obstacles as 3D solids, one row each (`temp_gym.problem.obstacles`' layout).

    ``lower`` and ``upper`` are each obstacle's world bounding box; for an axis-aligned box,
    the box itself (the arrays the pictures drew before there were other kinds, used as they
    are so that such scenes are drawn exactly as before).
    """

    lower: np.ndarray
    """``(M, 3)`` lower corners of the obstacles' axis-aligned bounding boxes."""
    upper: np.ndarray
    """``(M, 3)`` upper corners of the obstacles' axis-aligned bounding boxes."""
    kinds: np.ndarray
    """``(M,)`` `BOX`, `CYLINDER` or `SPHERE`."""
    centers: np.ndarray
    """``(M, 3)`` centers."""
    half_extents: np.ndarray
    """``(M, 3)`` half sides in the obstacle's own frame (a cylinder's ``(r, r, length / 2)``)."""
    rotations: np.ndarray
    """``(M, 3, 3)`` rotations: the obstacle's axes as columns."""

    @classmethod
    def boxes(cls, lower: np.ndarray, upper: np.ndarray) -> Solids:
        """Axis-aligned boxes ``[lower, upper]`` (``(M, 3)`` each)."""
        lower = np.asarray(lower, dtype=np.float64).reshape(-1, 3)
        upper = np.asarray(upper, dtype=np.float64).reshape(-1, 3)
        count = len(lower)
        return cls(
            lower,
            upper,
            np.full(count, BOX, dtype=np.int8),
            (lower + upper) / 2,
            (upper - lower) / 2,
            np.broadcast_to(np.eye(3), (count, 3, 3)).copy(),
        )

    @classmethod
    def of_workspace(cls, workspace: Workspace) -> Solids:
        """The obstacles of a 3D ``workspace``."""
        if workspace.workspace_dim != 3:
            raise ValueError(
                f"workspace: Solids.of_workspace takes a 3D workspace, got {workspace.robot}'s "
                f"{workspace.workspace_dim}D one"
            )
        return cls(
            workspace.obstacle_lower,
            workspace.obstacle_upper,
            workspace.obstacle_kinds,
            workspace.obstacle_centers,
            workspace.obstacle_half_extents,
            workspace.obstacle_rotations,
        )

    def __len__(self) -> int:
        return len(self.kinds)

    @property
    def aligned_boxes(self) -> np.ndarray:
        """``bool[M]``: which obstacles are boxes turned by exactly the identity."""
        return (self.kinds == BOX) & np.all(self.rotations == np.eye(3), axis=(1, 2))


def outline(kind: int, center: np.ndarray, half: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """The boundary ``(K, 2)`` of a 2D obstacle, counter-clockwise: a rectangle or a disc."""
    if kind == SPHERE:
        angles = np.linspace(0.0, 2.0 * np.pi, OUTLINE_SEGMENTS, endpoint=False)
        return center + half[0] * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    local = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]) * half
    return center + local @ rotation.T


def surface(
    kind: int, center: np.ndarray, half: np.ndarray, rotation: np.ndarray
) -> list[np.ndarray]:
    """The faces of a 3D obstacle as polygons ``(k, 3)``.

    A box's are its six quadrilaterals in `box_faces`' order; a cylinder's and a sphere's are
    wound counter-clockwise seen from outside, so a mesh of them (`triangle_mesh`) faces out.
    """
    if kind == BOX:
        signs = np.array(
            [[1.0 if (k >> axis) & 1 else -1.0 for axis in range(3)] for k in range(8)]
        )
        corners = center + (signs * half) @ rotation.T
        return list(corners[_BOX_QUADS])
    if kind == CYLINDER:
        local = _cylinder_polygons(half[0], half[2])
    else:
        local = _sphere_polygons(half[0])
    return [center + polygon @ rotation.T for polygon in local]


def box_faces(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The six quadrilateral faces ``(6, 4, 3)`` of the axis-aligned box ``[lower, upper]``."""
    corners = np.array(
        [[(upper if (k >> axis) & 1 else lower)[axis] for axis in range(3)] for k in range(8)]
    )
    return corners[_BOX_QUADS]


def _circle(radius: float, count: int) -> tuple[np.ndarray, np.ndarray]:
    angles = np.linspace(0.0, 2.0 * np.pi, count, endpoint=False)
    return radius * np.cos(angles), radius * np.sin(angles)


def _cylinder_polygons(radius: float, half_length: float) -> list[np.ndarray]:
    """A cylinder about the origin along z: side strips, then the bottom and top caps."""
    x, y = _circle(radius, CURVE_SEGMENTS)
    bottom = np.stack([x, y, np.full_like(x, -half_length)], axis=1)
    top = np.stack([x, y, np.full_like(x, half_length)], axis=1)
    following = np.roll(np.arange(CURVE_SEGMENTS), -1)
    sides = np.stack([bottom, bottom[following], top[following], top], axis=1)
    return [*sides, bottom[::-1], top]


def _sphere_polygons(radius: float) -> list[np.ndarray]:
    """A sphere about the origin: patches between meridians and parallels, pole triangles."""
    bands = CURVE_SEGMENTS // 2
    longitudes = np.linspace(0.0, 2.0 * np.pi, CURVE_SEGMENTS, endpoint=False)
    latitudes = np.linspace(-np.pi / 2, np.pi / 2, bands + 1)
    rings = radius * np.stack(
        [
            np.cos(latitudes)[:, None] * np.cos(longitudes)[None],
            np.cos(latitudes)[:, None] * np.sin(longitudes)[None],
            np.broadcast_to(np.sin(latitudes)[:, None], (bands + 1, CURVE_SEGMENTS)),
        ],
        axis=2,
    )
    polygons = []
    for band in range(bands):
        for k in range(CURVE_SEGMENTS):
            after = (k + 1) % CURVE_SEGMENTS
            corners = [
                rings[band, k],
                rings[band, after],
                rings[band + 1, after],
                rings[band + 1, k],
            ]
            if band == 0:
                corners = corners[1:]  # the south pole: one point
            elif band == bands - 1:
                corners = corners[:3]  # the north pole: one point
            polygons.append(np.array(corners))
    return polygons


def triangle_mesh(polygons: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Convex ``polygons`` as a mesh ``(vertices (V, 3), faces (F, 3))``.

    Each polygon is fanned from its first corner (its winding kept); corners are not shared
    between polygons, so each facet is shaded flat.
    """
    vertices, faces, offset = [], [], 0
    for polygon in polygons:
        count = len(polygon)
        fan = np.stack([np.zeros(count - 2, int), np.arange(1, count - 1), np.arange(2, count)], 1)
        vertices.append(polygon)
        faces.append(fan + offset)
        offset += count
    return np.concatenate(vertices), np.concatenate(faces)
