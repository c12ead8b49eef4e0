"""The KUKA LBR iiwa 14: URDF model, collision meshes and forward kinematics.

The model is pybullet_data's ``kuka_iiwa/model.urdf``: 8 links (``link_0`` is the base, fixed
at the world origin with z up) joined by 7 revolute joints. Everything here is read from the
URDF with `xml.etree`, so the kinematics cannot drift from the file pybullet loads.

Link ``j``'s frame is the frame of the joint that carries it (as in URDF and pybullet's
``worldLinkFramePosition``), not its inertial frame.

Examples:
    >>> poses = forward_kinematics(np.zeros((2, 7)))  # (2, 8, 4, 4) world poses of the links
    >>> poses[0, 7, :3, 3].round(3)  # link_7 origin with the arm stretched up
    array([0.   , 0.   , 1.261])
"""

from __future__ import annotations

import functools
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np

NUM_JOINTS = 7
NUM_LINKS = 8


def urdf_path() -> Path:
    """Path of pybullet_data's ``kuka_iiwa/model.urdf``."""
    import pybullet_data

    return Path(pybullet_data.getDataPath()) / "kuka_iiwa" / "model.urdf"


def _rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    """URDF fixed-axis roll-pitch-yaw: ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``."""
    roll, pitch, yaw = rpy
    cr, sr, cp, sp, cy, sy = (np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch),
                              np.cos(yaw), np.sin(yaw))  # fmt: skip
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def _origin_transform(element: ElementTree.Element | None) -> np.ndarray:
    """4x4 transform of a URDF ``<origin xyz=.. rpy=..>`` element (identity when absent)."""
    transform = np.eye(4)
    if element is not None:
        xyz = np.array(element.get("xyz", "0 0 0").split(), dtype=np.float64)
        rpy = np.array(element.get("rpy", "0 0 0").split(), dtype=np.float64)
        transform[:3, :3] = _rpy_matrix(rpy)
        transform[:3, 3] = xyz
    return transform


@dataclass(frozen=True)
class IiwaModel:
    """What the URDF says, as arrays.

    Attributes:
        joint_origins: ``(7, 4, 4)`` parent-link-to-joint transforms (the ``<origin>`` tags).
        joint_axes: ``(7, 3)`` unit rotation axes in the joint frame.
        joint_limits: ``(2, 7)`` lower and upper joint limits in radians.
        mesh_files: the 8 collision mesh paths, ``link_0`` first.
        mesh_origins: ``(8, 4, 4)`` collision-origin transforms in each link frame.
    """

    joint_origins: np.ndarray
    joint_axes: np.ndarray
    joint_limits: np.ndarray
    mesh_files: tuple[Path, ...]
    mesh_origins: np.ndarray


@functools.cache
def load_model() -> IiwaModel:
    """Parse the URDF (cached). The chain is ordered by following parent-child links."""
    path = urdf_path()
    root = ElementTree.parse(path).getroot()
    links = {link.get("name"): link for link in root.findall("link")}
    joints = {joint.find("parent").get("link"): joint for joint in root.findall("joint")}
    child_names = {joint.find("child").get("link") for joint in joints.values()}
    (base,) = set(links) - child_names
    chain, revolute = [base], []
    while chain[-1] in joints:
        joint = joints[chain[-1]]
        if joint.get("type") != "revolute":
            raise ValueError(f"{path}: joint {joint.get('name')} is not revolute")
        revolute.append(joint)
        chain.append(joint.find("child").get("link"))
    if len(revolute) != NUM_JOINTS:
        raise ValueError(f"{path}: expected {NUM_JOINTS} joints, found {len(revolute)}")
    origins = np.stack([_origin_transform(j.find("origin")) for j in revolute])
    axes = np.array([j.find("axis").get("xyz").split() for j in revolute], dtype=np.float64)
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    if not np.allclose(axes, [0.0, 0.0, 1.0]):
        raise ValueError(f"{path}: the compiled kinematics assume every joint axis is z")
    limits = np.array(
        [[float(j.find("limit").get(k)) for j in revolute] for k in ("lower", "upper")]
    )
    mesh_files, mesh_origins = [], []
    for name in chain:
        collision = links[name].find("collision")
        mesh_files.append(path.parent / collision.find("geometry/mesh").get("filename"))
        mesh_origins.append(_origin_transform(collision.find("origin")))
    for array in (origins, axes, limits):
        array.setflags(write=False)
    return IiwaModel(origins, axes, limits, tuple(mesh_files), np.stack(mesh_origins))


