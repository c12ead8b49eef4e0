"""Compiled forward kinematics of any serial arm whose joints turn or slide about z.

`temp_gym.worlds.arm.urdf` turns every joint's axis into its frame's z, so body ``j + 1``'s
pose is ``body j's pose @ origin[j] @ motion(q[j])``, where the motion turns about z
(revolute) or slides along it (prismatic). The kernels work on 3x4 poses (the last row is
always ``0 0 0 1``) and take the arm as arrays, so one compiled kernel serves every arm:

* ``joint_kind[j]``: 0 revolute, 1 prismatic;
* ``origin_rotation[j]`` (3x3) and ``origin_shift[j]`` (3,).

In the fast checker, sines and cosines come from `sincos_into`, a branch-free polynomial that
LLVM vectorizes over a block of states; it moves points by far less than `FAST_FK_MARGIN`,
which the checker adds to its sphere radii so that conservative tests stay conservative.
"""

from __future__ import annotations

import numba
import numpy as np

from temp_gym.worlds.hot_path import hot_inline, hot_path

FAST_FK_MARGIN = 1e-8
"""Bound (m) on how far the fast-path kinematics (`sincos_into`'s sines) moves any point
within a few metres of the base."""

_PIO2_HI = 1.5707963267341256  # pi/2 to 33 bits: k * _PIO2_HI is exact for small integers k
_PIO2_LO = 6.077100506506192e-11  # pi/2 - _PIO2_HI
_TWO_OVER_PI = 0.6366197723675814


@numba.njit(cache=True, nogil=True, inline="always")
def _sincos(x):
    """``(sin x, cos x)`` for finite ``|x| < 1e6``, branch-free so that loops vectorize.

    Reduces to ``r = x - k pi/2`` with ``|r| <= pi/4`` and sums Taylor series to ``r**15`` and
    ``r**16``; the truncation error is below ``(pi/4)**17 / 17! < 5e-17``, so with rounding the
    result is within a few 1e-16 of the true value. NaN or inf give garbage, never a fault.
    """
    k = np.floor(x * _TWO_OVER_PI + 0.5)
    r = (x - k * _PIO2_HI) - k * _PIO2_LO
    r2 = r * r
    sin_r = r + r * r2 * (
        -1.0 / 6.0
        + r2 * (1.0 / 120.0
        + r2 * (-1.0 / 5040.0
        + r2 * (1.0 / 362880.0
        + r2 * (-1.0 / 39916800.0
        + r2 * (1.0 / 6227020800.0
        + r2 * (-1.0 / 1307674368000.0))))))
    )  # fmt: skip
    cos_r = 1.0 + r2 * (
        -0.5
        + r2 * (1.0 / 24.0
        + r2 * (-1.0 / 720.0
        + r2 * (1.0 / 40320.0
        + r2 * (-1.0 / 3628800.0
        + r2 * (1.0 / 479001600.0
        + r2 * (-1.0 / 87178291200.0
        + r2 * (1.0 / 20922789888000.0)))))))
    )  # fmt: skip
    quadrant = k - 4.0 * np.floor(k * 0.25)  # 0, 1, 2 or 3
    odd = (quadrant == 1.0) | (quadrant == 3.0)
    sin_x = cos_r if odd else sin_r
    cos_x = sin_r if odd else cos_r
    sin_x = -sin_x if quadrant >= 2.0 else sin_x
    cos_x = -cos_x if (quadrant == 1.0) | (quadrant == 2.0) else cos_x
    return sin_x, cos_x


@hot_path
def sincos_into(x, start, stop, sin_out, cos_out) -> None:
    """``sin_out[k - start], cos_out[k - start] = _sincos(x[k])`` for ``start <= k < stop``.

    Vectorized by LLVM. Takes a range rather than a slice: a slice is a new array, which a
    `hot_path` helper cannot make.
    """
    for k in range(start, stop):
        sin_out[k - start], cos_out[k - start] = _sincos(x[k])


