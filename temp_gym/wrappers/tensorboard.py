"""`TensorBoardMetrics`: log each planning episode's statistics to TensorBoard."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from temp_gym.tensorboard_summaries import add_scalar
from temp_gym.wrappers.metrics import EPISODE_DESCRIPTIONS, EPISODE_KEYS, INFO_KEY, PlanningMetrics


class TensorBoardMetrics(gym.Wrapper):
    """Write ``{prefix}/{key}`` scalars for every finished episode (keys: `EPISODE_KEYS`).

    Wraps the env in `PlanningMetrics` unless it already is. The step of each scalar is the
    episode index. ``cost`` is logged only for successful episodes (inf does not plot). Each
    tag carries its description (`EPISODE_DESCRIPTIONS`), shown beside its chart.

    Args:
        env: the env to measure.
        log_dir: where the event files go (a `SummaryWriter` is created), or
        writer: an existing ``torch.utils.tensorboard.SummaryWriter`` to share.
        prefix: tag group, e.g. ``eval`` or ``train``.
    """

    def __init__(
        self,
        env: gym.Env,
        log_dir: str | Path | None = None,
        writer: Any = None,
        prefix: str = "eval",
    ) -> None:
        if not _has_wrapper(env, PlanningMetrics):
            env = PlanningMetrics(env)
        super().__init__(env)
        if writer is None:
            if log_dir is None:
                raise ValueError("TensorBoardMetrics needs a log_dir or a writer")
            from torch.utils.tensorboard import SummaryWriter

            writer = SummaryWriter(log_dir=str(log_dir))
            self._owns_writer = True
        else:
            self._owns_writer = False
        self.writer = writer
        self.prefix = prefix
        self.episodes = 0
        self._described: set[str] = set()

    def step(self, action):
        """Step, and log the episode when it ends."""
        observation, reward, terminated, truncated, info = super().step(action)
        if INFO_KEY in info:
            episode = info[INFO_KEY]
            for key in EPISODE_KEYS:
                value = float(episode[key])
                if np.isfinite(value):
                    tag = f"{self.prefix}/{key}"
                    first = tag not in self._described
                    description = (
                        f"Per planning episode (step: episode index): {EPISODE_DESCRIPTIONS[key]}."
                    )
                    add_scalar(
                        self.writer, tag, value, self.episodes, description if first else None
                    )
                    self._described.add(tag)
            self.episodes += 1
        return observation, reward, terminated, truncated, info

    def close(self) -> None:
        """Flush and close the writer (if this wrapper made it) and the env."""
        if self._owns_writer and self.writer is not None:
            self.writer.close()
            self.writer = None
        super().close()


def _has_wrapper(env: gym.Env, kind: type) -> bool:
    while isinstance(env, gym.Wrapper):
        if isinstance(env, kind):
            return True
        env = env.env
    return False
