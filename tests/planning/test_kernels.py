"""The tree kernels against plain numpy references, on the cases their shortcuts must not change."""

import numpy as np
import pytest

from temp_gym.planning import _kernels
from temp_gym.planning._grid import make_grid


def reference_near(positions, new, nearest, radius):
    """Every node whose distance (the square root of the summed squares) is at most radius."""
    distances = np.sqrt(((positions - new) ** 2).sum(axis=1))
    keep = [i for i in range(len(positions)) if distances[i] <= radius or i == nearest]
    return np.array(keep, dtype=np.int64), distances[keep]


def _grid(positions, radius, through_grid):
    """A grid over bounds that leave some positions outside (filed in the border cells)."""
    low, high = np.quantile(positions, [0.05, 0.95], axis=0)
    return make_grid(np.array([low, high]), radius, len(positions), 1 if through_grid else 10**9)


@pytest.mark.parametrize("through_grid", [False, True])
@pytest.mark.parametrize("dim", [2, 3, 7])
def test_radius_near_set_is_the_exact_one_even_on_the_sphere(dim, through_grid):
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
        positions, costs, count, new, nearest, radius, 0, near_idx, near_dist, cand_idx,
        _grid(positions, radius, through_grid),
    )  # fmt: skip
    expected_idx, expected_dist = reference_near(positions, new, nearest, radius)
    assert 0 < num_near < count
    np.testing.assert_array_equal(near_idx[:num_near], expected_idx)
    np.testing.assert_array_equal(near_dist[:num_near], expected_dist)  # bit for bit


@pytest.mark.parametrize("dim", [2, 3])
def test_the_grid_finds_the_scans_nearest_node_ties_and_far_samples_included(dim):
    rng = np.random.default_rng(10 + dim)
    count = 700
    positions = rng.uniform(0, 10, (count, dim))
    positions[300] = positions[40]  # a tie: the lower index wins, as in the scan
    positions[650:] = np.round(positions[650:])  # more ties on lattice points
    grid = make_grid(np.array([[0.0] * dim, [10.0] * dim]), 0.5, count, min_nodes=1)
    scan = make_grid(np.array([[0.0] * dim, [10.0] * dim]), 0.5, count, min_nodes=10**9)
    scratch = np.empty(count, np.int64)
    samples = [
        *rng.uniform(-3, 13, (300, dim)),
        positions[40],
        positions[300],
        positions[660],
        np.full(dim, 1e6),
        np.full(dim, -1e300),
        np.array([5.0] * (dim - 1) + [np.inf]),
    ]
    for sample in samples:
        for size in (1, 2, 513, count):  # the grid files nodes as the tree grows
            got = _kernels.nearest_and_steer(positions, size, sample, 0.3, np.empty(dim), grid,
                                             scratch)  # fmt: skip
            want = _kernels.nearest_and_steer(positions, size, sample, 0.3, np.empty(dim), scan,
                                              scratch)  # fmt: skip
            assert got == want or (np.isnan(got[1]) and np.isnan(want[1]) and got[0] == want[0])
