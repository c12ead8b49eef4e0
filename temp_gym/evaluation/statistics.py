"""Robust summaries of per-task figures: medians and means with bootstrap intervals.

Planning times on a shared machine have heavy tails: one stalled task can move a mean by a
factor of two, while the median barely moves. Reporting both, each with a percentile
bootstrap interval over the tasks, says how far a figure can be trusted, and a claim such as
"faster than RRT*" can be read off an interval that excludes 1 rather than off one number.

Examples:
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


def paired_capped_difference(
    reference: Sequence[float] | np.ndarray,
    candidate: Sequence[float] | np.ndarray,
    cap: float,
    resamples: int = RESAMPLES,
    level: float = LEVEL,
    seed: int = 0,
) -> dict[str, float]:
    """Two planners' per-task figures on the same tasks, each capped at ``cap``, compared.

    A mean of node counts can be decided by one task of thousands. Capping every task at
    ``cap`` counts such a task as a failure to solve fast, whatever it took, so the mean
    weighs the many ordinary tasks and the number of slow ones rather than the size of the
    slowest. Returns the plain and capped means of both, the capped mean difference
    (``candidate`` minus ``reference``) with its percentile paired bootstrap interval (tasks
    resampled together, from ``default_rng(seed)``), and how many tasks of each exceed ``cap``.
    """
    reference = np.asarray(reference, dtype=np.float64)
    candidate = np.asarray(candidate, dtype=np.float64)
    if reference.ndim != 1 or reference.shape != candidate.shape or len(reference) == 0:
        raise ValueError(
            "expected two non-empty 1-D sequences over the same tasks, got shapes "
            f"{reference.shape} and {candidate.shape}"
        )
    if not (math.isfinite(cap) and cap > 0):
        raise ValueError(f"cap: expected a finite positive number, got {cap}")
    capped_reference = np.minimum(reference, cap)
    capped_candidate = np.minimum(candidate, cap)
    difference = capped_candidate - capped_reference
    low, high = bootstrap_interval(difference, np.mean, resamples, level, seed)
    return {
        "n": int(len(reference)),
        "reference_mean": float(reference.mean()),
        "candidate_mean": float(candidate.mean()),
        "reference_capped": float(capped_reference.mean()),
        "candidate_capped": float(capped_candidate.mean()),
        "difference": float(difference.mean()),
        "low": low,
        "high": high,
        "reference_over_cap": int(np.sum(reference > cap)),
        "candidate_over_cap": int(np.sum(candidate > cap)),
    }


def format_interval(summary: dict[str, float], key: str, digits: int = 3) -> str:
    """``"value [low, high]"`` of ``summary[key]`` (`describe`), or ``"-"`` when undefined."""
    value = summary.get(key, math.nan)
    if value is None or not math.isfinite(value):
        return "-"
    low, high = summary[f"{key}_low"], summary[f"{key}_high"]
    return f"{value:.{digits}f} [{low:.{digits}f}, {high:.{digits}f}]"
