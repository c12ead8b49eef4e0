"""Compiled forward kinematics of any serial arm whose joints turn or slide about z.

`temp_gym.worlds.arm.urdf` turns every joint's axis into its frame's z, so body ``j + 1``'s
pose is ``body j's pose @ origin[j] @ motion(q[j])``, where the motion turns about z
(revolute) or slides along it (prismatic). The kernels work on 3x4 poses (the last row is
always ``0 0 0 1``) and take the arm as arrays, so one compiled kernel serves every arm:

* ``joint_kind[j]``: 0 revolute, 1 prismatic;
* ``origin_rotation[j]`` (3x3) and ``origin_shift[j]`` (3,);
* ``permutation[j]``, ``sign[j]``: for origins whose rotation is a signed permutation (as
  right-angle URDF origins are), ``R[permutation[j, k], k] = sign[j, k]`` and the product with
  the parent's rotation is a copy, not a matrix product (``permutation[j, 0] < 0``: general).

Sines and cosines come from `sincos_into`, a branch-free polynomial that LLVM vectorizes over
a block of states; snapping nearly-permutation rotations and the polynomial move points by far
less than `FAST_FK_MARGIN`, which the checkers add to their sphere radii so that conservative
tests stay conservative.
"""

from __future__ import annotations

import numba
import numpy as np

FAST_FK_MARGIN = 1e-8
"""Bound (m) on how far the fast-path kinematics (snapped rotations, `sincos_into`) moves any
point within a few metres of the base; `snap_permutations` checks the snapping's share."""
SNAP_TOLERANCE = 2e-10
"""Largest rotation error (Frobenius) snapped to a signed permutation."""

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


@numba.njit(cache=True, nogil=True)
def sincos_into(x, sin_out, cos_out) -> None:
    """Elementwise `_sincos` of the flat array ``x`` (vectorized by LLVM)."""
    for k in range(x.shape[0]):
        sin_out[k], cos_out[k] = _sincos(x[k])


def snap_permutations(rotations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotations that are signed permutations, as ``(permutation (J, 3) int64, sign (J, 3))``.

    A rotation within `SNAP_TOLERANCE` of a signed permutation is one; ``permutation[j] = -1``
    where rotation ``j`` is not.
    """
    count = len(rotations)
    permutation = np.full((count, 3), -1, dtype=np.int64)
    sign = np.zeros((count, 3))
    for j, rotation in enumerate(rotations):
        rows = np.argmax(np.abs(rotation), axis=0)
        if sorted(rows.tolist()) != [0, 1, 2]:
            continue
        signs = np.sign(rotation[rows, np.arange(3)])
        snapped = np.zeros((3, 3))
        snapped[rows, np.arange(3)] = signs
        if np.linalg.norm(rotation - snapped) <= SNAP_TOLERANCE:
            permutation[j], sign[j] = rows, signs
    return permutation, sign


@numba.njit(cache=True, nogil=True, inline="always")
def joint_step_into(poses, j, kind, rotation, shift, permutation, sign, c, s, q) -> None:
    """``poses[j + 1] = poses[j] @ origin[j] @ motion``, 3x4 poses (module docstring).

    ``c``, ``s`` are the joint's cosine and sine (revolute), ``q`` its value (prismatic).
    Every parameter of the joint is read into a local first: the compiler cannot tell that
    writing ``poses`` leaves the parameter arrays alone, and would read them again per row.
    Indexes whole arrays rather than taking row views: views cost reference counting.
    """
    t0, t1, t2 = shift[j, 0], shift[j, 1], shift[j, 2]
    if kind[j] != 0:  # prismatic: no turn, a slide along the joint's z
        c, s = 1.0, 0.0
    slide = q if kind[j] != 0 else 0.0
    if permutation[j, 0] >= 0:
        p0, p1, p2 = permutation[j, 0], permutation[j, 1], permutation[j, 2]
        a0, a1, a2 = sign[j, 0], sign[j, 1], sign[j, 2]
        for r in range(3):
            m0 = a0 * poses[j, r, p0]
            m1 = a1 * poses[j, r, p1]
            m2 = a2 * poses[j, r, p2]
            poses[j + 1, r, 3] = (poses[j, r, 0] * t0 + poses[j, r, 1] * t1
                                  + poses[j, r, 2] * t2 + poses[j, r, 3] + slide * m2)  # fmt: skip
            poses[j + 1, r, 2] = m2
            poses[j + 1, r, 0] = c * m0 + s * m1
            poses[j + 1, r, 1] = c * m1 - s * m0
        return
    r00, r01, r02 = rotation[j, 0, 0], rotation[j, 0, 1], rotation[j, 0, 2]
    r10, r11, r12 = rotation[j, 1, 0], rotation[j, 1, 1], rotation[j, 1, 2]
    r20, r21, r22 = rotation[j, 2, 0], rotation[j, 2, 1], rotation[j, 2, 2]
    for r in range(3):
        x, y, z = poses[j, r, 0], poses[j, r, 1], poses[j, r, 2]
        m0 = x * r00 + y * r10 + z * r20
        m1 = x * r01 + y * r11 + z * r21
        m2 = x * r02 + y * r12 + z * r22
        poses[j + 1, r, 3] = x * t0 + y * t1 + z * t2 + poses[j, r, 3] + slide * m2
        poses[j + 1, r, 2] = m2
        poses[j + 1, r, 0] = c * m0 + s * m1
        poses[j + 1, r, 1] = c * m1 - s * m0


@numba.njit(cache=True, nogil=True)
def identity_poses(count):
    """``(count, 3, 4)`` poses, the first the identity (the base), the rest zero."""
    poses = np.zeros((count, 3, 4))
    for r in range(3):
        poses[0, r, r] = 1.0
    return poses


@numba.njit(cache=True, nogil=True)
def fk_batch(configs, kind, rotation, shift, permutation, sign):
    """``(N, J + 1, 3, 4)`` body poses of configurations ``(N, J)`` (exact sines)."""
    count, joints = configs.shape
    out = np.zeros((count, joints + 1, 3, 4))
    poses = identity_poses(joints + 1)
    for i in range(count):
        for j in range(joints):
            q = configs[i, j]
            joint_step_into(poses, j, kind, rotation, shift, permutation, sign, np.cos(q),
                            np.sin(q), q)  # fmt: skip
        out[i] = poses
    return out


__all__ = [
    "FAST_FK_MARGIN",
    "SNAP_TOLERANCE",
    "fk_batch",
    "identity_poses",
    "joint_step_into",
    "sincos_into",
    "snap_permutations",
]
