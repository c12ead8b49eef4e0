"""The map between a world's configuration space and the normalized [-1, 1]^d of actions.

The model and the env's action and observation speak normalized coordinates; the world keeps
its own units (DESIGN.md, "Data shapes worth fixing early").
"""

from __future__ import annotations

import numpy as np


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
