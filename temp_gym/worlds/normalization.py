"""The map between a world's configuration space and the normalized [-1, 1]^d of actions.

The model and the env's action and observation speak normalized coordinates; the world keeps
its own units (DESIGN.md, "Data shapes worth fixing early"). Lengths the model reads are
ratios: the goal radius over the mean half-range of the bounds (`goal_radius_ratio`).
"""

from __future__ import annotations

import numpy as np

MAX_RATIO = 100.0
"""Upper bound of the ratio observations (``goal_radius``, ``best_cost``); larger is clipped."""


def normalize(states: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """World states -> [-1, 1]^d (bounds map to -1 and 1)."""
    low, high = bounds
    return 2.0 * (np.asarray(states, dtype=np.float64) - low) / (high - low) - 1.0


def denormalize(actions: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """[-1, 1]^d -> world states."""
    low, high = bounds
    return low + 0.5 * (np.asarray(actions, dtype=np.float64) + 1.0) * (high - low)


def half_range(bounds: np.ndarray) -> np.ndarray:
    """Half the side of the bounds per dimension: world length per normalized unit."""
    return 0.5 * (bounds[1] - bounds[0])


def goal_radius_ratio(goal_radius: float, bounds: np.ndarray) -> float:
    """The goal radius as the model reads it: over the mean half-range, clipped at `MAX_RATIO`.

    The observation, the demonstrations and the policy's task all use this one ratio.
    """
    halves = half_range(bounds)  # np.mean's sum and division, without its Python overhead
    return min(float(goal_radius) / (float(np.add.reduce(halves)) / halves.shape[0]), MAX_RATIO)
