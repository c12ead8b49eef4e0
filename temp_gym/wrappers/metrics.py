"""`PlanningMetrics`: per-episode planning statistics, in the style of RecordEpisodeStatistics."""

from __future__ import annotations

import time
from collections import deque
from typing import Any

import gymnasium as gym
import numpy as np

EPISODE_KEYS = (
    "success",
    "nodes",
    "cost",
    "sampling_failures",
    "samples",
    "collision_checks",
    "wall_time",
    "steps",
    "return",
)
"""Keys of ``info["episode"]``, each documented in `PlanningMetrics`."""


class PlanningMetrics(gym.Wrapper):
    """Put a planning episode's statistics in ``info["episode"]`` when it ends.

    At the step that terminates or truncates an episode, ``info["episode"]`` holds:

    | key | meaning |
    |---|---|
    | ``success`` | whether a solution was found (1.0 or 0.0) |
    | ``nodes`` | tree nodes at the end |
    | ``cost`` | best path cost (world units; inf without a solution) |
    | ``sampling_failures`` | samples whose extension collided |
    | ``samples`` | samples drawn, fallback retries included |
    | ``collision_checks`` | state and edge checks |
    | ``wall_time`` | seconds from `reset` to the last step, as the planner experiences it |
    | ``steps`` | env steps |
    | ``return`` | sum of rewards |

    Like `gymnasium.wrappers.RecordEpisodeStatistics` it works inside vector envs (the vector
    env stacks the entries and adds the ``_episode`` mask) and keeps the last ``buffer_length``
    episodes in ``episode_queues``.
    """

    def __init__(self, env: gym.Env, buffer_length: int = 100) -> None:
        super().__init__(env)
        self.episode_queues: dict[str, deque] = {
            key: deque(maxlen=buffer_length) for key in EPISODE_KEYS
        }
        self._started = 0.0
        self._steps = 0
        self._return = 0.0

    def reset(self, **kwargs: Any):
        """Reset the env and the episode counters."""
        observation, info = super().reset(**kwargs)
        self._started = time.perf_counter()
        self._steps = 0
        self._return = 0.0
        return observation, info

    def step(self, action):
        """Step, and at the episode's end add ``info["episode"]``."""
        observation, reward, terminated, truncated, info = super().step(action)
        self._steps += 1
        self._return += float(reward)
        if terminated or truncated:
            if "episode" in info:
                raise ValueError("info already has an 'episode' key; PlanningMetrics twice?")
            episode = {
                "success": float(info["success"]),
                "nodes": float(info["nodes"]),
                "cost": float(info["best_cost"]),
                "sampling_failures": float(info["sampling_failures"]),
                "samples": float(info["samples"]),
                "collision_checks": float(info["collision_checks"]),
                "wall_time": time.perf_counter() - self._started,
                "steps": float(self._steps),
                "return": self._return,
            }
            info["episode"] = {key: np.float64(value) for key, value in episode.items()}
            for key, value in episode.items():
                self.episode_queues[key].append(value)
        return observation, reward, terminated, truncated, info
