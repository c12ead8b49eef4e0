"""Gymnasium environments: `PlanningEnv` and one registered id per robot (``TEMP-{2,3,7}D-v0``)."""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from temp_gym.worlds.robots import robot_specs


def register_envs() -> None:
    """Register every registered robot's env id once (importing `temp_gym` does this).

    A robot registered later (`temp_gym.worlds.robots.register_robot`) gets its env by
    calling this again.
    """
    for spec in robot_specs():
        if spec.env_id not in registry:
            register(
                id=spec.env_id,
                entry_point="temp_gym.envs.planning_env:PlanningEnv",
                kwargs={"robot": spec.name},
            )


ENV_IDS = [spec.env_id for spec in robot_specs()]
"""The built-in robots' env ids."""


def __getattr__(name: str):
    if name == "PlanningEnv":  # lazy: importing the package should stay light
        from temp_gym.envs.planning_env import PlanningEnv

        return PlanningEnv
    raise AttributeError(name)


__all__ = ["ENV_IDS", "PlanningEnv", "register_envs"]
