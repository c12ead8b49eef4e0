"""The tree kernels against plain numpy references, on the cases their shortcuts must not change."""

import numpy as np
import pytest

from temp_gym.planning import _kernels


def reference_near(positions, new, nearest, radius):
    """Every node whose distance (the square root of the summed squares) is at most radius."""
    distances = np.sqrt(((positions - new) ** 2).sum(axis=1))
    keep = [i for i in range(len(positions)) if distances[i] <= radius or i == nearest]
    return np.array(keep, dtype=np.int64), distances[keep]


@pytest.mark.parametrize("dim", [2, 3, 7])
def test_radius_near_set_is_the_exact_one_even_on_the_sphere(dim):
    rng = np.random.default_rng(dim)
    radius = 0.7
    new = rng.uniform(-1, 1, dim)
    count = 600
    directions = rng.normal(size=(count, dim))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    lengths = rng.uniform(0, 2 * radius, count)
    lengths[::3] = radius  # on the sphere, up to rounding
    lengths[1::3] = np.nextafter(radius, 2.0)
    positions = np.ascontiguousarray(new + directions * lengths[:, None])
    positions[5] = new + np.eye(dim)[0] * radius  # exactly radius away along an axis
    costs = rng.uniform(0, 5, count)
    nearest = int(np.argmin(((positions - new) ** 2).sum(axis=1)))
    near_idx = np.empty(count, np.int64)
    near_dist = np.empty(count)
    cand_idx = np.empty(count, np.int64)
    num_near, _ = _kernels.near_and_parent_candidates(
        positions, costs, count, new, nearest, radius, 0, near_idx, near_dist, cand_idx
    )
    expected_idx, expected_dist = reference_near(positions, new, nearest, radius)
    assert 0 < num_near < count
    np.testing.assert_array_equal(near_idx[:num_near], expected_idx)
    np.testing.assert_array_equal(near_dist[:num_near], expected_dist)  # bit for bit