@hot_inline
def chain_into(poses, kind, rotation, shift, cosines, sines, base, values, value_base) -> None:
    """``poses[j + 1] = poses[j] @ origin[j] @ motion(q[j])`` for every joint, 3x4 poses.

    Joint ``j``'s cosine, sine and value are ``cosines[base + j]``, ``sines[base + j]`` and
    ``values[value_base + j]`` (the value is only read for a prismatic joint). The running
    pose is kept in twelve locals and only written out: read back from ``poses``, the
    compiler would have to assume that each write may change the arrays it reads (they are
    all float64), and reload everything per row, several times slower.
    """
    a00, a01, a02, a03 = poses[0, 0, 0], poses[0, 0, 1], poses[0, 0, 2], poses[0, 0, 3]
    a10, a11, a12, a13 = poses[0, 1, 0], poses[0, 1, 1], poses[0, 1, 2], poses[0, 1, 3]
    a20, a21, a22, a23 = poses[0, 2, 0], poses[0, 2, 1], poses[0, 2, 2], poses[0, 2, 3]
    for j in range(kind.shape[0]):
        c, s, slide = cosines[base + j], sines[base + j], 0.0
        if kind[j] != 0:  # prismatic: no turn, a slide along the joint's z
            c, s, slide = 1.0, 0.0, values[value_base + j]
        t0, t1, t2 = shift[j, 0], shift[j, 1], shift[j, 2]
        r00, r01, r02 = rotation[j, 0, 0], rotation[j, 0, 1], rotation[j, 0, 2]
        r10, r11, r12 = rotation[j, 1, 0], rotation[j, 1, 1], rotation[j, 1, 2]
        r20, r21, r22 = rotation[j, 2, 0], rotation[j, 2, 1], rotation[j, 2, 2]
        # Row by row: m = row @ origin rotation; then the turn about z and the slide.
        m0 = a00 * r00 + a01 * r10 + a02 * r20
        m1 = a00 * r01 + a01 * r11 + a02 * r21
        m2 = a00 * r02 + a01 * r12 + a02 * r22
        a03 = a00 * t0 + a01 * t1 + a02 * t2 + a03 + slide * m2
        a00, a01, a02 = c * m0 + s * m1, c * m1 - s * m0, m2
        m0 = a10 * r00 + a11 * r10 + a12 * r20
        m1 = a10 * r01 + a11 * r11 + a12 * r21
        m2 = a10 * r02 + a11 * r12 + a12 * r22
        a13 = a10 * t0 + a11 * t1 + a12 * t2 + a13 + slide * m2
        a10, a11, a12 = c * m0 + s * m1, c * m1 - s * m0, m2
        m0 = a20 * r00 + a21 * r10 + a22 * r20
        m1 = a20 * r01 + a21 * r11 + a22 * r21
        m2 = a20 * r02 + a21 * r12 + a22 * r22
        a23 = a20 * t0 + a21 * t1 + a22 * t2 + a23 + slide * m2
        a20, a21, a22 = c * m0 + s * m1, c * m1 - s * m0, m2
        poses[j + 1, 0, 0], poses[j + 1, 0, 1], poses[j + 1, 0, 2] = a00, a01, a02
        poses[j + 1, 1, 0], poses[j + 1, 1, 1], poses[j + 1, 1, 2] = a10, a11, a12
        poses[j + 1, 2, 0], poses[j + 1, 2, 1], poses[j + 1, 2, 2] = a20, a21, a22
        poses[j + 1, 0, 3], poses[j + 1, 1, 3], poses[j + 1, 2, 3] = a03, a13, a23


@hot_inline
def place_point(poses, j, c0, c1, c2):
    """World position of the point ``(c0, c1, c2)`` of body ``j`` (poses (B, 3, 4))."""
    x = poses[j, 0, 0] * c0 + poses[j, 0, 1] * c1 + poses[j, 0, 2] * c2 + poses[j, 0, 3]
    y = poses[j, 1, 0] * c0 + poses[j, 1, 1] * c1 + poses[j, 1, 2] * c2 + poses[j, 1, 3]
    z = poses[j, 2, 0] * c0 + poses[j, 2, 1] * c1 + poses[j, 2, 2] * c2 + poses[j, 2, 3]
    return x, y, z


@hot_inline
def place(poses, j, centers, k):
    """World position of row ``k`` of ``centers``, a point of body ``j`` (`place_point`)."""
    return place_point(poses, j, centers[k, 0], centers[k, 1], centers[k, 2])


LEVER_SLACK = 1e-6
"""Added (m) to every lever arm `segment_levers_into` measures: it covers `FAST_FK_MARGIN`
and rounding many times over."""


