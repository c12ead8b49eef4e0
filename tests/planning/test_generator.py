"""A Generator handed to compiled code by address draws what numba's own unboxing draws."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from temp_gym.planning._generator import address, generator_at


@numba.njit(cache=False)
def _draws_by_address(bitgen_address, count):
    rng = generator_at(bitgen_address)
    out = np.empty(count)
    for i in range(count):
        out[i] = rng.normal(0.0, 0.5) if i % 3 == 0 else rng.random()
    out[: count // 2] += rng.random(count // 2)
    return out


@numba.njit(cache=False)
def _draws_by_object(rng, count):
    out = np.empty(count)
    for i in range(count):
        out[i] = rng.normal(0.0, 0.5) if i % 3 == 0 else rng.random()
    out[: count // 2] += rng.random(count // 2)
    return out


@pytest.mark.parametrize("bit_generator", [np.random.PCG64, np.random.Philox, np.random.MT19937])
def test_same_numbers_and_state_as_numbas_unboxing(bit_generator):
    by_address = np.random.Generator(bit_generator(7))
    by_object = np.random.Generator(bit_generator(7))
    by_address.random(3)  # a state advanced in Python first, as the planners' is
    by_object.random(3)
    for count in (1, 10, 1001):
        assert np.array_equal(
            _draws_by_address(address(by_address), count), _draws_by_object(by_object, count)
        )
    np.testing.assert_equal(by_address.bit_generator.state, by_object.bit_generator.state)
    assert by_address.random() == by_object.random()  # Python goes on from the same state


def test_each_generator_has_its_own_address():
    first, second = np.random.default_rng(0), np.random.default_rng(0)
    assert address(first) != address(second)
    assert address(first) == address(first)
    _draws_by_address(address(first), 5)
    assert first.random() != second.random()  # only the first one was drawn from


def test_address_refuses_what_is_not_a_generator():
    with pytest.raises(TypeError, match="numpy.random.Generator"):
        address(np.random.RandomState(0))
    with pytest.raises(TypeError, match="numpy.random.Generator"):
        address(np.random.PCG64(0))
