"""Compiled helpers that keep `PlanningEnv.step` close to the cost of a bare tree extension."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def action_to_sample(action, low, high, out) -> bool:
    """Clip ``action`` to [-1, 1] and map it into the bounds; False if any entry is not finite."""
    for k in range(action.shape[0]):
        a = action[k]
        if not np.isfinite(a):
            return False
        a = min(max(a, -1.0), 1.0)
        out[k] = low[k] + 0.5 * (a + 1.0) * (high[k] - low[k])
    return True


@numba.njit(cache=True, nogil=True)
def path_observation(links, positions, node, low, high, max_length):
    """Normalized float32 root path of ``node`` (its last ``max_length`` nodes), zero-padded.

    ``links[:, 0]`` is the parent (-1 at the root), as in `temp_gym.planning.tree.Tree`.
    Walking up from ``node`` meets the newest nodes first, so at most ``max_length`` steps are
    needed. Returns the fresh ``(max_length, d)`` array and the number of valid rows.
    """
    stack = np.empty(max_length, dtype=np.int64)
    length = 0
    while node >= 0 and length < max_length:
        stack[length] = node
        length += 1
        node = links[node, 0]
    dim = positions.shape[1]
    out = np.zeros((max_length, dim), dtype=np.float32)
    for row in range(length):
        index = stack[length - 1 - row]  # the stack runs newest -> oldest
        for k in range(dim):
            out[row, k] = 2.0 * (positions[index, k] - low[k]) / (high[k] - low[k]) - 1.0
    return out, length
