"""The occupancy-grid encoding of a workspace (the EISE's input and the env's observation)."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from temp_gym.problem import Workspace
from temp_gym.problem.obstacles import Box, Cylinder, Sphere
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
    # Thinner than rounding, on a grid line (x = 10 at 20 cells): it spanned no cell and
    # vanished, though the checkers block every motion across it.
    grid = occupancy_grid(workspace_2d([[10.0, 10.0]], [[1e-17, 8.0]]), 20)
    assert grid[10, 2:18].all() and grid.sum() == 16
    # Touching the region from outside stays outside.
    assert occupancy_grid(workspace_2d([[-1.0, 10.0]], [[1.0, 8.0]]), 20).sum() == 0


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


# ---- obstacles of every kind ------------------------------------------------------------------
def _old_box_grid(space: Workspace, resolution: int) -> np.ndarray:
    """The grid as boxes were always marked: cells ``floor(lower)`` to ``ceil(upper)`` per axis."""
    dim = space.workspace_dim
    region = np.asarray(space.bounds, float)
    cell = (region[1] - region[0]) / resolution
    grid = np.zeros((resolution,) * dim, np.float32)
    for lower, upper in zip(space.obstacle_lower, space.obstacle_upper):
        first = np.clip(np.floor((lower - region[0]) / cell).astype(int), 0, resolution - 1)
        stop = np.clip(np.ceil((upper - region[0]) / cell).astype(int), 0, resolution)
        if np.any(stop <= first) or np.any(upper < region[0]) or np.any(lower > region[1]):
            continue
        grid[tuple(slice(a, b) for a, b in zip(first, stop))] = 1.0
    return grid


@pytest.mark.parametrize("robot, dim", [("point2d", 2), ("point3d", 3)])
def test_axis_aligned_boxes_give_the_grids_they_always_gave(robot, dim):
    rng = np.random.default_rng(9)
    for round_to in (None, 0.5):  # faces anywhere, then on cell borders
        centers = rng.uniform(-3.0, 23.0, size=(15, dim))
        halves = rng.uniform(0.01, 4.0, size=(15, dim))
        if round_to:
            centers, halves = np.round(centers / round_to) * round_to, np.ceil(halves * 2) / 2
        space = Workspace(robot, [[0.0] * dim, [20.0] * dim], centers, halves)
        for resolution in (8, 10, 16):
            np.testing.assert_array_equal(
                occupancy_grid(space, resolution), _old_box_grid(space, resolution)
            )


def _shapes_world(dim: int, seed: int) -> Workspace:
    rng = np.random.default_rng(seed)
    obstacles = []
    for i in range(12):
        center = tuple(rng.uniform(-1.0, 21.0, dim))
        kind = i % 3 if dim == 3 else (0, 2)[i % 2]
        quat = tuple(Rotation.random(random_state=rng).as_quat())
        if kind == 0:
            turn = float(rng.uniform(-np.pi, np.pi)) if dim == 2 else quat
            obstacles.append(Box(center, tuple(rng.uniform(0.05, 3.0, dim)), turn))
        elif kind == 1:
            obstacles.append(Cylinder(center, rng.uniform(0.05, 2.5), rng.uniform(0.1, 6.0), quat))
        else:
            obstacles.append(Sphere(center, rng.uniform(0.05, 2.5)))
    robot = "point2d" if dim == 2 else "point3d"
    return Workspace.from_obstacles(robot, [[0.0] * dim, [20.0] * dim], obstacles)


def _inside(obstacle, points: np.ndarray) -> np.ndarray:
    """Which points lie in the obstacle, by scipy's rotations (not the package's)."""
    dim = points.shape[1]
    offset = points - np.asarray(obstacle.center)
    if isinstance(obstacle, Sphere):
        return np.linalg.norm(offset, axis=1) <= obstacle.radius
    if dim == 2:
        rotation = Rotation.from_euler("z", obstacle.orientation or 0.0).as_matrix()[:2, :2]
    else:
        rotation = Rotation.from_quat(obstacle.orientation or (0, 0, 0, 1)).as_matrix()
    local = offset @ rotation
    if isinstance(obstacle, Cylinder):
        radial = np.hypot(local[:, 0], local[:, 1])
        return (radial <= obstacle.radius) & (np.abs(local[:, 2]) <= obstacle.length / 2)
    return np.all(np.abs(local) <= np.asarray(obstacle.half_extents), axis=1)


@pytest.mark.parametrize("dim", [2, 3])
def test_no_cell_holding_a_point_of_an_obstacle_is_left_free(dim):
    space = _shapes_world(dim, dim)
    resolution = 16 if dim == 3 else 40
    grid = occupancy_grid(space, resolution)
    rng = np.random.default_rng(0)
    for obstacle, lower, upper in zip(space.obstacles, space.obstacle_lower, space.obstacle_upper):
        points = rng.uniform(lower, upper, (4000, dim))
        points = points[_inside(obstacle, points) & np.all((points >= 0) & (points <= 20), 1)]
        cells = np.minimum((points / (20.0 / resolution)).astype(int), resolution - 1)
        assert grid[tuple(cells.T)].all(), obstacle


def _rotation(obstacle, dim: int) -> np.ndarray:
    if dim == 2:
        return Rotation.from_euler("z", obstacle.orientation or 0.0).as_matrix()[:2, :2]
    return Rotation.from_quat(obstacle.orientation or (0, 0, 0, 1)).as_matrix()


def _overlap_depth(obstacle, low: np.ndarray, high: np.ndarray) -> float:
    """Positive when the cell overlaps the obstacle, negative when apart (about by how much).

    A box: the largest margin by which a point of the cell is inside all of the box's slabs, a
    linear program. A sphere: its radius less the least distance from its center to the cell.
    A cylinder: minus the least squared distance from the cell to it (0 when they meet).
    """
    from scipy.optimize import linprog, minimize

    dim = len(low)
    center = np.asarray(obstacle.center)
    if isinstance(obstacle, Sphere):
        result = minimize(lambda p: np.sum((p - center) ** 2), np.clip(center, low, high),
                          bounds=list(zip(low, high)), method="L-BFGS-B", tol=1e-14)  # fmt: skip
        return obstacle.radius - np.sqrt(result.fun)
    rotation = _rotation(obstacle, dim)
    if isinstance(obstacle, Cylinder):

        def outside(p):
            local = (p - center) @ rotation
            radial = max(np.hypot(local[0], local[1]) - obstacle.radius, 0.0)
            along = max(abs(local[2]) - obstacle.length / 2, 0.0)
            return radial**2 + along**2

        starts = [np.clip(center, low, high), (low + high) / 2]
        return -min(minimize(outside, x, bounds=list(zip(low, high))).fun for x in starts)
    # maximize s: low <= p <= high, +-(R^T (p - c))_k + s <= h_k; variables (p, s)
    rows = np.vstack([np.hstack([rotation.T, np.ones((dim, 1))]),
                      np.hstack([-rotation.T, np.ones((dim, 1))])])  # fmt: skip
    half = np.asarray(obstacle.half_extents)
    limits = np.concatenate([half + rotation.T @ center, half - rotation.T @ center])
    cost = np.zeros(dim + 1)
    cost[-1] = -1.0
    bounds = [*zip(low, high), (None, None)]
    return float(-linprog(cost, A_ub=rows, b_ub=limits, bounds=bounds).fun)


def _cells_near(space: Workspace, b: int, resolution: int):
    """The cells of obstacle ``b``'s bounding box and one more around it, as (index, low, high)."""
    cell = 20.0 / resolution
    first = np.clip(np.floor(space.obstacle_lower[b] / cell).astype(int) - 1, 0, resolution)
    stop = np.clip(np.ceil(space.obstacle_upper[b] / cell).astype(int) + 1, 0, resolution)
    for index in np.ndindex(*(stop - first)):
        index = tuple(np.asarray(index) + first)
        yield index, np.asarray(index) * cell, (np.asarray(index) + 1) * cell