@hot_inline
def _measure_levers(rows, e, kind, rotation, shift, body_start, node_centers, node_radii, poses,
                    q, sines, cosines, lever, first) -> None:  # fmt: skip
    """How far each body's root sphere reaches from each revolute joint's axis that moves it.

    At the configuration ``rows[e]``: body ``j`` from joint ``i``'s axis, into ``lever[i, j]``
    (``first``) or added to it. ``poses``, ``q``, ``sines`` and ``cosines`` are scratch.
    """
    dim = kind.shape[0]
    for i in range(dim):
        q[i] = rows[e, i]
    sincos_into(q, 0, dim, sines, cosines)
    chain_into(poses, kind, rotation, shift, cosines, sines, 0, q, 0)
    for j in range(1, poses.shape[0]):
        root = body_start[j]
        if root == body_start[j + 1]:
            continue
        cx, cy, cz = place(poses, j, node_centers, root)
        for i in range(j):
            if kind[i] != 0:
                continue
            # Joint i turns about the z axis of body i + 1's frame, through its origin.
            vx = cx - poses[i + 1, 0, 3]
            vy = cy - poses[i + 1, 1, 3]
            vz = cz - poses[i + 1, 2, 3]
            zx, zy, zz = poses[i + 1, 0, 2], poses[i + 1, 1, 2], poses[i + 1, 2, 2]
            wx, wy, wz = vy * zz - vz * zy, vz * zx - vx * zz, vx * zy - vy * zx
            reach = (wx * wx + wy * wy + wz * wz) ** 0.5 + node_radii[root]
            lever[i, j] = reach if first else lever[i, j] + reach


@hot_inline
def segment_levers_into(starts, ends, e, kind, rotation, shift, motion, body_start,
                        node_centers, node_radii, poses, q, sines, cosines,
                        lever) -> None:  # fmt: skip
    """Lever arms of one motion: how far any point of each body gets from each joint's axis.

    ``lever[i, j]`` bounds how far from joint ``i``'s axis any point of body ``j``'s root
    sphere gets along the straight motion ``starts[e] -> ends[e]``; at most ``motion[i, j]``.

    ``motion`` (`ArmModel.motion_radii`) bounds it over every configuration. Along one motion
    it is smaller for a folded arm: the distance ``D`` at either end, measured, grows by at
    most ``S = sum over the joints k between i and j of |dq_k| motion[k, j]`` (they move body
    ``j`` relative to the axis) over the motion, so ``D(t) <= min(D(0) + t S, D(1) + (1 - t)
    S) <= (D(0) + D(1) + S) / 2``. A point of body ``j`` then moves at most
    ``sum_i |dq_i| lever[i, j]`` per unit of the motion's parameter, anywhere along it. For a
    prismatic joint, a body without spheres and joints that do not move a body it is
    ``motion``. ``poses``, ``q``, ``sines`` and ``cosines`` are scratch.
    """
    _measure_levers(starts, e, kind, rotation, shift, body_start, node_centers, node_radii,
                    poses, q, sines, cosines, lever, True)  # fmt: skip
    _measure_levers(ends, e, kind, rotation, shift, body_start, node_centers, node_radii,
                    poses, q, sines, cosines, lever, False)  # fmt: skip
    dim = kind.shape[0]
    for j in range(poses.shape[0]):
        spheres = body_start[j] < body_start[j + 1]
        for i in range(dim):
            if not (spheres and kind[i] == 0 and i < j):
                lever[i, j] = motion[i, j]
                continue
            between = 0.0
            for k in range(i + 1, j):
                between += abs(ends[e, k] - starts[e, k]) * motion[k, j]
            lever[i, j] = min(motion[i, j], 0.5 * (lever[i, j] + between) + LEVER_SLACK)


@numba.njit(cache=True, nogil=True)
def identity_poses(count):
    """``(count, 3, 4)`` poses, the first the identity (the base), the rest zero."""
    poses = np.zeros((count, 3, 4))
    for r in range(3):
        poses[0, r, r] = 1.0
    return poses


@numba.njit(cache=True, nogil=True)
def fk_batch(configs, kind, rotation, shift):
    """``(N, J + 1, 3, 4)`` body poses of configurations ``(N, J)`` (exact sines)."""
    count, joints = configs.shape
    out = np.zeros((count, joints + 1, 3, 4))
    poses = identity_poses(joints + 1)
    flat = configs.reshape(-1)
    sines, cosines = np.sin(flat), np.cos(flat)
    for i in range(count):
        chain_into(poses, kind, rotation, shift, cosines, sines, i * joints, flat, i * joints)
        out[i] = poses
    return out


__all__ = [
    "FAST_FK_MARGIN",
    "LEVER_SLACK",
    "segment_levers_into",
    "place",
    "place_point",
    "fk_batch",
    "identity_poses",
    "chain_into",
    "sincos_into",
]
