"""temp-gym: sampling-based motion planning as Gymnasium environments, and TEMP.

Importing the package registers ``TEMP-2D-v0``, ``TEMP-3D-v0`` and ``TEMP-7D-v0``. The planners
(and numba, which compiles them) load on first use of `plan`, `PlanResult`, `PLANNERS` or
`register_planner`, and the models (and PyTorch) on first use of a policy: importing the
package, and every command's ``--help``, stays light. `PlanSettings` and `TEMPSettings` load
without the planners.
"""

from temp_gym.worlds import robots  # registers the built-in robots  # noqa: I001
from temp_gym import hooks
from temp_gym.envs import ENV_IDS, register_envs
from temp_gym.problem import Box, Cylinder, Problem, Sphere, Workspace

register_envs()


def _shipped_policy(robot: str):
    """The ``temp`` planner's default policy: the one shipped for ``robot`` (imports torch)."""
    from temp_gym.models.registry import shipped_policy

    return shipped_policy(robot)


# The planning layer imports no model code itself: its default policy is handed in, through a
# module that does not load the planners.
hooks.default_policy_loader = _shipped_policy


def register_robot_file(path):
    """Register the arm described at ``path`` (a robot description, YAML) and its env.

    Its derived data must be built (``temp-robot build path``). A problem file then names the
    robot in ``"robot"``, and ``gymnasium.make(spec.env_id)`` makes its env. Registering the
    same file again returns the registered spec.

    Examples:
        >>> spec = temp_gym.register_robot_file("my_arm.yaml")
        >>> spec.name, spec.env_id
        ('my_arm', 'TEMP-MyArm-v0')
    """
    from temp_gym.worlds.arm.spec import register_robot_file as register

    spec = register(path)
    register_envs()
    return spec


def _described_arms() -> tuple[str, ...]:
    """The description files of the arms registered beyond the shipped ones.

    Every process registers the shipped ones at import (`temp_gym.hooks.described_arms`).
    """
    from temp_gym.worlds.robots import BUILT_IN, robot_specs

    return tuple(sorted({str(spec.description) for spec in robot_specs()
                         if spec.description is not None and spec not in BUILT_IN}))  # fmt: skip


hooks.robot_file_loader = register_robot_file
hooks.described_arms = _described_arms

__all__ = [
    "ENV_IDS",
    "PLANNERS",
    "Box",
    "Cylinder",
    "InformedRRTStarSettings",
    "OMPLSettings",
    "PlanResult",
    "PlanSettings",
    "Problem",
    "RRTConnectSettings",
    "RRTStarSettings",
    "Sphere",
    "TEMPSettings",
    "load_policy",
    "plan",
    "register_planner",
    "register_robot_file",
    "robots",
    "Workspace",
]


_PLANNING = {"InformedRRTStarSettings", "OMPLSettings", "PLANNERS", "PlanResult", "PlanSettings",
             "RRTConnectSettings", "RRTStarSettings", "TEMPSettings", "plan",
             "register_planner"}  # fmt: skip
"""Names of `temp_gym.planning`, imported from there on first use."""


def __getattr__(name: str):
    if name in _PLANNING:  # lazy: the planners import numba
        import temp_gym.planning

        return getattr(temp_gym.planning, name)
    if name == "load_policy":  # lazy: importing temp_gym does not import torch
        from temp_gym.models.registry import load_policy

        return load_policy
    raise AttributeError(f"module 'temp_gym' has no attribute {name!r}")


__version__ = "0.2.0.dev0"
