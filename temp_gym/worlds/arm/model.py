"""An arm as the checkers, generators and renderer use it: description, chain, geometry, data.

`load_arm` reads a robot description (`temp_gym.worlds.arm.description`), its URDF's chain
(`temp_gym.worlds.arm.urdf`) and collision geometry (`temp_gym.worlds.arm.meshes`), and the
derived data that ``temp-robot build`` wrote beside the description (spheres, the
allowed-collision matrix, pair tables: `temp_gym.worlds.arm.build`). It is cached per
description file and content (and its URDF's and derived data's: an edited file is read
again), so every checker of a process shares one `ArmModel`.

Example:
    >>> arm = load_arm("temp_gym/worlds/robots/descriptions/kuka_iiwa14.yaml")
    >>> arm.dim, arm.body_names[-1]
    (7, 'lbr_iiwa_link_7')
    >>> poses = arm.forward_kinematics(np.zeros((2, 7)))  # (2, 8, 4, 4) body poses
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import threading
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from temp_gym.worlds.arm.description import RobotDescription, load_description
from temp_gym.worlds.arm.kinematics import fk_batch
from temp_gym.worlds.arm.meshes import BodyGeometry, body_geometry, resolve_mesh
from temp_gym.worlds.arm.urdf import PRISMATIC, ArmChain, read_chain

DERIVED_FORMAT = 2
"""Version of the derived-data file; a file of another version must be rebuilt."""
COLLISION_PADDING = 0.001
"""Every link is grown by this much (m) in both checkers: pybullet's collision margin for
URDF meshes, so that our verdicts and pybullet's agree on what touches."""


class ArmDataError(ValueError):
    """The derived data of an arm is missing or stale; the message says how to rebuild it."""


