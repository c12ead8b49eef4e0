"""Validation of the checkers' inputs: one place for the shapes and the error messages.

The arm checkers use all of it; the point checkers share the states', edges' and paths'.
"""

from __future__ import annotations

import numpy as np


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


def as_bounds(bounds: np.ndarray, dim: int) -> np.ndarray:
    """Validated ``(2, dim)`` float64 joint bounds ``[lower, upper]``."""
    bounds = np.ascontiguousarray(bounds, dtype=np.float64)
    if bounds.shape != (2, dim):
        raise ValueError(f"bounds: expected shape (2, {dim}), got {bounds.shape}")
    if not np.all(np.isfinite(bounds)) or np.any(bounds[0] > bounds[1]):
        raise ValueError("bounds: must be finite with lower <= upper")
    return bounds


def within_limits(bounds: np.ndarray, limits: np.ndarray) -> np.ndarray:
    """``bounds`` cut to the joint ``limits`` (lower > upper where they do not overlap)."""
    return np.ascontiguousarray(
        np.stack([np.maximum(bounds[0], limits[0]), np.minimum(bounds[1], limits[1])])
    )


def _real_array(value: object, name: str) -> np.ndarray:
    """``value`` as a contiguous float64 array of real numbers, or a `ValueError` naming it.

    Booleans, complex numbers and text are refused: numpy would turn them into numbers
    silently (a complex state loses its imaginary part, ``True`` becomes 1).
    """
    if value is None:
        raise ValueError(f"{name}: expected an array of numbers, got None")
    try:
        array = np.asarray(value)
    except ValueError:  # ragged nested lists
        raise ValueError(f"{name}: expected an array of numbers, got ragged rows") from None
    if array.dtype.kind not in "iuf":
        if array.dtype.kind != "O" or not _all_reals(array):
            raise ValueError(f"{name}: expected real numbers, got an array of {array.dtype}")
    return np.ascontiguousarray(array, dtype=np.float64)


def _all_reals(array: np.ndarray) -> bool:
    """Whether every entry of an object array is a real number (not a bool)."""
    return all(
        isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))
        for v in array.flat
    )


def as_states(states: np.ndarray, dim: int, name: str = "states") -> np.ndarray:
    """``(N, dim)`` float64 states (one ``(dim,)`` state becomes ``(1, dim)``)."""
    if type(states) is np.ndarray and states.dtype == np.float64 and states.ndim == 2:
        if states.shape[1] == dim:  # the planners' own arrays: no conversion to check
            return np.ascontiguousarray(states)
    states = _real_array(states, name)
    if states.ndim == 1:  # one state, or none at all
        states = states.reshape(1, -1) if states.size else states.reshape(0, dim)
    if states.ndim != 2 or states.shape[1] != dim:
        raise ValueError(f"{name}: expected shape (N, {dim}), got {states.shape}")
    return states


def as_state(state: np.ndarray, name: str, dim: int) -> np.ndarray:
    """One ``(dim,)`` float64 state; ``name`` is the field named in the error."""
    if type(state) is np.ndarray and state.dtype == np.float64 and state.shape == (dim,):
        return np.ascontiguousarray(state)  # the planners' own arrays: no conversion to check
    state = _real_array(state, name)
    if state.shape != (dim,):
        raise ValueError(f"{name}: expected shape ({dim},), got {state.shape}")
    return state


def as_edges(starts: np.ndarray, ends: np.ndarray, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """``(N, dim)`` starts and ends of N edges; one state on either side is shared by all."""
    starts = as_states(starts, dim, "starts")
    ends = as_states(ends, dim, "ends")
    if starts.shape != ends.shape:
        if len(starts) != 1 and len(ends) != 1:
            raise ValueError(
                f"starts, ends: expected as many rows, or one on either side, got "
                f"{starts.shape} and {ends.shape}"
            )
        starts, ends = (np.ascontiguousarray(a) for a in np.broadcast_arrays(starts, ends))
    return starts, ends


def as_path(path: np.ndarray, dim: int) -> np.ndarray:
    """A polyline's ``(K, dim)`` float64 states, K >= 1."""
    path = as_states(path, dim, "path")
    if len(path) == 0:
        raise ValueError("path: expected at least one state")
    return path


__all__ = ["as_bounds", "as_boxes", "as_edges", "as_path", "as_state", "as_states", "within_limits"]
