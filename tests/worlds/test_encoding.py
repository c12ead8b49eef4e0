"""The occupancy-grid encoding of a workspace (the EISE's input and the env's observation)."""

import numpy as np
import pytest

from temp_gym.problem import Workspace
from temp_gym.worlds.encoding import occupancy_grid
from temp_gym.worlds.robots import KUKA_IIWA14

BOUNDS_2D = [[0.0, 0.0], [20.0, 20.0]]


def workspace_2d(centers, half_extents):
    return Workspace("point2d", BOUNDS_2D, np.array(centers, float), np.array(half_extents, float))


def test_cells_overlapping_a_box_are_occupied():
    # 20 x 20 region on a 10-cell grid: cells are 2 units wide. The box [3, 7] x [9.5, 10.5]
    # overlaps cells x 1..3 and y 4..5 (10.5 reaches into cell 5).
    grid = occupancy_grid(workspace_2d([[5.0, 10.0]], [[2.0, 0.5]]), 10)
    assert grid.shape == (10, 10) and grid.dtype == np.float32
    expected = np.zeros((10, 10), np.float32)
    expected[1:4, 4:6] = 1.0
    np.testing.assert_array_equal(grid, expected)


def test_a_box_thinner_than_a_cell_still_shows_up():
    grid = occupancy_grid(workspace_2d([[10.3, 10.0]], [[1e-6, 5.0]]), 16)
    assert grid[8].sum() > 0 and grid.sum() == grid[8].sum()


def test_obstacles_outside_the_region_are_ignored_and_an_empty_world_is_free():
    assert occupancy_grid(workspace_2d([[30.0, 30.0]], [[1.0, 1.0]]), 8).sum() == 0
    assert occupancy_grid(workspace_2d(np.zeros((0, 2)), np.zeros((0, 2))), 8).sum() == 0


def test_3d_and_iiwa_shapes():
    point3d = Workspace("point3d", [[0.0] * 3, [20.0] * 3], np.array([[10.0] * 3]),
                        np.array([[1.0] * 3]))  # fmt: skip
    assert occupancy_grid(point3d, 16).shape == (16, 16, 16)
    centre = KUKA_IIWA14.encoding_region.mean(axis=0)
    iiwa = Workspace("kuka_iiwa14", [[-2.0] * 7, [2.0] * 7], centre[None], np.array([[0.1] * 3]))
    grid = occupancy_grid(iiwa, 16)
    assert grid.shape == (16, 16, 16) and 0 < grid.sum() <= 4**3


def test_every_call_returns_a_fresh_writable_array():
    workspace = workspace_2d([[5.0, 10.0]], [[2.0, 0.5]])
    first = occupancy_grid(workspace, 10)
    first[:] = 7.0  # a caller that writes must not change what the next caller gets
    second = occupancy_grid(workspace, 10)
    assert second.max() == 1.0 and second is not first and second.flags.writeable


@pytest.mark.parametrize("resolution", [1, 0, 2.5, -3])
def test_bad_resolution_is_an_error(resolution):
    with pytest.raises(ValueError, match="resolution"):
        occupancy_grid(workspace_2d([[5.0, 10.0]], [[2.0, 0.5]]), resolution)


@pytest.mark.parametrize("robot, dim", [("point2d", 2), ("point3d", 3)])
def test_grid_matches_a_cell_by_cell_overlap_test(robot, dim):
    # Reference: cell [lo + i c, lo + (i + 1) c] is occupied iff it overlaps a box on every axis.
    rng = np.random.default_rng(4)
    bounds = [[0.0] * dim, [20.0] * dim]
    centers = rng.uniform(-3.0, 23.0, size=(12, dim))
    half_extents = rng.uniform(0.01, 4.0, size=(12, dim))
    space = Workspace(robot, bounds, centers, half_extents)
    resolution = 9  # cells of 20/9: faces rarely fall on cell borders
    grid = occupancy_grid(space, resolution)
    edges = np.linspace(0.0, 20.0, resolution + 1)
    cells = np.stack(np.meshgrid(*[np.arange(resolution)] * dim, indexing="ij"), -1).reshape(
        -1, dim
    )
    low, high = edges[cells], edges[cells + 1]
    overlaps = np.all(
        (low[:, None, :] <= space.obstacle_upper) & (high[:, None, :] >= space.obstacle_lower),
        axis=2,
    )
    expected = overlaps.any(axis=1).reshape((resolution,) * dim)
    np.testing.assert_array_equal(grid.astype(bool), expected)