@dataclass(frozen=True)
class ArmModel:
    """One arm, loaded (`load_arm`).

    Attributes:
        description: its robot description.
        chain: its kinematic chain and collision elements.
        geometry: per body, its meshes and convex pieces.
        derived: the derived data (JSON mapping) written by ``temp-robot build``, or None
            while it is being built.
    """

    description: RobotDescription
    chain: ArmChain
    geometry: tuple[BodyGeometry, ...]
    derived: dict | None = None
    _arrays: dict = field(default_factory=dict, repr=False, compare=False)

    # ---------------------------------------------------------------- copies
    def __deepcopy__(self, memo: dict) -> ArmModel:
        # One model per description and process, never modified: a copy is the model itself
        # (its fcl geometry cannot be copied, and needs not be).
        return self

    def __reduce__(self):
        # Pickled as its description file: unpickling loads (or finds) the process's model.
        return (load_arm, (str(self.description.path), self.derived is not None))

    # ---------------------------------------------------------------- structure
    @property
    def name(self) -> str:
        """The robot's name."""
        return self.description.name

    @property
    def dim(self) -> int:
        """Number of joints planned for."""
        return self.chain.dim

    @property
    def num_bodies(self) -> int:
        """Number of rigid bodies: the base and one per joint."""
        return self.chain.dim + 1

    @property
    def body_names(self) -> tuple[str, ...]:
        """Each body's chain link (the base first)."""
        return self.chain.body_names

    @property
    def joint_names(self) -> tuple[str, ...]:
        """The planned joints, base to tip."""
        return self.chain.joint_names

    def joint_limits(self) -> np.ndarray:
        """``(2, dim)`` joint limits ``[lower, upper]``, a fresh array."""
        return self.chain.joint_limits.copy()

    # ---------------------------------------------------------------- kinematics
    def kinematic_arrays(self) -> tuple[np.ndarray, ...]:
        """``(kind, rotation, shift)`` for the compiled kernels (read-only, cached)."""
        key = "kinematics"
        if key not in self._arrays:
            origins = self.chain.joint_origins
            arrays = (np.ascontiguousarray(self.chain.joint_types, dtype=np.int64),
                      np.ascontiguousarray(origins[:, :3, :3]),
                      np.ascontiguousarray(origins[:, :3, 3]))  # fmt: skip
            for array in arrays:
                array.setflags(write=False)
            self._arrays[key] = arrays
        return self._arrays[key]

    def forward_kinematics(self, configs: np.ndarray) -> np.ndarray:
        """World poses ``(N, bodies, 4, 4)`` of the bodies for configurations ``(N, dim)``."""
        configs = self.as_configs(configs)
        poses = fk_batch(configs, *self.kinematic_arrays())
        out = np.zeros(poses.shape[:2] + (4, 4))
        out[..., :3, :] = poses
        out[..., 3, 3] = 1.0
        return out

    def link_poses(self, configs: np.ndarray, links: list[str] | None = None) -> np.ndarray:
        """World poses ``(N, L, 4, 4)`` of URDF ``links`` (default: every link of the arm)."""
        links = list(self.chain.link_bodies) if links is None else links
        bodies = self.forward_kinematics(configs)
        return np.stack(
            [bodies[:, self.chain.link_bodies[link]] @ self.chain.link_transforms[link]
             for link in links],
            axis=1,
        )  # fmt: skip

    def tip_poses(self, configs: np.ndarray) -> np.ndarray:
        """World poses ``(N, 4, 4)`` of the tip link."""
        return self.link_poses(configs, [self.chain.tip_link])[:, 0]

    def as_configs(self, configs: np.ndarray, name: str = "configs") -> np.ndarray:
        """``(N, dim)`` float64 configurations (one ``(dim,)`` becomes ``(1, dim)``)."""
        configs = np.ascontiguousarray(configs, dtype=np.float64)
        if configs.ndim == 1:
            configs = configs.reshape(1, -1)
        if configs.ndim != 2 or configs.shape[1] != self.dim:
            raise ValueError(f"{name}: expected shape (N, {self.dim}), got {configs.shape}")
        return configs

    # ---------------------------------------------------------------- geometry bounds
    def body_radii(self) -> np.ndarray:
        """``(bodies,)`` largest distance of a body's geometry from its frame origin."""
        if "body_radii" not in self._arrays:
            radii = np.array([
                max((float(np.linalg.norm(p, axis=1).max()) for p in g.pieces), default=0.0)
                for g in self.geometry
            ])  # fmt: skip
            radii.setflags(write=False)
            self._arrays["body_radii"] = radii
        return self._arrays["body_radii"]

    def motion_radii(self) -> np.ndarray:
        """``(dim, bodies)`` bounds ``R[i, j]``: how far a point of body ``j`` moves per unit.

        Per unit of joint ``i``: m/rad about a revolute joint, m/m along a prismatic one.

        For a revolute joint, the distance from its axis, at most the distance from its
        origin: the offsets of the joint origins between the two bodies plus body ``j``'s
        radius, a prismatic joint in between adding its largest extension. Zero for bodies
        joint ``i`` does not move. A joint-space segment moves a point of body ``j`` at most
        ``sum_i |dq_i| R[i, j]``.
        """
        if "motion_radii" not in self._arrays:
            shift = self.chain.joint_origins[:, :3, 3]
            limits = self.chain.joint_limits
            reach = np.abs(limits).max(axis=0)
            prismatic = self.chain.joint_types == PRISMATIC
            radii = np.zeros((self.dim, self.num_bodies))
            body_radii = self.body_radii()
            for i in range(self.dim):
                for j in range(i + 1, self.num_bodies):
                    if prismatic[i]:
                        radii[i, j] = 1.0
                        continue
                    # From joint i's origin (in body i + 1) to body j's frame: the origins
                    # of joints i + 1 .. j - 1, each turned but of fixed length, plus the
                    # extension of the prismatic joints among i + 1 .. j - 1.
                    between = range(i + 1, j)
                    offsets = sum(float(np.linalg.norm(shift[k])) for k in between)
                    slides = sum(float(reach[k]) for k in between if prismatic[k])
                    radii[i, j] = offsets + slides + body_radii[j]
            radii.setflags(write=False)
            self._arrays["motion_radii"] = radii
        return self._arrays["motion_radii"]

    def relative_motion_radii(self, pairs: np.ndarray) -> np.ndarray:
        """``(P, dim)`` bounds on how fast body ``b`` moves relative to body ``a`` per pair.

        Entry ``[p, i]`` is ``R[i, b]`` for the joints between the two bodies
        (``a <= i < b``) and 0 for the others, which move both bodies as one rigid body.
        """
        radii = self.motion_radii()
        out = np.zeros((len(pairs), self.dim))
        for p, (a, b) in enumerate(np.asarray(pairs, dtype=np.int64).reshape(-1, 2)):
            out[p, a:b] = radii[a:b, b]
        return out

    def reach(self) -> float:
        """A bound (m) on how far any point of the arm gets from the base's origin."""
        shift = self.chain.joint_origins[:, :3, 3]
        slides = np.abs(self.chain.joint_limits).max(axis=0)
        slides = slides[self.chain.joint_types == PRISMATIC].sum()
        offsets = float(np.linalg.norm(shift, axis=1).sum()) + float(slides)
        return offsets + float(self.body_radii()[1:].max())

    # ---------------------------------------------------------------- derived data
    def derived_data(self) -> dict:
        """The derived data; raises `ArmDataError` when it has not been built."""
        if self.derived is None:
            raise ArmDataError(f"{self.name}: derived data not loaded")
        return self.derived

    def enabled_pairs(self) -> np.ndarray:
        """``(P, 2)`` body pairs tested for self-collision (lower body first)."""
        pairs = [entry["bodies"] for entry in self.derived_data()["acm"]["pairs"]
                 if entry["reason"] == "enabled"]  # fmt: skip
        return np.array(pairs, dtype=np.int64).reshape(-1, 2)

    def pair_name(self, a: int, b: int) -> tuple[str, str]:
        """The chain links that name bodies ``a`` and ``b``."""
        return self.body_names[a], self.body_names[b]