@pytest.mark.parametrize("dim", [2, 3])
def test_spheres_and_rotated_boxes_mark_exactly_the_cells_they_overlap(dim):
    space = _shapes_world(dim, 20 + dim)
    resolution = 12
    called = 0
    for b, obstacle in enumerate(space.obstacles):
        if isinstance(obstacle, Cylinder):
            continue
        grid = occupancy_grid(space.with_obstacles([b]), resolution).astype(bool)
        for index, low, high in _cells_near(space, b, resolution):
            depth = _overlap_depth(obstacle, low, high)
            if abs(depth) > 1e-7:
                assert grid[index] == (depth > 0), (obstacle, index, depth)
                called += 1
    assert called > 100


def test_cylinders_mark_every_cell_they_overlap_and_few_others():
    space = _shapes_world(3, 30)
    resolution = 12
    marked, extra = 0, 0
    for b, obstacle in enumerate(space.obstacles):
        if not isinstance(obstacle, Cylinder):
            continue
        grid = occupancy_grid(space.with_obstacles([b]), resolution).astype(bool)
        for index, low, high in _cells_near(space, b, resolution):
            depth = _overlap_depth(obstacle, low, high)
            if depth == 0.0:
                assert grid[index], (obstacle, index)
            marked += int(grid[index])
            extra += int(grid[index] and depth < -1e-6)
    print(f"cylinders: {extra} of {marked} marked cells do not touch them")
    assert marked > 20 and extra <= 0.15 * marked


@pytest.mark.parametrize("dim", [2, 3])
def test_grids_of_rotated_worlds_are_cached_by_their_obstacles(dim):
    space = _shapes_world(dim, 40)
    grid = occupancy_grid(space, 16)
    boxes_only = Workspace(space.robot, space.bounds, space.obstacle_centers,
                           space.obstacle_half_extents)  # fmt: skip
    assert not np.array_equal(occupancy_grid(boxes_only, 16), grid)  # kinds are in the key
    np.testing.assert_array_equal(occupancy_grid(space, 16), grid)
