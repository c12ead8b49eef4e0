"""Environment encoding: an occupancy grid of the workspace, the model's view of obstacles.

A cell is occupied when the closed box of the cell overlaps an obstacle, so an obstacle
thinner than a cell still shows up: exactly for rotated boxes and spheres, and conservatively
for cylinders, where a cell by the rim may be marked without touching it; an axis-aligned box
marks the cells it spans, not those it only touches at a face (`mark_obstacles`). The grid
covers the robot's encoding region (`temp_gym.worlds.robots.RobotSpec.region`): the
configuration bounds for point robots, and a fixed box around the iiwa that holds its whole
reach.
"""

from __future__ import annotations

import functools

import numba
import numpy as np

from temp_gym.limits import MAX_ENCODING_CELLS, MIN_ENCODING_RESOLUTION
from temp_gym.problem import Workspace
from temp_gym.worlds.cells import next_cell
from temp_gym.worlds.collision.shape_geometry import AXIS_BOX, box_overlaps_shape, obstacle_arrays
from temp_gym.worlds.robots import robot_spec


def check_resolution(resolution: object, workspace_dim: int, name: str = "resolution") -> int:
    """``resolution`` as an int if its grid has at most `temp_gym.limits.MAX_ENCODING_CELLS`.

    Raises:
        ValueError: not an integer of at least `temp_gym.limits.MIN_ENCODING_RESOLUTION`, or
            a grid of more cells than supported; the message names ``name``.
    """
    integral = isinstance(resolution, (float, np.floating)) and float(resolution).is_integer()
    if isinstance(resolution, bool) or not (isinstance(resolution, (int, np.integer)) or integral):
        raise ValueError(f"{name}: expected an integer, got {resolution!r}")
    resolution = int(resolution)
    if resolution < MIN_ENCODING_RESOLUTION:
        raise ValueError(
            f"{name}: expected at least {MIN_ENCODING_RESOLUTION} cells per axis, got {resolution}"
        )
    most = int(round(MAX_ENCODING_CELLS ** (1 / workspace_dim)))
    while (most + 1) ** workspace_dim <= MAX_ENCODING_CELLS:
        most += 1
    while most**workspace_dim > MAX_ENCODING_CELLS:
        most -= 1
    if resolution > most:
        raise ValueError(
            f"{name}: {resolution} cells per axis is {resolution**workspace_dim:,} cells in "
            f"{workspace_dim}D; at most {most} per axis ({MAX_ENCODING_CELLS:,} cells) are "
            "supported"
        )
    return resolution


def workspace_region(workspace: Workspace) -> np.ndarray:
    """The ``(2, workspace_dim)`` region that the occupancy grid covers (the robot's)."""
    return robot_spec(workspace.robot).region(workspace.bounds)


def occupancy_grid(workspace: Workspace, resolution: int) -> np.ndarray:
    """Occupancy of the workspace region on a ``resolution``-per-axis grid, as float32 0/1.

    The array has one axis per workspace dimension, indexed ``[x, y]`` or ``[x, y, z]``.

    Examples:
        >>> grid = occupancy_grid(problem.workspace, resolution=32)  # (32, 32) for 2D
    """
    arrays = occupancy_obstacles(workspace)
    resolution = check_resolution(resolution, arrays[0].shape[1])
    key = (int(resolution), tuple((a.dtype.str, a.shape, a.tobytes()) for a in arrays))
    return _grid(key).copy()  # a fresh array: callers may write to it


def occupancy_obstacles(workspace: Workspace) -> tuple[np.ndarray, ...]:
    """What `occupancy_grid` is made of, in the form `mark_obstacles` reads it.

    ``(region, codes, centers, halves, rotations, lower, upper)``: the ``(2, workspace_dim)``
    region and the obstacles' arrays (`temp_gym.worlds.collision.shape_geometry.obstacle_arrays`),
    contiguous.
    """
    region = np.ascontiguousarray(workspace_region(workspace), dtype=np.float64)
    return (region, *obstacle_arrays(workspace))