def source_digest(description: RobotDescription, chain: ArmChain) -> str:
    """SHA-256 of everything the derived data is computed from.

    The description's meaning, the URDF, the SRDF and every mesh file, and the derived format.
    """
    digest = hashlib.sha256()
    digest.update(f"format {DERIVED_FORMAT}\n".encode())
    digest.update(description.digest().encode())
    digest.update(chain.urdf.read_bytes())
    if description.srdf is not None:
        digest.update(description.srdf.read_bytes())
    for elements in chain.elements:
        for element in elements:
            if element.kind == "mesh":
                mesh = resolve_mesh(element.mesh, chain.urdf)
                digest.update(mesh.read_bytes())
                if mesh.suffix.lower() == ".dae":  # data built before its unit was applied
                    digest.update(b"unit applied\n")
    if any(element.link in chain.above_base for element in chain.elements[0]):
        digest.update(b"links above the base folded\n")  # data built before they were
    return digest.hexdigest()


_LOCK = threading.Lock()


@functools.lru_cache(maxsize=16)
def _load(path: Path, stamp: tuple, require_derived: bool) -> ArmModel:
    description = load_description(path)
    chain = read_chain(description.urdf, description.base_link, description.tip_link,
                       dict(description.fixed_joints), dict(description.joint_limits))  # fmt: skip
    geometry = tuple(body_geometry(elements, chain.urdf) for elements in chain.elements)
    derived = None
    derived_path = description.derived_path
    if derived_path.is_file():
        try:
            derived = json.loads(derived_path.read_text())
        except (OSError, ValueError):
            raise ArmDataError(f"{derived_path.name}: unreadable; run temp-robot build "
                               f"{path}") from None  # fmt: skip
        if derived.get("source_digest") != source_digest(description, chain):
            if require_derived:
                raise ArmDataError(
                    f"{derived_path.name}: made from another description, URDF or mesh, or by "
                    f"another version of temp-gym; run temp-robot build {path}"
                )
            derived = None
    elif require_derived:
        raise ArmDataError(f"{description.name}: no derived data ({derived_path.name}); run "
                           f"temp-robot build {path}")  # fmt: skip
    arm = ArmModel(description, chain, geometry, derived)
    arm._arrays["urdf_stamp"] = _stamp(chain.urdf)
    return arm


def _stamp(path: Path) -> tuple[int, int] | None:
    """A file's modification time and size (None: no file), to tell an edited file."""
    try:
        stat = path.stat()
    except OSError:
        return None
    return stat.st_mtime_ns, stat.st_size


def resolved_path(path: str | Path) -> Path:
    """``path`` made absolute with its links resolved, as `Path.resolve` does.

    Remembered per path (and working directory, for a relative one): a checker is built for
    every plan, and resolving walks every folder of the path.
    """
    path = os.path.expanduser(os.fspath(path))
    return _resolved(path, "" if os.path.isabs(path) else os.getcwd())


@functools.lru_cache(maxsize=256)
def _resolved(path: str, cwd: str) -> Path:
    return Path(cwd, path).resolve()


def load_arm(path: str | Path, require_derived: bool = True) -> ArmModel:
    """The arm described at ``path``, cached per file and content (module docstring).

    Raises:
        DescriptionError, UrdfError: a bad description or URDF (one line).
        ArmDataError: the derived data is missing or stale (``require_derived``).
    """
    path = resolved_path(path)
    stamp = (_stamp(path), _stamp(path.with_name(path.stem + ".derived.json")))
    with _LOCK:
        arm = _load(path, stamp, require_derived)
        if arm._arrays["urdf_stamp"] != _stamp(arm.chain.urdf):  # the URDF was edited since
            _load.cache_clear()
            arm = _load(path, stamp, require_derived)
        return arm


__all__ = [
    "COLLISION_PADDING",
    "DERIVED_FORMAT",
    "ArmDataError",
    "ArmModel",
    "load_arm",
    "source_digest",
]
