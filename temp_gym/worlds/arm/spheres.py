"""Spheres that cover an arm's convex pieces and bulge out of them by at most a tolerance.

The fast checker tests spheres instead of meshes. Its spheres must **cover** every convex
piece of a body (so a state it calls free is free), and should **bulge** little past the
piece (so a state near a surface is not refused for nothing). A sphere whose center lies at
depth ``delta`` inside a convex piece and whose radius is ``delta + tolerance`` pokes out of
the piece by at most ``tolerance``: every point of it is within ``tolerance`` of the ball of
radius ``delta`` around its center, which the piece contains. `fit_piece` picks such spheres
and proves that they cover the piece:

1. **Shell.** The surface is cut into small triangles; from each one's centroid a center is
   pushed along the inward normal as deep as the bulge rule lets a sphere there still hold
   the centroid. Deep centers hold wide patches. Greedily, deepest first, a candidate is taken
   whenever its centroid is not yet held.
2. **Core.** Points of a grid inside the piece are held the same way, by spheres centred on
   them with the bulge rule's radius, the deepest first.
3. **Proof.** An octree of cubes over the piece's bounding box is refined until every cube
   is either outside the piece, or such that its part inside the piece (bounded by the
   cube and the supporting plane nearest the cube's center, a convex polytope) lies in one
   sphere: a ball holds a convex polytope when it holds its corners. A cube still unproven at
   the smallest size (half the tolerance) grows the sphere that needs the least growth to
   hold it, up to a bulge of 1.5 tolerances, or else gets a small sphere of its own. So every
   point of the piece, not just samples, is inside a sphere; `FittedSpheres.bulge` reports how far
   the farthest one reaches out of the piece.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from scipy.spatial import ConvexHull, cKDTree

MARGIN = 1e-6
"""Added to every radius: absorbs floating-point error in the cover."""
_NEAREST = 16
"""Spheres tried per cube of the proof: those with the nearest centers."""
_CUBE_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
_CUBE_EDGES = np.array(
    [(a, b) for a in range(8) for b in range(a + 1, 8)
     if np.sum(np.abs(_CUBE_CORNERS[a] - _CUBE_CORNERS[b])) == 2]
)  # fmt: skip


@dataclass(frozen=True)
class FittedSpheres:
    """Spheres covering one convex piece.

    ``centers (K, 3)``, ``radii (K,)`` and the largest distance (m) any sphere reaches past
    the piece, ``bulge``.
    """

    centers: np.ndarray
    radii: np.ndarray
    bulge: float


def hull_planes(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(hull vertices, faces, planes)`` of the convex hull.

    ``planes`` rows are ``(n, d)`` with ``n . x + d <= 0`` inside and ``|n| = 1``. A flat point
    set is thickened by 1e-5 m.
    """
    points = np.asarray(vertices, dtype=np.float64)
    try:
        hull = ConvexHull(points)
    except Exception:  # flat or degenerate: Qhull refuses it
        points = (points[:, None, :] + 1e-5 * _CUBE_CORNERS[None]).reshape(-1, 3)
        hull = ConvexHull(points)
    corners = points[hull.vertices]
    index = np.full(len(points), -1, dtype=np.int64)
    index[hull.vertices] = np.arange(len(hull.vertices))
    faces = index[hull.simplices]
    a, b, c = corners[faces[:, 0]], corners[faces[:, 1]], corners[faces[:, 2]]
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), hull.equations[:, :3]) < 0
    faces[inward] = faces[inward][:, ::-1]
    return corners, faces, hull.equations.copy()


@numba.njit(cache=True, nogil=True)
def _signed_depth(points, planes, out, which):
    for i in range(points.shape[0]):
        best = -np.inf
        index = 0
        x, y, z = points[i, 0], points[i, 1], points[i, 2]
        for f in range(planes.shape[0]):
            value = planes[f, 0] * x + planes[f, 1] * y + planes[f, 2] * z + planes[f, 3]
            if value > best:
                best = value
                index = f
        out[i] = -best
        which[i] = index