def joint_limits() -> np.ndarray:
    """``(2, 7)`` joint limits ``[lower, upper]`` in radians, a fresh array."""
    return load_model().joint_limits.copy()


def read_stl(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a binary STL file into ``(vertices (V, 3), faces (F, 3))``, vertices deduplicated.

    A 20-line numpy reader instead of trimesh: the runtime then needs no mesh library, and
    the iiwa meshes are all binary STL (80-byte header, uint32 count, 50 bytes per triangle).
    """
    data = Path(path).read_bytes()
    count = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
    if len(data) != 84 + 50 * count:
        raise ValueError(f"{path}: not a binary STL file ({len(data)} bytes, {count} triangles)")
    record = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attr", "<u2")])
    triangles = np.frombuffer(data, dtype=record, count=count, offset=84)["corners"]
    corners = triangles.reshape(-1, 3).astype(np.float64)
    vertices, inverse = np.unique(corners, axis=0, return_inverse=True)
    return vertices, inverse.reshape(-1, 3).astype(np.int64)


@functools.cache
def link_meshes() -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """The 8 collision meshes as ``(vertices, faces)``, vertices in their link's frame."""
    model = load_model()
    meshes = []
    for path, origin in zip(model.mesh_files, model.mesh_origins):
        vertices, faces = read_stl(path)
        vertices = vertices @ origin[:3, :3].T + origin[:3, 3]
        vertices.setflags(write=False)
        faces.setflags(write=False)
        meshes.append((vertices, faces))
    return tuple(meshes)


# ---------------------------------------------------------------------------- kinematics
@numba.njit(cache=True, nogil=True, inline="always")
def _joint_transform_into(parent, origin, angle, out) -> None:
    """``out = parent @ origin @ rot_z(angle)`` for 4x4 rigid transforms.

    Every iiwa joint turns about its frame's z axis (`load_model` checks it), which saves
    two thirds of the rotation products in the hot loop.
    """
    c = np.cos(angle)
    s = np.sin(angle)
    for r in range(3):
        # Row r of parent @ origin, then its first two columns turned by the joint angle.
        m0 = parent[r, 0] * origin[0, 0] + parent[r, 1] * origin[1, 0] + parent[r, 2] * origin[2, 0]
        m1 = parent[r, 0] * origin[0, 1] + parent[r, 1] * origin[1, 1] + parent[r, 2] * origin[2, 1]
        m2 = parent[r, 0] * origin[0, 2] + parent[r, 1] * origin[1, 2] + parent[r, 2] * origin[2, 2]
        out[r, 3] = (
            parent[r, 0] * origin[0, 3]
            + parent[r, 1] * origin[1, 3]
            + parent[r, 2] * origin[2, 3]
            + parent[r, 3]
        )
        out[r, 0] = c * m0 + s * m1
        out[r, 1] = c * m1 - s * m0
        out[r, 2] = m2
    out[3, 0] = 0.0
    out[3, 1] = 0.0
    out[3, 2] = 0.0
    out[3, 3] = 1.0


@numba.njit(cache=True, nogil=True)
def fk_into(q, joint_origins, joint_axes, poses) -> None:
    """Write the 8 world link poses of configuration ``q`` (7,) into ``poses`` (8, 4, 4).

    Allocation-free, for use inside other numba kernels. ``joint_axes`` is accepted for
    symmetry with the model but must be all z (checked when the URDF is loaded).
    """
    for r in range(4):
        for col in range(4):
            poses[0, r, col] = 1.0 if r == col else 0.0
    for j in range(joint_origins.shape[0]):
        _joint_transform_into(poses[j], joint_origins[j], q[j], poses[j + 1])


@numba.njit(cache=True, nogil=True)
def _fk_batch(configs, joint_origins, joint_axes):
    poses = np.empty((configs.shape[0], joint_origins.shape[0] + 1, 4, 4))
    for i in range(configs.shape[0]):
        fk_into(configs[i], joint_origins, joint_axes, poses[i])
    return poses


# Fast-path kinematics for the collision kernels. The URDF's joint-origin rotations are signed
# permutations up to its rounded rpy angles (1.57079632679 for pi/2): snapping them, and a
# polynomial sine, moves FK results by far less than `FAST_FK_MARGIN`, which callers add to
# their sphere radii so that conservative tests stay conservative.
FAST_FK_MARGIN = 1e-8
"""Bound (m) on how far the fast-path FK (snapped origins, `sincos_into`) moves any point
within 2 m of the base, with a wide safety factor; `origin_permutations` checks it."""

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


def origin_permutations(joint_origins: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Joint origins as signed permutations: ``(perm (7, 3) int64, sign (7, 3), shift (7, 3))``.

    Origin ``i``'s rotation is (up to rounding in the URDF) ``R[perm[i, k], k] = sign[i, k]``,
    its translation ``shift[i]``. Raises `ValueError` if a rotation is not close enough to a
    signed permutation for `FAST_FK_MARGIN` to cover the snapping.
    """
    rotations = joint_origins[:, :3, :3]
    perm = np.argmax(np.abs(rotations), axis=1).astype(np.int64)
    sign = np.sign(np.take_along_axis(rotations, perm[:, None, :], axis=1)[:, 0, :])
    snapped = np.zeros_like(rotations)
    for i in range(len(rotations)):
        snapped[i, perm[i], np.arange(3)] = sign[i]
    # Replacing rotation i by one within d_i (spectral norm <= Frobenius) moves a point at
    # distance <= 2 m from joint i's origin by <= 2 d_i; errors add along the chain.
    deviation = np.linalg.norm(rotations - snapped, axis=(1, 2))
    not_permutation = any(sorted(row) != [0, 1, 2] for row in perm.tolist())
    if not_permutation or 10.0 * 2.0 * deviation.sum() > FAST_FK_MARGIN:
        raise ValueError("joint origins: rotations are not signed permutations")
    shift = np.ascontiguousarray(joint_origins[:, :3, 3])
    return perm, np.ascontiguousarray(sign), shift


@numba.njit(cache=True, nogil=True, inline="always")
def joint_step_into(poses, j, perm, sign, shift, c, s) -> None:
    """``poses[j + 1] = poses[j] @ origin[j] @ rot_z`` on 3x4 poses, origins signed permutations.

    ``(pose @ origin)[:, k] = sign[j, k] * pose[:, perm[j, k]]``, so the product is copies,
    and the joint turns the first two columns by the angle with cosine ``c`` and sine ``s``.
    Indexes whole arrays rather than taking row views: views cost reference counting.
    """
    p0, p1, p2 = perm[j, 0], perm[j, 1], perm[j, 2]
    a0, a1, a2 = sign[j, 0], sign[j, 1], sign[j, 2]
    t0, t1, t2 = shift[j, 0], shift[j, 1], shift[j, 2]
    for r in range(3):
        m0 = a0 * poses[j, r, p0]
        m1 = a1 * poses[j, r, p1]
        poses[j + 1, r, 3] = (
            poses[j, r, 0] * t0 + poses[j, r, 1] * t1 + poses[j, r, 2] * t2 + poses[j, r, 3]
        )
        poses[j + 1, r, 2] = a2 * poses[j, r, p2]
        poses[j + 1, r, 0] = c * m0 + s * m1
        poses[j + 1, r, 1] = c * m1 - s * m0


def as_configs(configs: np.ndarray, name: str = "configs") -> np.ndarray:
    """``(N, 7)`` float64 configurations (one ``(7,)`` becomes ``(1, 7)``), ``name`` the field."""
    configs = np.ascontiguousarray(configs, dtype=np.float64)
    if configs.ndim == 1:
        configs = configs.reshape(1, -1)
    if configs.ndim != 2 or configs.shape[1] != NUM_JOINTS:
        raise ValueError(f"{name}: expected shape (N, {NUM_JOINTS}), got {configs.shape}")
    return configs


def forward_kinematics(configs: np.ndarray) -> np.ndarray:
    """World poses ``(N, 8, 4, 4)`` of the 8 links for configurations ``(N, 7)`` (numba)."""
    model = load_model()
    return _fk_batch(as_configs(configs), model.joint_origins, model.joint_axes)


def forward_kinematics_reference(config: np.ndarray) -> np.ndarray:
    """Plain-numpy FK of one configuration ``(7,)`` -> ``(8, 4, 4)``; the tests' reference."""
    model = load_model()
    config = as_configs(config)[0]
    poses = [np.eye(4)]
    for origin, axis, angle in zip(model.joint_origins, model.joint_axes, config):
        skew = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        rotation = np.eye(4)
        rotation[:3, :3] = np.eye(3) + np.sin(angle) * skew + (1 - np.cos(angle)) * skew @ skew
        poses.append(poses[-1] @ origin @ rotation)
    return np.stack(poses)


def joint_offsets() -> np.ndarray:
    """``(7,)`` distance from joint ``i``'s origin to joint ``i+1``'s (0 for the last joint).

    Used in motion bounds: both origins are fixed in link ``i+1``'s frame, so this distance
    does not depend on the configuration.
    """
    origins = load_model().joint_origins
    offsets = np.zeros(NUM_JOINTS)
    offsets[:-1] = np.linalg.norm(origins[1:, :3, 3], axis=1)
    return offsets


def motion_radii(link_radii: np.ndarray) -> np.ndarray:
    """``(7, 8)`` bounds ``R[i, j]``: distance from joint ``i``'s axis to any point of link ``j``.

    Args:
        link_radii: ``(8,)`` largest distance of a point of link ``j`` from its frame origin.

    Returns:
        ``R[i, j] = sum(offsets[i:j]) + link_radii[j]`` for ``j > i`` (triangle inequality along
        the chain; distance to the origin bounds distance to the axis), 0 for links that joint
        ``i`` does not move. Rotating joint ``i`` by ``dq`` moves a point of link ``j`` by at
        most ``|dq| * R[i, j]``; a joint-space segment moves it at most ``sum_i |dq_i| R[i, j]``.
    """
    offsets = joint_offsets()
    radii = np.zeros((NUM_JOINTS, NUM_LINKS))
    for i in range(NUM_JOINTS):
        for j in range(i + 1, NUM_LINKS):
            radii[i, j] = offsets[i : j - 1].sum() + link_radii[j]
    return radii


def relative_motion_radii(radii: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """``(P, 7)`` bounds on how fast link ``b`` moves relative to link ``a``, per pair ``(a, b)``.

    Entry ``[p, i]`` is ``radii[i, b]`` (`motion_radii`) for the joints between the two links
    (``a <= i < b``) and 0 for the others: joints before link ``a`` move both links as one
    rigid body, which changes no distance between them. So along a joint-space segment the
    distance between the links changes at most by ``|dq| @ result[p]``.
    """
    out = np.zeros((len(pairs), radii.shape[0]))
    for p, (a, b) in enumerate(np.asarray(pairs, dtype=np.int64)):
        out[p, a:b] = radii[a:b, b]
    return out


__all__ = [
    "NUM_JOINTS",
    "NUM_LINKS",
    "as_configs",
    "IiwaModel",
    "FAST_FK_MARGIN",
    "fk_into",
    "joint_step_into",
    "origin_permutations",
    "sincos_into",
    "forward_kinematics",
    "forward_kinematics_reference",
    "joint_limits",
    "link_meshes",
    "load_model",
    "motion_radii",
    "read_stl",
    "relative_motion_radii",
    "urdf_path",
]
