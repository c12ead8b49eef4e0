"""Near a surface, the fast arm checker asks a body's convex pieces, not its spheres.

A leaf sphere may bulge out of the piece it covers by up to the robot's sphere tolerance
(`temp_gym.worlds.arm.spheres`), so by the spheres alone a link a millimetre from a table
touches it. When every leaf of a body that touches an obstacle touches it by less than that
bulge (the leaf shrunk by the bulge misses it: `arm_fast_obstacles.tree_hits`), the touch may
be the bulge's, and `pieces_clear` decides: each of the body's convex pieces against the
obstacle.

**A certificate, not an estimate.** For any direction ``u``, a piece ``A`` and an obstacle
``B`` are at least ``min_a u.a - max_b u.b`` apart (a separating plane). GJK (Gilbert, Johnson
and Keerthi) on the Minkowski difference ``A - B`` finds a good ``u``; the bound is then
evaluated with the supports themselves: the piece's corners placed by the same forward
kinematics as the spheres, and the obstacle's exact support (box, cylinder or sphere). A body
is clear only when that bound exceeds the growth asked (an edge interval's motion, or a
clearance) plus `HULL_SLACK`; a degenerate simplex or an exhausted iteration budget leaves the
touch a collision. So the answer stays conservative, whatever GJK's rounding: the pieces hold
the link meshes that the exact checker tests.
"""

from __future__ import annotations

import math

import numpy as np

from temp_gym.problem.obstacles import CYLINDER, SPHERE
from temp_gym.worlds.arm.kinematics import FAST_FK_MARGIN, place
from temp_gym.worlds.arm.model import ArmModel
from temp_gym.worlds.hot_path import hot_inline, hot_path

HULL_SLACK = 2 * FAST_FK_MARGIN + 1e-9
"""Added to the growth a piece must clear (m): the fast kinematics' error and rounding."""
GJK_ITERATIONS = 48
"""GJK steps per piece before a touch is left a collision."""
GJK_GAP = 1e-7
"""GJK stops when its upper and lower bounds on the distance are this close (m)."""
BULGE_FACTOR = 1.5
"""A leaf bulges out of its piece by at most this many sphere tolerances (the fit's rule)."""


def _corner_graph(faces: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """``(start, neighbors)``: each hull corner's neighbours along the hull's edges (CSR)."""
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    edges = np.unique(np.concatenate([edges, edges[:, ::-1]]), axis=0)
    start = np.searchsorted(edges[:, 0], np.arange(count + 1)).astype(np.int64)
    return start, edges[:, 1].astype(np.int64)


def hull_arrays(arm: ArmModel, enabled: bool = True) -> tuple[np.ndarray, ...]:
    """``(corners, piece_start, body_pieces, bulge, neighbor_start, neighbors)`` (cached).

    ``corners`` (V, 3) are the convex pieces' hull corners in their body's frame; piece ``p``
    owns rows ``piece_start[p]:piece_start[p + 1]`` and body ``j`` pieces
    ``body_pieces[j]:body_pieces[j + 1]``. ``bulge[0]`` is how far a leaf sphere may reach
    beyond its piece; disabled, it is -1 and every touch stays a collision. Corner ``k``'s
    neighbours along the hull's edges are ``neighbors[neighbor_start[k]:neighbor_start[k + 1]]``
    (row numbers of ``corners``): the support walks them.
    """
    from temp_gym.worlds.arm.spheres import hull_planes

    key = "fast_hulls"
    if key not in arm._arrays:
        corners, piece_sizes, body_sizes, starts, neighbors = [], [], [], [], []
        offset = 0
        for geometry in arm.geometry:
            for piece in geometry.pieces:
                points, faces, _ = hull_planes(piece)
                start, around = _corner_graph(faces, len(points))
                corners.append(points)
                starts.append(start[:-1] + sum(len(n) for n in neighbors))
                neighbors.append(around + offset)
                piece_sizes.append(len(points))
                offset += len(points)
            body_sizes.append(len(geometry.pieces))
        tolerance = float(arm.derived_data()["spheres"]["tolerance"])
        edge_count = sum(len(n) for n in neighbors)
        arrays = (np.ascontiguousarray(np.concatenate(corners) if corners else np.zeros((0, 3))),
                  np.cumsum([0, *piece_sizes]).astype(np.int64),
                  np.cumsum([0, *body_sizes]).astype(np.int64),
                  np.array([BULGE_FACTOR * tolerance + HULL_SLACK]),
                  np.concatenate([*starts, [edge_count]]).astype(np.int64),
                  np.concatenate([*neighbors, np.zeros(0, dtype=np.int64)]))  # fmt: skip
        for array in arrays:
            array.setflags(write=False)
        arm._arrays[key] = arrays
    arrays = arm._arrays[key]
    if enabled:
        return arrays
    off = np.array([-1.0])
    off.setflags(write=False)  # the same array types: no second compilation
    return (*arrays[:3], off, *arrays[4:])


@hot_inline
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@hot_inline
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@hot_inline
def _along(a, d, t):
    """``a + t d``."""
    return (a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2])


