"""Validation of the iiwa checkers' inputs: one place for the shapes and the error messages."""

from __future__ import annotations

import numpy as np

from temp_gym.worlds.iiwa14.kinematics import NUM_JOINTS, as_configs, joint_limits


def as_boxes(box_lower: np.ndarray, box_upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Validated ``(M, 3)`` float64 box corners."""
    lower = np.ascontiguousarray(box_lower, dtype=np.float64)
    upper = np.ascontiguousarray(box_upper, dtype=np.float64)
    if lower.size == 0 and upper.size == 0:
        return np.zeros((0, 3)), np.zeros((0, 3))
    if lower.ndim != 2 or lower.shape[1] != 3 or lower.shape != upper.shape:
        raise ValueError(
            f"box_lower, box_upper: expected two (M, 3) arrays, got {lower.shape}, {upper.shape}"
        )
    if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
        raise ValueError("box_lower, box_upper: contain NaN or inf")
    if np.any(lower > upper):
        raise ValueError("box_lower, box_upper: a lower corner is above its upper corner")
    return lower, upper


def as_bounds(bounds: np.ndarray) -> np.ndarray:
    """Validated ``(2, 7)`` float64 joint bounds ``[lower, upper]``."""
    bounds = np.ascontiguousarray(bounds, dtype=np.float64)
    if bounds.shape != (2, NUM_JOINTS):
        raise ValueError(f"bounds: expected shape (2, {NUM_JOINTS}), got {bounds.shape}")
    if not np.all(np.isfinite(bounds)) or np.any(bounds[0] > bounds[1]):
        raise ValueError("bounds: must be finite with lower <= upper")
    return bounds


def within_joint_limits(bounds: np.ndarray) -> np.ndarray:
    """``bounds`` cut to the URDF joint limits (lower > upper where they do not overlap)."""
    limits = joint_limits()
    return np.ascontiguousarray(
        np.stack([np.maximum(bounds[0], limits[0]), np.minimum(bounds[1], limits[1])])
    )


def as_states(states: np.ndarray, name: str = "states") -> np.ndarray:
    """``(N, 7)`` float64 states (one ``(7,)`` state becomes ``(1, 7)``); ``name`` is the field."""
    return as_configs(states, name)


def as_state(state: np.ndarray, name: str) -> np.ndarray:
    """One ``(7,)`` float64 state; ``name`` is the field named in the error."""
    state = np.ascontiguousarray(state, dtype=np.float64)
    if state.shape != (NUM_JOINTS,):
        raise ValueError(f"{name}: expected shape ({NUM_JOINTS},), got {state.shape}")
    return state


__all__ = ["as_bounds", "as_boxes", "as_state", "as_states", "within_joint_limits"]
