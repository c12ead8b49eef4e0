"""Planning: the shared RRT* tree core, samplers, planner loops and `plan()`."""

from temp_gym.planning.plan import PLANNERS, plan, register_planner
from temp_gym.planning.result import PlanResult, PlanSettings
from temp_gym.planning.samplers import GoalBiasedSampler, InformedSampler, UniformSampler
from temp_gym.planning.tree import ExtendResult, Tree, default_step_size

__all__ = [
    "PLANNERS",
    "ExtendResult",
    "GoalBiasedSampler",
    "InformedSampler",
    "PlanResult",
    "PlanSettings",
    "Tree",
    "UniformSampler",
    "default_step_size",
    "plan",
    "register_planner",
]
