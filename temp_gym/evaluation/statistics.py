"""Robust summaries of per-task figures: medians and means with bootstrap intervals.

Planning times on a shared machine have heavy tails: one stalled task can move a mean by a
factor of two, while the median barely moves. Reporting both, each with a percentile
bootstrap interval over the tasks, says how far a figure can be trusted, and a claim such as
"faster than RRT*" can be read off an interval that excludes 1 rather than off one number.

Example:
    >>> summary = describe([0.010, 0.012, 0.011, 0.250])  # one stall
    >>> summary["median"], summary["mean"]
    (0.0115, 0.07075)
    >>> summary["median_low"] <= summary["median"] <= summary["median_high"]
    True
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

RESAMPLES = 2000
"""Bootstrap resamplings per interval."""
LEVEL = 0.95
"""Coverage of the intervals."""


def bootstrap_interval(
    values: Sequence[float] | np.ndarray,
    statistic: Callable[..., np.ndarray] = np.median,
    resamples: int = RESAMPLES,
    level: float = LEVEL,
    seed: int = 0,
) -> tuple[float, float]:
    """Percentile bootstrap interval of ``statistic`` over ``values`` (resampled with replacement).

    ``statistic`` is called as ``statistic(samples, axis=1)`` on a ``(resamples, n)`` array. The
    resampling draws from ``numpy.random.default_rng(seed)``, so an interval is reproducible.
    Returns ``(nan, nan)`` for no values.
    """
    values = np.asarray(values, dtype=np.float64)
    if values.ndim != 1:
        raise ValueError(f"values: expected a 1-D sequence, got shape {values.shape}")
    if not 0.0 < level < 1.0:
        raise ValueError(f"level: expected a coverage in (0, 1), got {level}")
    if len(values) == 0:
        return math.nan, math.nan
    rng = np.random.default_rng(seed)
    samples = values[rng.integers(0, len(values), (int(resamples), len(values)))]
    tail = 100.0 * (1.0 - level) / 2.0
    low, high = np.percentile(statistic(samples, axis=1), [tail, 100.0 - tail])
    return float(low), float(high)


def describe(values: Sequence[float] | np.ndarray, seed: int = 0) -> dict[str, float]:
    """Median and mean of ``values``, each with its 95% bootstrap interval, and the count.

    Keys: ``n``, ``median``, ``median_low``, ``median_high``, ``mean``, ``mean_low``,
    ``mean_high`` (nan for no values).
    """
    values = np.asarray(values, dtype=np.float64)
    if len(values) == 0:
        nan = math.nan
        return {"n": 0, "median": nan, "median_low": nan, "median_high": nan, "mean": nan,
                "mean_low": nan, "mean_high": nan}  # fmt: skip
    median_low, median_high = bootstrap_interval(values, np.median, seed=seed)
    mean_low, mean_high = bootstrap_interval(values, np.mean, seed=seed)
    return {
        "n": int(len(values)),
        "median": float(np.median(values)),
        "median_low": median_low,
        "median_high": median_high,
        "mean": float(np.mean(values)),
        "mean_low": mean_low,
        "mean_high": mean_high,
    }


def format_interval(summary: dict[str, float], key: str, digits: int = 3) -> str:
    """``"value [low, high]"`` of ``summary[key]`` (`describe`), or ``"-"`` when undefined."""
    value = summary.get(key, math.nan)
    if value is None or not math.isfinite(value):
        return "-"
    low, high = summary[f"{key}_low"], summary[f"{key}_high"]
    return f"{value:.{digits}f} [{low:.{digits}f}, {high:.{digits}f}]"