def signed_depth(points: np.ndarray, planes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(depth, plane)``: each point's distance to the boundary and the plane nearest it.

    The depth is negative outside (then a lower bound on the distance to the piece);
    1-Lipschitz.
    """
    points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    out = np.empty(len(points))
    which = np.empty(len(points), dtype=np.int64)
    _signed_depth(points, np.ascontiguousarray(planes, dtype=np.float64), out, which)
    return out, which


def depth(points: np.ndarray, planes: np.ndarray) -> np.ndarray:
    """`signed_depth` without the planes."""
    return signed_depth(points, planes)[0]


def subdivide(vertices: np.ndarray, faces: np.ndarray, max_edge: float) -> np.ndarray:
    """Bisect triangles at their longest edge until every edge is at most ``max_edge``.

    Returns ``(T, 3, 3)`` corners. Bisection (rather than 1-to-4 splits) cuts a thin sliver
    along its length only, so a hull's slivers do not turn into thousands of specks.
    """
    triangles = vertices[faces]
    done = []
    while len(triangles):
        edges = np.linalg.norm(triangles - np.roll(triangles, -1, axis=1), axis=2)
        longest = np.argmax(edges, axis=1)
        small = edges.max(axis=1) <= max_edge
        done.append(triangles[small])
        big, longest = triangles[~small], longest[~small]
        rows = np.arange(len(big))
        a = big[rows, longest]  # edge k runs from corner k to corner k + 1
        b = big[rows, (longest + 1) % 3]
        c = big[rows, (longest + 2) % 3]
        middle = (a + b) / 2
        triangles = np.concatenate([np.stack([a, middle, c], axis=1),
                                    np.stack([middle, b, c], axis=1)])  # fmt: skip
    return np.concatenate(done)


def _greedy(points: np.ndarray, centers: np.ndarray, radii: np.ndarray,
            held: np.ndarray, stride: int = 1) -> list[int]:  # fmt: skip
    """A small cover of ``points`` by candidate spheres ``(centers, radii)``.

    Candidate ``i`` is made for ``points[i]``: greedy set cover (the candidate holding the most
    points not yet held first), over every ``stride``-th candidate, then over the candidates of
    the points still unheld (each holds its own point). ``held`` is updated.
    """
    import heapq

    tree = cKDTree(points)
    chosen = []
    for pool in (np.arange(0, len(points), stride), None):
        if pool is None:  # second round: the candidates of the points still unheld
            pool = np.flatnonzero(~held)
        members = tree.query_ball_point(centers[pool], radii[pool] * (1 + 1e-9) + 1e-12)
        members = [np.asarray(m, dtype=np.int64) for m in members]
        heap = [(-int(np.sum(~held[m])), k) for k, m in enumerate(members)]
        heapq.heapify(heap)
        while heap:
            count, k = heapq.heappop(heap)
            fresh = members[k][~held[members[k]]]
            if len(fresh) == 0:
                continue
            if len(fresh) < -count and heap and len(fresh) < -heap[0][0]:
                heapq.heappush(heap, (-len(fresh), k))  # stale count: look again later
                continue
            chosen.append(int(pool[k]))
            held[fresh] = True
    return chosen


def _deepest_centers(samples: np.ndarray, normals: np.ndarray, planes: np.ndarray,
                     tolerance: float, deepest: float) -> np.ndarray:  # fmt: skip
    """Per sample, the deepest center along its inward normal that still holds it.

    The bulge rule's sphere there (radius: its depth plus ``tolerance``) holds the sample;
    bisection on the depth.
    """
    low = np.zeros(len(samples))
    high = np.full(len(samples), deepest)
    for _ in range(12):
        middle = (low + high) / 2
        ok = depth(samples - normals * middle[:, None], planes) + tolerance >= middle
        low = np.where(ok, middle, low)
        high = np.where(ok, high, middle)
    return samples - normals * low[:, None]


def _clipped_corners(centers: np.ndarray, half: float, planes: np.ndarray,
                     plane: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Corners ``(C, 20, 3)`` and mask of each cube cut by its plane ``n . x + d <= 0``.

    The cut polytope's corners are the cube's corners on the inner side and the points
    where cube edges cross the plane.
    """
    corners = centers[:, None, :] + half * _CUBE_CORNERS[None]
    n, d = planes[plane, :3], planes[plane, 3]
    side = np.einsum("ckj,cj->ck", corners, n) + d[:, None]
    inner = side <= 0
    a, b = _CUBE_EDGES[:, 0], _CUBE_EDGES[:, 1]
    sa, sb = side[:, a], side[:, b]
    crossing = (sa > 0) != (sb > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(crossing, sa / (sa - sb), 0.0)
    cuts = corners[:, a] + t[..., None] * (corners[:, b] - corners[:, a])
    return np.concatenate([corners, cuts], axis=1), np.concatenate([inner, crossing], axis=1)


def _best_spheres(points: np.ndarray, mask: np.ndarray, middle: np.ndarray, reach: float,
                  tree: cKDTree, centers: np.ndarray,
                  radii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Per cell, the sphere that needs the least growth to hold its masked ``points``.

    Returns it and that growth (<= 0: held). Only spheres that reach the cell's bounding ball
    can hold it.
    """
    growth = np.full(len(middle), np.inf)
    best = np.zeros(len(middle), dtype=np.int64)
    largest = float(radii.max()) + reach
    for first in range(0, len(middle), 512):
        rows = np.arange(first, min(first + 512, len(middle)))
        lists = tree.query_ball_point(middle[rows], largest)
        counts = np.array([len(near) for near in lists])
        cell = np.repeat(rows, counts)
        sphere = np.fromiter((k for near in lists for k in near), dtype=np.int64,
                             count=int(counts.sum()))  # fmt: skip
        close = np.linalg.norm(centers[sphere] - middle[cell], axis=1) <= radii[sphere] + reach
        cell, sphere = cell[close], sphere[close]
        if len(cell) == 0:
            continue
        distances = np.linalg.norm(points[cell] - centers[sphere][:, None, :], axis=2)
        need = np.where(mask[cell], distances, 0.0).max(axis=1) - radii[sphere]
        order = np.lexsort((need, cell))  # per cell, least need first
        cell, sphere, need = cell[order], sphere[order], need[order]
        first_of = np.r_[True, cell[1:] != cell[:-1]]
        growth[cell[first_of]] = need[first_of]
        best[cell[first_of]] = sphere[first_of]
    lost = ~np.isfinite(growth)  # no sphere reaches the cell: the nearest grows
    if lost.any():
        _, nearest = tree.query(middle[lost])
        distances = np.linalg.norm(points[lost] - centers[nearest][:, None, :], axis=2)
        growth[lost] = np.where(mask[lost], distances, 0.0).max(axis=1) - radii[nearest]
        best[lost] = nearest
    return best, growth


def prove_cover(planes: np.ndarray, lower: np.ndarray, upper: np.ndarray, centers: np.ndarray,
                radii: np.ndarray, min_size: float,
                max_bulge: float) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The spheres, grown or added where needed, such that they hold the whole piece (step 3).

    A cube still unproven at ``min_size`` grows the sphere that needs the least growth to
    hold it, if that sphere then bulges at most ``max_bulge`` out of the piece; otherwise it
    gets a sphere of its own (centred on it, its half-diagonal in radius), which bulges out
    of the piece by less than the cube's size.
    """
    radii = radii.astype(np.float64).copy()
    tree = cKDTree(centers)
    size = float(np.max(upper - lower)) / 4
    steps = np.ceil((upper - lower) / size).astype(int)
    grid = np.stack(np.meshgrid(*[np.arange(s) for s in steps], indexing="ij"), -1).reshape(-1, 3)
    pending = lower + (grid + 0.5) * size
    added = [np.zeros((0, 3))]
    added_radii = [np.zeros(0)]
    while len(pending):
        half = size / 2
        reach = half * np.sqrt(3.0)
        cube_depth, plane = signed_depth(pending, planes)
        inside = cube_depth >= -reach
        pending, plane = pending[inside], plane[inside]
        points, mask = _clipped_corners(pending, half, planes, plane)
        sphere, growth = _best_spheres(points, mask, pending, reach, tree, centers, radii)
        failed = growth > 0
        if size <= min_size:
            # Grow a sphere where that keeps it within the bulge allowed, else add one.
            sphere, growth = sphere[failed], growth[failed]
            cubes = pending[failed]
            allowed = max_bulge - (radii[sphere] - depth(centers[sphere], planes))
            grow = growth <= allowed
            np.maximum.at(radii, sphere[grow], radii[sphere[grow]] + growth[grow])
            added.append(cubes[~grow])
            added_radii.append(np.full(int(np.sum(~grow)), reach))
            break
        size /= 2
        pending = (pending[failed][:, None, :] + (size / 2) * _CUBE_CORNERS[None]).reshape(-1, 3)
    return np.concatenate([centers, *added]), np.concatenate([radii, *added_radii])


def fit_piece(vertices: np.ndarray, tolerance: float) -> FittedSpheres:
    """Spheres covering the solid convex hull of ``vertices``.

    They bulge at most about ``tolerance`` (module docstring). Deterministic.
    """
    corners, faces, planes = hull_planes(vertices)
    lower, upper = corners.min(axis=0), corners.max(axis=0)
    centroid = corners.mean(axis=0)
    deepest = max(float(depth(centroid[None], planes)[0]), tolerance)
    # 1. Shell.
    triangles = subdivide(corners, faces, 2.0 * tolerance)
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
    points = np.concatenate([triangles.mean(axis=1), triangles.reshape(-1, 3)])
    point_normals = np.concatenate([normals, np.repeat(normals, 3, axis=0)])
    points, first = np.unique(points.round(12), axis=0, return_index=True)
    point_normals = point_normals[first]
    pushed = _deepest_centers(points, point_normals, planes, tolerance, deepest)
    pushed_radii = np.maximum(depth(pushed, planes), 0.0) + tolerance
    held = np.zeros(len(points), dtype=bool)
    chosen = _greedy(points, pushed, pushed_radii, held, stride=max(1, len(points) // 12_000))
    centers, radii = pushed[chosen], pushed_radii[chosen]
    # 2. Core.
    step = max(deepest / 3, tolerance)
    axes = [np.arange(lo + step / 2, hi, step) for lo, hi in zip(lower, upper)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    grid = np.concatenate([grid[depth(grid, planes) > 0], centroid[None]])
    grid_radii = depth(grid, planes) + tolerance
    # A grid point held with half a cell diagonal to spare holds its whole cell.
    spare = step * np.sqrt(3.0) / 2
    held = np.zeros(len(grid), dtype=bool)
    tree = cKDTree(grid)
    for c, r in zip(centers, radii):
        held[tree.query_ball_point(c, max(r - spare, 0.0))] = True
    chosen = _greedy(grid, grid, np.maximum(grid_radii - spare, 0.0), held)
    centers = np.concatenate([centers, grid[chosen]])
    radii = np.concatenate([radii, grid_radii[chosen]])
    # 3. Proof.
    centers, radii = prove_cover(planes, lower - 1e-9, upper + 1e-9, centers, radii,
                                 tolerance / 2, 1.5 * tolerance)  # fmt: skip
    radii = radii + MARGIN
    bulge = float(np.max(radii - depth(centers, planes)))
    return FittedSpheres(centers, radii, bulge)


__all__ = ["MARGIN", "FittedSpheres", "depth", "fit_piece", "hull_planes", "prove_cover",
           "signed_depth", "subdivide"]  # fmt: skip
