"""An arm's `RobotSpec` from its robot description: every arm is this code plus its data.

`arm_spec` reads the description (and only the URDF's joints, cheaply) and returns a spec whose
checkers, generators and renderer are the generic arm's, bound to the description by path.
Nothing loads meshes or compiles kernels until the robot is used; the spec pickles (worker
processes and Ray ship it by path, and a worker that has never seen the robot registers it
on first use, `ArmPart`).

Example:
    >>> spec = register_robot_file("my_arm.yaml")   # after `temp-robot build my_arm.yaml`
    >>> spec.env_id
    'TEMP-MyArm-v0'
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from temp_gym.worlds.arm.description import DescriptionError, load_description
from temp_gym.worlds.arm.urdf import read_chain
from temp_gym.worlds.robots.spec import RobotSpec

ARM_COMPILE_MINUTES = 2.0
"""Roughly how long an arm's planner kernels take to compile on first use."""


@dataclass(frozen=True)
class ArmPart:
    """One factory of an arm's spec (a checker, a generator, the renderer, the limits).

    Bound to the arm's description file; picklable, and loads nothing until called.
    """

    description: str
    part: str

    def arm(self):
        """The arm, loaded (cached per process)."""
        from temp_gym.worlds.arm.model import load_arm

        return load_arm(self.description)

    def __call__(self, *args, **kwargs):
        """Build or draw the part (see `arm_spec`)."""
        ensure_registered(self.description)
        if self.part == "checker":
            workspace, exact = args
            return make_arm_checker(self.arm(), workspace, exact)
        if self.part == "joint_limits":
            return self.arm().joint_limits()
        if self.part == "workspace":
            from temp_gym.worlds.arm_world import generate_arm_workspace

            return generate_arm_workspace(*args, **kwargs)
        if self.part == "task":
            from temp_gym.worlds.arm_world import generate_arm_task

            return generate_arm_task(*args, **kwargs)
        if self.part == "structured":
            from temp_gym.worlds.arm_structured import generate_arm_structured_workspace

            return generate_arm_structured_workspace(*args, **kwargs)
        if self.part == "renderer":
            from temp_gym.worlds.rendering.arm import ArmRenderer

            return ArmRenderer(self.arm())
        raise ValueError(f"part: unknown {self.part!r}")


def make_arm_checker(arm, workspace, exact: bool = False):
    """The fast (default) or exact checker of ``workspace`` for ``arm``, every obstacle kind."""
    from temp_gym.worlds.collision.arm_obstacles import arm_obstacles

    obstacles = arm_obstacles(workspace)
    if exact:
        from temp_gym.worlds.collision.arm_exact import ArmExactChecker

        return ArmExactChecker(arm, workspace.bounds, obstacles=obstacles)
    from temp_gym.worlds.collision.arm_fast import ArmSphereChecker

    return ArmSphereChecker(arm, workspace.bounds, obstacles=obstacles)


def default_region(reach: float, drop: float = 0.0) -> np.ndarray:
    """The occupancy grid's box around an arm of this reach (base at the origin, z up).

    Its floor goes down with the arm's scene (``drop``, `temp_gym.worlds.arm_world.scene_drop`),
    so that the policy sees the floor and furniture of an arm whose base reaches below z = 0.
    """
    return np.array([[-1.1 * reach, -1.1 * reach, drop - 0.15 * reach],
                     [1.1 * reach, 1.1 * reach, 1.25 * reach]])  # fmt: skip


def arm_spec(path: str | Path) -> RobotSpec:
    """The `RobotSpec` of the arm described at ``path`` (module docstring).

    Raises:
        DescriptionError, UrdfError: a bad description or URDF (one line).
    """
    description = load_description(path)
    chain = read_chain(description.urdf, description.base_link, description.tip_link,
                       dict(description.fixed_joints), dict(description.joint_limits))  # fmt: skip
    key = str(description.path)
    region = description.encoding_region
    if region is None:
        from temp_gym.worlds.arm.model import load_arm
        from temp_gym.worlds.arm_world import scene_drop

        arm = load_arm(key, require_derived=False)
        region = default_region(arm.reach(), scene_drop(arm))
    return RobotSpec(
        name=description.name,
        env_id=description.env_id,
        short_name=description.short_name,
        seed_code=description.seed_code,
        dim=chain.dim,
        workspace_dim=3,
        encoding_resolution=description.encoding_resolution,
        goal_radius=description.goal_radius,
        max_nodes=description.max_nodes,
        evaluation_rows=dict(description.evaluation_rows),
        evaluation_tasks=description.evaluation_tasks,
        checker_factory=ArmPart(key, "checker"),
        workspace_generator=ArmPart(key, "workspace"),
        task_generator=ArmPart(key, "task"),
        structured_generator=ArmPart(key, "structured"),
        renderer_factory=ArmPart(key, "renderer"),
        step_size=description.step_size,
        encoding_region=np.asarray(region, dtype=np.float64),
        joint_limits=ArmPart(key, "joint_limits"),
        description=description.path,
        compile_minutes=ARM_COMPILE_MINUTES,
    )


