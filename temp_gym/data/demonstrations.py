"""Expert paths into training samples: resampling at the steer step and prefix/next-node pairs.

An expert path ``x0..xn`` from the planner may have edges longer than the env's steering step
(the expert planner may steer with a longer step, and shortcuts through rewiring are long).
The env's policy, though, proposes one step at a time, so the path is first **resampled**:
every edge ``(a, b)`` of length ``l > 0`` is split into ``ceil(l / step)`` equal pieces.
Consecutive points are then at most ``step`` apart, every original vertex is kept, and
zero-length edges (repeated vertices) are dropped. The resampled path ``y0..ym`` gives ``m``
samples: prefix ``y0..yk`` (its last ``L`` nodes) with target ``y(k+1)``, ``k = 0..m-1``.
"""

from __future__ import annotations

import math

import numpy as np

from temp_gym.worlds.normalization import goal_radius_ratio, normalize

_ROUNDING = 1e-9  # an edge of exactly k steps (up to rounding) is split into k pieces, not k + 1


def resample_path(path: np.ndarray, step: float) -> np.ndarray:
    """Split every edge into ``ceil(length / step)`` equal pieces; keep every vertex.

    Examples:
        >>> resample_path(np.array([[0.0, 0.0], [2.5, 0.0]]), 1.0)[:, 0].tolist()
        [0.0, 0.8333333333333334, 1.6666666666666667, 2.5]
    """
    path = np.asarray(path, dtype=np.float64)
    if path.ndim != 2 or len(path) == 0:
        raise ValueError(f"path: expected a non-empty (K, d) array, got shape {path.shape}")
    if not step > 0:
        raise ValueError(f"step: must be positive, got {step}")
    points = [path[:1]]
    for a, b in zip(path[:-1], path[1:]):
        length = float(np.linalg.norm(b - a))
        if length == 0.0:
            continue
        pieces = max(1, math.ceil(length / step - _ROUNDING))
        fractions = np.arange(1, pieces + 1, dtype=np.float64)[:, None] / pieces
        inner = a + fractions[:-1] * (b - a)
        points.append(inner)
        points.append(b[None])
    return np.concatenate(points, axis=0)


def prefix_samples(
    resampled: np.ndarray,
    bounds: np.ndarray,
    max_path_length: int,
) -> dict[str, np.ndarray]:
    """The prefix/next-node arrays of one resampled path ``y0..ym`` (``m`` samples).

    Returns ``step`` (m,), ``path`` (m, L, d) float32 (last ``L`` nodes of ``y0..yk``,
    normalized, zero-padded after the valid rows, as the env's ``path`` observation),
    ``path_length`` (m, 1) and ``target`` (m, d) float32 (``y(k+1)``, normalized).
    """
    points = normalize(resampled, bounds).astype(np.float32)
    count = len(points) - 1
    steps = np.arange(count, dtype=np.int64)
    first = np.maximum(steps - max_path_length + 1, 0)
    lengths = steps - first + 1
    rows = np.arange(max_path_length, dtype=np.int64)
    index = first[:, None] + rows[None, :]
    valid = rows[None, :] < lengths[:, None]
    path = points[np.where(valid, index, 0)]
    path[~valid] = 0.0
    return {
        "step": steps,
        "path": path,
        "path_length": lengths[:, None],
        "target": points[1:].copy(),
    }


def task_samples(
    resampled: np.ndarray,
    start: np.ndarray,
    goal: np.ndarray,
    goal_radius: float,
    bounds: np.ndarray,
    max_path_length: int,
    workspace_id: int,
    task_id: int,
) -> dict[str, np.ndarray]:
    """All samples of one expert path, every key of `temp_gym.data.format.SAMPLE_KEYS`."""
    samples = prefix_samples(resampled, bounds, max_path_length)
    count = len(samples["step"])
    dim = resampled.shape[1]
    samples["workspace_id"] = np.full(count, workspace_id, dtype=np.int64)
    samples["task_id"] = np.full(count, task_id, dtype=np.int64)
    samples["start"] = np.broadcast_to(
        normalize(start, bounds).astype(np.float32), (count, dim)
    ).copy()
    samples["goal"] = np.broadcast_to(
        normalize(goal, bounds).astype(np.float32), (count, dim)
    ).copy()
    samples["goal_radius"] = np.full(
        (count, 1), goal_radius_ratio(goal_radius, bounds), dtype=np.float32
    )
    return samples