@hot_inline
def _piece_lowest(poses, j, corners, neighbor_start, neighbors, k, v):
    """``(corner, row)``: the hull corner of a piece, in the world, least along ``v``.

    A walk from corner ``k`` along the hull's edges to a neighbour lower along ``v``, until
    none is: a linear function's local minimum on a convex polytope is its minimum (the
    simplex method's argument), so the walk visits a few corners, not all.
    """
    # v in the body frame: R^T v, so one dot product per corner.
    lx = poses[j, 0, 0] * v[0] + poses[j, 1, 0] * v[1] + poses[j, 2, 0] * v[2]
    ly = poses[j, 0, 1] * v[0] + poses[j, 1, 1] * v[1] + poses[j, 2, 1] * v[2]
    lz = poses[j, 0, 2] * v[0] + poses[j, 1, 2] * v[1] + poses[j, 2, 2] * v[2]
    best = lx * corners[k, 0] + ly * corners[k, 1] + lz * corners[k, 2]
    while True:
        step = k
        for e in range(neighbor_start[k], neighbor_start[k + 1]):
            m = neighbors[e]
            value = lx * corners[m, 0] + ly * corners[m, 1] + lz * corners[m, 2]
            if value < best:
                best = value
                step = m
        if step == k:
            return place(poses, j, corners, k), k
        k = step


@hot_inline
def _piece_least(poses, j, corners, first, last, v):
    """``min_a v.a`` over every corner of the piece, in the world: the walk's answer, checked."""
    lx = poses[j, 0, 0] * v[0] + poses[j, 1, 0] * v[1] + poses[j, 2, 0] * v[2]
    ly = poses[j, 0, 1] * v[0] + poses[j, 1, 1] * v[1] + poses[j, 2, 1] * v[2]
    lz = poses[j, 0, 2] * v[0] + poses[j, 1, 2] * v[1] + poses[j, 2, 2] * v[2]
    best = np.inf
    for k in range(first, last):
        best = min(best, lx * corners[k, 0] + ly * corners[k, 1] + lz * corners[k, 2])
    return best + v[0] * poses[j, 0, 3] + v[1] * poses[j, 1, 3] + v[2] * poses[j, 2, 3]


