"""temp-gym: sampling-based motion planning as Gymnasium environments, and TEMP.

Importing the package registers ``TEMP-2D-v0``, ``TEMP-3D-v0`` and ``TEMP-7D-v0``.
"""

from temp_gym.worlds import robots  # registers the built-in robots  # noqa: I001
from temp_gym.envs import ENV_IDS, register_envs
from temp_gym.planning import (
    PLANNERS,
    InformedRRTStarSettings,
    OMPLSettings,
    PlanResult,
    PlanSettings,
    RRTStarSettings,
    TEMPSettings,
    plan,
    register_planner,
)
from temp_gym.planning.temp_planner import set_default_policy
from temp_gym.problem import Problem

register_envs()


def _shipped_policy(robot: str):
    """The ``temp`` planner's default policy: the one shipped for ``robot`` (imports torch)."""
    from temp_gym.models.registry import shipped_policy

    return shipped_policy(robot)


set_default_policy(_shipped_policy)  # the planning layer imports no model code itself

__all__ = [
    "ENV_IDS",
    "PLANNERS",
    "InformedRRTStarSettings",
    "OMPLSettings",
    "PlanResult",
    "PlanSettings",
    "Problem",
    "RRTStarSettings",
    "TEMPSettings",
    "load_policy",
    "plan",
    "register_planner",
    "robots",
]


def __getattr__(name: str):
    if name == "load_policy":  # lazy: importing temp_gym does not import torch
        from temp_gym.models.registry import load_policy

        return load_policy
    raise AttributeError(f"module 'temp_gym' has no attribute {name!r}")


__version__ = "0.1.0"
