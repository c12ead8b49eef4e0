"""The robots: one `RobotSpec` per robot, each in its own file, and the registry of them.

| robot | file | env id |
|---|---|---|
| ``point2d`` | `point2d` (via `point`) | ``TEMP-2D-v0`` |
| ``point3d`` | `point3d` (via `point`) | ``TEMP-3D-v0`` |
| ``kuka_iiwa14`` | `kuka_iiwa14` (``descriptions/kuka_iiwa14.yaml``) | ``TEMP-7D-v0`` |
| ``franka_panda`` | `franka_panda` (``descriptions/franka_panda.yaml``) | ``TEMP-Panda-v0`` |

**Adding an arm** needs no code: write its robot description (a YAML file naming its URDF,
base and tip links), run ``temp-robot build`` on it, and register it with
`temp_gym.register_robot_file` (the built-in arms are such descriptions, in ``descriptions/``,
registered below).

**Adding another kind of robot** is one file and one registry line:

1. a file here that builds its `RobotSpec`: dimensions, defaults, and the factories of its
   checkers (a `temp_gym.worlds.collision.CollisionChecker`; one with a
   ``compiled_context()`` also runs in the compiled attention loop, any other is driven from
   Python), workspace and task generators, and renderer;
2. its entry in `BUILT_IN` below (a robot of another package calls `register_robot` instead,
   then `temp_gym.envs.register_envs` for its env).

Everything else (problems, the env, planners, data, training, evaluation) reads the spec:
``tests/worlds/test_new_robot.py`` defines a robot in a test file alone and plans, steps the
env and draws with it.
"""

from __future__ import annotations

from temp_gym.problem import register_robot as _register_in_problems
from temp_gym.problem import robot_named, robot_names, unregister_robot
from temp_gym.worlds.robots.franka_panda import FRANKA_PANDA
from temp_gym.worlds.robots.kuka_iiwa14 import KUKA_IIWA14
from temp_gym.worlds.robots.point2d import POINT2D
from temp_gym.worlds.robots.point3d import POINT3D
from temp_gym.worlds.robots.spec import RobotSpec

BUILT_IN: tuple[RobotSpec, ...] = (POINT2D, POINT3D, KUKA_IIWA14, FRANKA_PANDA)
"""The robots registered when `temp_gym` is imported."""


IDENTITY_FIELDS = ("name", "env_id", "short_name", "seed_code")
"""The fields no two registered robots may share (a robot spec's, or a description's)."""


def identity_clash(robot: object, others: list[RobotSpec]) -> tuple[str, RobotSpec] | None:
    """The first of `IDENTITY_FIELDS` that ``robot`` shares with one of ``others``, and that one."""
    for other in others:
        for field in IDENTITY_FIELDS:
            if getattr(other, field) == getattr(robot, field):
                return field, other
    return None


def register_robot(spec: RobotSpec) -> None:
    """Make ``spec`` known by its name everywhere (problems, generators, planners, the env).

    Raises:
        ValueError: another robot has its name, env id, short name or seed code.
    """
    others = robot_specs()
    if any(other is spec for other in others):
        return
    clash = identity_clash(spec, others)
    if clash is not None:
        field, other = clash
        source = "" if other.description is None else f" (from {other.description})"
        raise ValueError(f"robot: {field} {getattr(spec, field)!r} is taken by the "
                         f"registered robot {other.name!r}{source}; give this one "
                         f"another {field}")  # fmt: skip
    _register_in_problems(spec)


def forget_robot(name: str) -> None:
    """Unregister the robot ``name`` (one a test defined, say)."""
    unregister_robot(name)


def robot_spec(name: str) -> RobotSpec:
    """The spec of the registered robot ``name``.

    Raises:
        ValueError: no robot of that name (the message lists the known ones).
    """
    spec = robot_named(name)
    if not isinstance(spec, RobotSpec):
        raise ValueError(f"robot: {name!r} is registered without a RobotSpec")
    return spec


def robot_specs() -> list[RobotSpec]:
    """Every registered spec, in registration order."""
    return [robot_spec(name) for name in robot_names()]


def spec_for_env(env_id: str) -> RobotSpec:
    """The spec of the robot whose env is ``env_id``.

    Raises:
        ValueError: no registered robot has that env.
    """
    specs = robot_specs()
    for spec in specs:
        if spec.env_id == env_id:
            return spec
    raise ValueError(f"env id: unknown {env_id!r}; expected one of {[s.env_id for s in specs]}")


for _spec in BUILT_IN:
    register_robot(_spec)

__all__ = [
    "BUILT_IN",
    "FRANKA_PANDA",
    "IDENTITY_FIELDS",
    "KUKA_IIWA14",
    "POINT2D",
    "POINT3D",
    "RobotSpec",
    "forget_robot",
    "identity_clash",
    "register_robot",
    "robot_spec",
    "robot_specs",
    "spec_for_env",
]
