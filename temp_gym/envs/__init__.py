"""Gymnasium environments: `PlanningEnv` and the registered ids ``TEMP-{2,3,7}D-v0``."""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

ENV_ROBOTS = {"TEMP-2D-v0": "point2d", "TEMP-3D-v0": "point3d", "TEMP-7D-v0": "kuka_iiwa14"}
"""Registered id -> robot."""
ENV_IDS = list(ENV_ROBOTS)


def register_envs() -> None:
    """Register every id once (importing `temp_gym` does this)."""
    for env_id, robot in ENV_ROBOTS.items():
        if env_id not in registry:
            register(
                id=env_id,
                entry_point="temp_gym.envs.planning_env:PlanningEnv",
                kwargs={"robot": robot},
            )


def __getattr__(name: str):
    if name == "PlanningEnv":  # lazy: importing the package should stay light
        from temp_gym.envs.planning_env import PlanningEnv

        return PlanningEnv
    raise AttributeError(name)


__all__ = ["ENV_IDS", "ENV_ROBOTS", "PlanningEnv", "register_envs"]