def ensure_registered(path: str | Path) -> RobotSpec:
    """The spec of the arm at ``path``, registered if it was not yet.

    A worker process that receives an arm's problem registers the arm on first use (its env
    is registered by `temp_gym.register_robot_file`, in the package's face). The same file
    again gives the registered spec; the file edited since is refused (`DescriptionError`):
    a registered robot cannot change under the objects that already use it.
    """
    from temp_gym.worlds.arm.model import resolved_path
    from temp_gym.worlds.robots import register_robot, robot_specs

    resolved = resolved_path(path)
    content = _meaning(resolved)
    for spec in robot_specs():
        if spec.description is not None and Path(spec.description) == resolved:
            if _REGISTERED.get(resolved, content) != content:
                raise DescriptionError(
                    f"{resolved.name}: changed since robot {spec.name!r} was registered from it "
                    "in this process; the registered robot cannot change, so start a new "
                    "process to use the edited description"
                )
            return spec
    spec = arm_spec(resolved)
    register_robot(spec)
    _REGISTERED[resolved] = content
    return spec


_REGISTERED: dict[Path, str] = {}
"""What each description file `ensure_registered` registered said then (`_meaning`)."""


def _meaning(path: Path) -> str:
    """A description's validated values as text: an edit of its comments or layout is none.

    Read again only when the file's modification time, size or inode changed, as `load_arm`
    does: every part of an arm's spec asks, a checker for every plan and the joint limits for
    every problem, and parsing the YAML costs about a millisecond.
    """
    try:
        stat = path.stat()
    except OSError:
        return _meaning_of(path, None)
    return _meaning_of(path, (stat.st_mtime_ns, stat.st_size, stat.st_ino))


@functools.lru_cache(maxsize=64)
def _meaning_of(path: Path, stamp: tuple[int, int, int] | None) -> str:
    import dataclasses
    import json

    values = dataclasses.asdict(load_description(path))
    return json.dumps(values, sort_keys=True, default=lambda value: np.asarray(value).tolist()
                      if isinstance(value, np.ndarray) else str(value))  # fmt: skip


def robot_digest(path: str | Path) -> str:
    """SHA-256 of the arm described at ``path``: its description's values and its sources.

    The sources are what its derived data is made from (URDF, SRDF, meshes:
    `temp_gym.worlds.arm.model.source_digest`). A dataset records it, so that a run resumed
    after any of them was edited is refused rather than mixing two robots' demonstrations.

    Raises:
        DescriptionError, UrdfError: a bad description or URDF (one line).
    """
    import hashlib

    from temp_gym.worlds.arm.model import load_arm, resolved_path, source_digest

    resolved = resolved_path(path)
    arm = load_arm(resolved, require_derived=False)
    digest = hashlib.sha256(_meaning(resolved).encode())
    digest.update(source_digest(arm.description, arm.chain).encode())
    return digest.hexdigest()


def register_robot_file(path: str | Path) -> RobotSpec:
    """Register the arm described at ``path`` under its name; return its spec.

    A problem file then names it in ``"robot"``. Registering the same file again returns the
    registered spec.

    Raises:
        DescriptionError, UrdfError: a bad description or URDF (one line).
        ArmDataError: its derived data is missing or stale (run ``temp-robot build``).
        ValueError: another robot already has its name, env id, short name or seed code.
    """
    from temp_gym.worlds.arm.model import load_arm

    if not isinstance(path, (str, os.PathLike)) or not str(path).strip():
        raise DescriptionError(f"path: expected a robot description file (YAML), got "
                               f"{type(path).__name__} {path!r:.60}")  # fmt: skip
    load_arm(path)  # refuse a robot whose derived data is missing or stale, now
    return ensure_registered(path)


__all__ = ["ArmPart", "arm_spec", "ensure_registered", "make_arm_checker",
           "register_robot_file", "robot_digest"]  # fmt: skip