def clear_occupancy_grids() -> None:
    """Forget every cached grid: the next `occupancy_grid` of each workspace computes it."""
    _grid.cache_clear()


@functools.lru_cache(maxsize=128)
def _grid(key: tuple) -> np.ndarray:
    """The grid of a (resolution, region and obstacles) key, computed once per key.

    A planner and its policy both encode the workspace of a problem (the observation and the
    EISE input); an evaluation plans every task with several planners. Caching by content
    makes the second encoding free.
    """
    resolution, described = key
    region, *obstacles = (
        np.frombuffer(data, dtype=np.dtype(kind)).reshape(shape) for kind, shape, data in described
    )
    wdim = region.shape[1]
    flat = np.zeros(resolution**wdim, dtype=np.bool_)
    mark_obstacles(flat, region, *obstacles, resolution)
    grid = flat.reshape((resolution,) * wdim).astype(np.float32)
    grid.flags.writeable = False
    return grid


@numba.njit(cache=True, nogil=True)
def mark_obstacles(flat, region, codes, centers, halves, rotations, lower, upper, resolution):
    """Mark, in the C-order flattened grid, the cells that overlap each obstacle (closed).

    The kernel of `occupancy_grid`, for compiled callers too (`occupancy_obstacles`' arrays).
    Cell ``i`` of an axis spans ``[region0 + i * cell, region0 + (i + 1) * cell]``.

    An axis-aligned box marks the cells its box spans, as grids have always been made. Any
    other obstacle visits the cells of its bounding box and marks those that overlap it
    (`temp_gym.worlds.collision.shape_geometry.box_overlaps_shape`): exactly for spheres and
    rotated boxes, conservatively for cylinders (a cell by a cylinder's rim may be marked
    without touching it; no overlapping cell is missed).
    """
    wdim = region.shape[1]
    cell = (region[1] - region[0]) / resolution
    first = np.empty(wdim, dtype=np.int64)
    stop = np.empty(wdim, dtype=np.int64)
    index = np.empty(wdim, dtype=np.int64)
    cell_lower = np.empty(wdim)
    cell_upper = np.empty(wdim)
    for b in range(lower.shape[0]):
        exact = codes[b] == AXIS_BOX
        skip = False
        for k in range(wdim):
            first[k] = min(max(int(np.floor((lower[b, k] - region[0, k]) / cell[k])), 0),
                           resolution - 1)  # fmt: skip
            if exact:
                stop[k] = min(max(int(np.ceil((upper[b, k] - region[0, k]) / cell[k])), 0),
                              resolution)  # fmt: skip
                # A box thinner than rounding, on a grid line inside the region: the cell
                # after the line (else it would span no cell and vanish from the grid).
                if (stop[k] == first[k] and upper[b, k] > region[0, k]
                        and lower[b, k] < region[1, k]):  # fmt: skip
                    stop[k] = first[k] + 1
            else:  # a cell its bounding box only touches is tested too
                stop[k] = min(max(int(np.floor((upper[b, k] - region[0, k]) / cell[k])) + 1, 0),
                              resolution)  # fmt: skip
            if stop[k] <= first[k] or upper[b, k] < region[0, k] or lower[b, k] > region[1, k]:
                skip = True
            index[k] = first[k]
        if skip:
            continue
        while True:  # every cell of the bounding box
            covered = exact
            if not exact:
                for k in range(wdim):
                    cell_lower[k] = region[0, k] + index[k] * cell[k]
                    cell_upper[k] = region[0, k] + (index[k] + 1) * cell[k]
                covered = box_overlaps_shape(
                    cell_lower, cell_upper, codes, centers, halves, rotations, b
                )
            if covered:
                position = 0
                for k in range(wdim):
                    position = position * resolution + index[k]
                flat[position] = True
            if not next_cell(index, first, stop, wdim):
                break
