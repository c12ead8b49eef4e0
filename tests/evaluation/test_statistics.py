import math

import numpy as np
import pytest

from temp_gym.evaluation.statistics import (
    bootstrap_interval,
    describe,
    format_interval,
    paired_capped_difference,
)


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


def test_a_capped_comparison_is_not_decided_by_one_task_of_thousands():
    rng = np.random.default_rng(1)
    reference = rng.integers(10, 40, 500).astype(float)
    candidate = reference - 2.0  # two nodes fewer on every task
    candidate[7] = 8000.0  # and one task far in the tail
    plain = candidate.mean() - reference.mean()
    summary = paired_capped_difference(reference, candidate, cap=1000)
    assert plain > 10  # the plain mean says the candidate is much worse
    assert summary["candidate_mean"] - summary["reference_mean"] == pytest.approx(plain)
    # Capped, the tail task counts 1000 - its reference: the rest still shows.
    expected = (np.minimum(candidate, 1000) - reference).mean()
    assert summary["difference"] == pytest.approx(expected)
    assert summary["low"] <= summary["difference"] <= summary["high"]
    assert (summary["reference_over_cap"], summary["candidate_over_cap"]) == (0, 1)
    assert summary["n"] == 500
    assert paired_capped_difference(reference, candidate, 1000, seed=3) == (
        paired_capped_difference(reference, candidate, 1000, seed=3)
    )


def test_a_paired_interval_is_narrower_than_the_spread_of_the_tasks():
    rng = np.random.default_rng(2)
    reference = rng.lognormal(3.0, 1.0, 400)
    candidate = reference + rng.normal(1.0, 0.5, 400)
    summary = paired_capped_difference(reference, candidate, cap=1e9)
    assert 0.8 < summary["low"] < 1.0 < summary["high"] < 1.2  # the pairing removes the spread


def test_a_capped_comparison_refuses_what_it_cannot_pair():
    with pytest.raises(ValueError, match="same tasks"):
        paired_capped_difference([1.0, 2.0], [1.0], cap=10)
    with pytest.raises(ValueError, match="same tasks"):
        paired_capped_difference([], [], cap=10)
    with pytest.raises(ValueError, match="cap"):
        paired_capped_difference([1.0], [1.0], cap=0)
    with pytest.raises(ValueError, match="cap"):
        paired_capped_difference([1.0], [1.0], cap=math.inf)