@hot_inline
def _obstacle_highest(tables, b, any_kind, v):
    """The point of obstacle ``b`` farthest along ``v`` (a box corner, a rim or cap point)."""
    if not any_kind:
        box = tables[0]
        return (box[b, 0] + math.copysign(box[b, 3], v[0]),
                box[b, 1] + math.copysign(box[b, 4], v[1]),
                box[b, 2] + math.copysign(box[b, 5], v[2]))  # fmt: skip
    s = tables[1]
    kind = s[b, 6]
    if kind == SPHERE:
        norm = math.sqrt(_dot(v, v))
        scale = s[b, 3] / norm if norm > 0.0 else 0.0
        return (s[b, 0] + scale * v[0], s[b, 1] + scale * v[1], s[b, 2] + scale * v[2])
    # v in the obstacle's frame, R^T v; R's rows are columns 7-9, 10-12, 13-15.
    lx = s[b, 7] * v[0] + s[b, 10] * v[1] + s[b, 13] * v[2]
    ly = s[b, 8] * v[0] + s[b, 11] * v[1] + s[b, 14] * v[2]
    lz = s[b, 9] * v[0] + s[b, 12] * v[1] + s[b, 15] * v[2]
    if kind == CYLINDER:
        radial = math.sqrt(lx * lx + ly * ly)
        scale = s[b, 3] / radial if radial > 0.0 else 0.0
        px, py, pz = scale * lx, scale * ly, math.copysign(s[b, 5], lz)
    else:
        px = math.copysign(s[b, 3], lx)
        py = math.copysign(s[b, 4], ly)
        pz = math.copysign(s[b, 5], lz)
    return (s[b, 0] + s[b, 7] * px + s[b, 8] * py + s[b, 9] * pz,
            s[b, 1] + s[b, 10] * px + s[b, 11] * py + s[b, 12] * pz,
            s[b, 2] + s[b, 13] * px + s[b, 14] * py + s[b, 15] * pz)  # fmt: skip


@hot_inline
def _closest_segment(a, b):
    """The point of segment ``ab`` nearest the origin, and the weights of ``a`` and ``b``."""
    d = _sub(b, a)
    length = _dot(d, d)
    t = 0.0 if length <= 0.0 else min(max(-_dot(a, d) / length, 0.0), 1.0)
    return _along(a, d, t), 1.0 - t, t


@hot_inline
def _closest_triangle(a, b, c):
    """The point of triangle ``abc`` nearest the origin, and its barycentric weights.

    Voronoi regions of the vertices, then the edges, then the face (Ericson, Real-Time
    Collision Detection, 5.1.5), for the query point at the origin.
    """
    ab, ac = _sub(b, a), _sub(c, a)
    d1, d2 = -_dot(ab, a), -_dot(ac, a)
    if d1 <= 0.0 and d2 <= 0.0:
        return a, 1.0, 0.0, 0.0
    d3, d4 = -_dot(ab, b), -_dot(ac, b)
    if d3 >= 0.0 and d4 <= d3:
        return b, 0.0, 1.0, 0.0
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        t = d1 / (d1 - d3)
        return _along(a, ab, t), 1.0 - t, t, 0.0
    d5, d6 = -_dot(ab, c), -_dot(ac, c)
    if d6 >= 0.0 and d5 <= d6:
        return c, 0.0, 0.0, 1.0
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        t = d2 / (d2 - d6)
        return _along(a, ac, t), 1.0 - t, 0.0, t
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return _along(b, _sub(c, b), t), 0.0, 1.0 - t, t
    total = va + vb + vc
    if not total > 0.0:  # degenerate: the caller stops
        return a, 1.0, 0.0, 0.0
    v, w = vb / total, vc / total
    return _along(_along(a, ab, v), ac, w), 1.0 - v - w, v, w


@hot_inline
def _outside(a, b, c, d) -> bool:
    """Whether the origin and ``d`` lie strictly on opposite sides of plane ``abc``."""
    ab, ac = _sub(b, a), _sub(c, a)
    n = (ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2],
         ab[0] * ac[1] - ab[1] * ac[0])  # fmt: skip
    return -_dot(n, a) * _dot(n, _sub(d, a)) < 0.0


