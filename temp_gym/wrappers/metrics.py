"""`PlanningMetrics`: per-episode planning statistics, in the style of RecordEpisodeStatistics.

The statistics go under their own key, ``info["planning"]``, not Gymnasium's
``info["episode"]``: `gymnasium.wrappers.RecordEpisodeStatistics` owns that key (it asserts
that nobody else wrote it), so both wrappers stack in either order.
"""

from __future__ import annotations

import time
from collections import deque
from typing import Any

import gymnasium as gym
import numpy as np

EPISODE_DESCRIPTIONS = {
    "success": "whether a solution was found (1.0 or 0.0)",
    "nodes": "tree nodes at the end",
    "cost": "best path cost (world units; inf without a solution)",
    "sampling_failures": "samples whose extension collided",
    "samples": "samples drawn, fallback retries included",
    "collision_checks": "state and edge checks",
    "wall_time": "seconds from `reset` to the last step, as the planner experiences it",
    "steps": "env steps",
    "return": "sum of rewards",
}
"""What each key of ``info[INFO_KEY]`` holds (the table in `PlanningMetrics`)."""
EPISODE_KEYS = tuple(EPISODE_DESCRIPTIONS)
"""Keys of ``info[INFO_KEY]``, each documented in `PlanningMetrics`."""
INFO_KEY = "planning"
"""Where `PlanningMetrics` puts an episode's statistics in ``info`` (``"episode"`` is
Gymnasium's `RecordEpisodeStatistics`')."""


class PlanningMetrics(gym.Wrapper):
    """Put a planning episode's statistics in ``info["planning"]`` when it ends.

    At the step that terminates or truncates an episode, ``info["planning"]`` holds:

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
    env stacks the entries and adds the ``_planning`` mask) and keeps the last
    ``buffer_length`` episodes in ``episode_queues``. It stacks with
    `RecordEpisodeStatistics` in either order: that wrapper's ``r``, ``l``, ``t`` stay in
    ``info["episode"]``.

    Examples:
        >>> env = PlanningMetrics(RecordEpisodeStatistics(gymnasium.make("TEMP-2D-v0")))
        >>> ...  # at the last step of an episode:
        >>> info["planning"]["nodes"], info["episode"]["l"]
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
        """Step, and at the episode's end add ``info["planning"]``."""
        observation, reward, terminated, truncated, info = super().step(action)
        self._steps += 1
        self._return += float(reward)
        if terminated or truncated:
            if INFO_KEY in info:
                raise ValueError(
                    f"info already has a {INFO_KEY!r} key: is the env wrapped in "
                    "PlanningMetrics twice?"
                )
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
            info[INFO_KEY] = {key: np.float64(value) for key, value in episode.items()}
            for key, value in episode.items():
                self.episode_queues[key].append(value)
        return observation, reward, terminated, truncated, info
