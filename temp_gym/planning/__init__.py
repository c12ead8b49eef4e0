"""Planning: the shared RRT* tree core, samplers, planner loops and `plan()`.

Each planner has its own settings class, registered with it (`PLANNERS`); the common
settings are `PlanSettings`, which every planner's class extends.
"""

from temp_gym.planning.ompl_planners import (
    OMPLInformedRRTStarSettings,
    OMPLRRTStarSettings,
    OMPLSettings,
)
from temp_gym.planning.plan import plan
from temp_gym.planning.planners import InformedRRTStarSettings, RRTStarSettings
from temp_gym.planning.registry import PLANNERS, Planner, register_planner
from temp_gym.planning.result import PlanResult
from temp_gym.planning.samplers import GoalBiasedSampler, InformedSampler, UniformSampler
from temp_gym.planning.settings import PlanSettings
from temp_gym.planning.temp_settings import TEMPSettings
from temp_gym.planning.tree import ExtendResult, Tree, default_step_size

__all__ = [
    "PLANNERS",
    "ExtendResult",
    "GoalBiasedSampler",
    "InformedRRTStarSettings",
    "InformedSampler",
    "OMPLInformedRRTStarSettings",
    "OMPLRRTStarSettings",
    "OMPLSettings",
    "PlanResult",
    "PlanSettings",
    "Planner",
    "RRTStarSettings",
    "TEMPSettings",
    "Tree",
    "UniformSampler",
    "default_step_size",
    "plan",
    "register_planner",
]