@hot_path
def _piece_clear(poses, j, corners, neighbor_start, neighbors, first, last, tables, b,
                 any_kind, clearance) -> bool:  # fmt: skip
    """Whether a piece of body ``j`` is farther than ``clearance`` from obstacle ``b``.

    The piece's corners are rows ``first:last``. The answer is certified by a separating
    direction (module docstring): GJK's supports come from the walk, and the bound that
    clears the piece is evaluated once more over every corner.
    """
    # The simplex: up to four points of the Minkowski difference (piece minus obstacle).
    anchor = place(poses, j, corners, first)
    far = _obstacle_highest(tables, b, any_kind, (0.0, 0.0, 1.0))
    p0 = _sub(anchor, far)
    p1 = p2 = p3 = p0
    count = 1
    v = p0
    k = first  # the walk's corner, kept from one support to the next
    for _ in range(GJK_ITERATIONS):
        norm = math.sqrt(_dot(v, v))
        if norm <= clearance:  # v is a point of the difference: the distance is at most |v|
            return False
        # The support of the difference least along v: the separating plane's bound.
        lowest, k = _piece_lowest(poses, j, corners, neighbor_start, neighbors, k, v)
        top = _obstacle_highest(tables, b, any_kind, v)
        w = _sub(lowest, top)
        lower = _dot(v, w) / norm
        if lower > clearance:
            # The certificate rests on the true least corner, not on the walk's.
            return (_piece_least(poses, j, corners, first, last, v) - _dot(v, top)) / norm > (
                clearance)  # fmt: skip
        if norm - lower <= GJK_GAP:
            return False
        if count == 1:
            v, wa, wb = _closest_segment(p0, w)
            p1 = w
            count = 2
            weights = (wa, wb, 0.0, 0.0)
        elif count == 2:
            v, wa, wb, wc = _closest_triangle(p0, p1, w)
            p2 = w
            count = 3
            weights = (wa, wb, wc, 0.0)
        else:
            p3 = w
            # The tetrahedron: the nearest of the faces the origin lies outside of.
            best = np.inf
            weights = (0.0, 0.0, 0.0, 0.0)
            if _outside(p0, p1, p2, p3):
                point, wa, wb, wc = _closest_triangle(p0, p1, p2)
                if _dot(point, point) < best:
                    best, v, weights = _dot(point, point), point, (wa, wb, wc, 0.0)
            if _outside(p0, p1, p3, p2):
                point, wa, wb, wc = _closest_triangle(p0, p1, p3)
                if _dot(point, point) < best:
                    best, v, weights = _dot(point, point), point, (wa, wb, 0.0, wc)
            if _outside(p0, p2, p3, p1):
                point, wa, wb, wc = _closest_triangle(p0, p2, p3)
                if _dot(point, point) < best:
                    best, v, weights = _dot(point, point), point, (wa, 0.0, wb, wc)
            if _outside(p1, p2, p3, p0):
                point, wa, wb, wc = _closest_triangle(p1, p2, p3)
                if _dot(point, point) < best:
                    best, v, weights = _dot(point, point), point, (0.0, wa, wb, wc)
            if best == np.inf:  # the origin is inside (or the tetrahedron is flat)
                return False
            count = 4
        # Keep the points that the nearest point needs.
        kept = 0
        q0 = q1 = q2 = q3 = p0
        for slot in range(count):
            if weights[slot] > 0.0:
                point = p0 if slot == 0 else (p1 if slot == 1 else (p2 if slot == 2 else p3))
                if kept == 0:
                    q0 = point
                elif kept == 1:
                    q1 = point
                elif kept == 2:
                    q2 = point
                else:
                    q3 = point
                kept += 1
        if kept == 0:
            return False
        p0, p1, p2, p3, count = q0, q1, q2, q3, kept
    return False


@hot_path
def pieces_clear(poses, j, hulls, tables, b, any_kind, growth) -> bool:
    """Whether every convex piece of body ``j`` is farther than ``growth`` from obstacle ``b``.

    ``hulls`` is `hull_arrays`; a body with no pieces is not cleared.
    """
    corners, piece_start, body_pieces, _, neighbor_start, neighbors = hulls
    if body_pieces[j] == body_pieces[j + 1]:
        return False
    clearance = growth + HULL_SLACK
    for p in range(body_pieces[j], body_pieces[j + 1]):
        if not _piece_clear(poses, j, corners, neighbor_start, neighbors, piece_start[p],
                            piece_start[p + 1], tables, b, any_kind, clearance):  # fmt: skip
            return False
    return True


__all__ = ["BULGE_FACTOR", "GJK_ITERATIONS", "HULL_SLACK", "hull_arrays", "pieces_clear"]
