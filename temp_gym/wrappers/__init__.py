"""Wrappers that measure planning episodes: `PlanningMetrics` and `TensorBoardMetrics`."""

from temp_gym.wrappers.metrics import EPISODE_KEYS, PlanningMetrics
from temp_gym.wrappers.tensorboard import TensorBoardMetrics

__all__ = ["EPISODE_KEYS", "PlanningMetrics", "TensorBoardMetrics"]
