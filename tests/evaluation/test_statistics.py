import math

import numpy as np
import pytest

from temp_gym.evaluation.statistics import bootstrap_interval, describe, format_interval


def test_the_median_interval_ignores_one_stall_that_moves_the_mean():
    rng = np.random.default_rng(0)
    times = rng.normal(0.010, 0.001, 60)
    stalled = times.copy()
    stalled[0] = 2.0  # one task stalled for two seconds
    quiet, loaded = describe(times), describe(stalled)
    assert loaded["mean"] > 3 * quiet["mean"]
    assert loaded["median"] == pytest.approx(quiet["median"], rel=0.05)
    assert loaded["median_high"] < 0.012  # still far below the stalled mean
    for summary in (quiet, loaded):
        assert summary["n"] == 60
        assert summary["median_low"] <= summary["median"] <= summary["median_high"]
        assert summary["mean_low"] <= summary["mean"] <= summary["mean_high"]


def test_intervals_are_seeded_and_collapse_on_constant_values():
    values = np.arange(20.0)
    assert bootstrap_interval(values, seed=3) == bootstrap_interval(values, seed=3)
    low, high = bootstrap_interval(values, np.mean, seed=0)
    assert low < values.mean() < high
    assert bootstrap_interval([5.0] * 7) == (5.0, 5.0)


def test_empty_input_and_bad_arguments():
    summary = describe([])
    assert summary["n"] == 0 and math.isnan(summary["median"])
    assert format_interval(summary, "median") == "-"
    assert format_interval(describe([1.0, 2.0, 3.0]), "median", 1).startswith("2.0 [")
    with pytest.raises(ValueError, match="values"):
        bootstrap_interval(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="level"):
        bootstrap_interval([1.0], level=1.5)
