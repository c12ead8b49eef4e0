"""Planning: the shared RRT* tree core, samplers, planner loops and `plan()`.

Each planner has its own settings class, registered with it (`PLANNERS`); the common
settings are `PlanSettings`, which every planner's class extends.

Importing this package imports nothing heavy: each name is imported from its module when
first used, so the settings classes (`PlanSettings`, `TEMPSettings`) load without numba, and a
command can check its flags against them before it loads the planners. `PLANNERS`,
`register_planner` and `plan` load `temp_gym.planning.plan`, which registers the built-in
planners.
"""

import sys
from importlib import import_module
from types import ModuleType

_HOMES = {
    "ExtendResult": "tree",
    "GoalBiasedSampler": "samplers",
    "InformedRRTStarSettings": "planners",
    "InformedSampler": "samplers",
    "OMPLBITStarSettings": "ompl_planners",
    "OMPLInformedRRTStarSettings": "ompl_planners",
    "OMPLRRTConnectSettings": "ompl_planners",
    "OMPLRRTStarSettings": "ompl_planners",
    "OMPLSettings": "ompl_planners",
    "PLANNERS": "registry",
    "PlanResult": "result",
    "PlanSettings": "settings",
    "Planner": "registry",
    "RRTConnectSettings": "rrt_connect",
    "RRTStarSettings": "planners",
    "TEMPSettings": "temp_settings",
    "Tree": "tree",
    "UniformSampler": "samplers",
    "default_step_size": "tree",
    "plan": "plan",
    "register_planner": "registry",
    "simplify_path": "simplify",
}
"""Public name -> the module of this package that defines it."""

_REGISTERED = {"PLANNERS", "Planner", "register_planner"}
"""Names read from the registry only once the built-in planners are in it."""

__all__ = sorted(_HOMES)


def __getattr__(name: str):
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'temp_gym.planning' has no attribute {name!r}")
    if name in _REGISTERED:
        import_module("temp_gym.planning.plan")  # registers the built-in planners
    return getattr(import_module(f"temp_gym.planning.{home}"), name)


def __dir__() -> list[str]:
    return sorted({*globals(), *_HOMES})


class _Package(ModuleType):
    """This package as a module whose ``plan`` is always the function.

    The import system binds a submodule, once loaded, as an attribute of its package, so
    importing `temp_gym.planning.plan` (which the lazy names above do) would hide the function
    ``plan`` behind the module of the same name. The property keeps the function; the setter
    ignores that binding (the module stays in ``sys.modules``).
    """

    @property
    def plan(self):
        """`temp_gym.planning.plan.plan`, the function."""
        return import_module("temp_gym.planning.plan").plan

    @plan.setter
    def plan(self, value: object) -> None:
        if not isinstance(value, ModuleType):
            raise AttributeError("temp_gym.planning.plan: register a planner instead")


sys.modules[__name__].__class__ = _Package
