"""Wrappers that measure planning episodes: `PlanningMetrics` and `TensorBoardMetrics`."""

from temp_gym.wrappers.metrics import EPISODE_KEYS, INFO_KEY, PlanningMetrics
from temp_gym.wrappers.tensorboard import TensorBoardMetrics

__all__ = ["EPISODE_KEYS", "INFO_KEY", "PlanningMetrics", "TensorBoardMetrics"]
