"""A uniform grid over a point robot's tree, so that nearest and near queries stop scanning it.

RRT* asks, for every sample, for the tree's nearest node and then for every node within the
near radius. A scan of all n nodes is the fastest answer for small trees, but it makes each
extension O(n): beyond a few thousand nodes the scans are most of an extension's time, and a
stalled TEMP run or a long anytime run grows such trees. For point robots (d <= 3) the tree's
nodes are also kept in a uniform grid over the bounds, and the queries read only the cells
that can hold an answer.

The grid gives exactly the scan's answers, so trees are the same node for node (tested):

* nearest: the node of least squared distance (computed as the scan computes it), the lowest
  index among equals; the grid finds one node, then reads every cell within that node's
  distance (with a margin far above rounding), so every node as close is read;
* near set: every node within the radius, in increasing index order, as the scan lists them.

The grid is indexed lazily: each query first files the nodes added since the last one (a node
never moves). A node outside the bounds (a caller's own sample can lie outside) is filed in
the nearest border cell, which the cell ranges below still reach. A tree below
`GRID_MIN_NODES` nodes has no grid (`NO_GRID`), and for d > 3 (the iiwa: a grid over 7 joint
angles would be mostly empty cells) and for a sample that is not finite the queries scan as
before.

``grid`` is one float64 array (`make_grid`; one array, because every array a compiled
extension passes on costs it time): a header (`HEADER`: nodes filed, least nodes for the grid,
cells per axis, origin per axis, cell side), then the first node of each cell's list (-1:
empty), then the next node in its cell's list per node. Node indices stay exact in float64.
"""

from __future__ import annotations

import math

import numba
import numpy as np

GRID_MIN_NODES = 1024
"""A tree gets its grid once it outgrows this many nodes (`temp_gym.planning.tree.Tree` makes
it when its arrays grow past it): a scan of fewer nodes costs less than making a grid."""
MAX_CELLS = 2**18
"""Most cells of a grid; a coarser grid when the bounds hold more cells of the planned side."""
CROWDED = 8
"""A nearest query whose box would list more than 1/CROWDED of the tree's nodes scans them
instead: following the cells' lists costs several times a sequential scan per node (a sample
far from a tree crowded into a trap lists most of it)."""
MARGIN = 1e-9
"""Relative margin on every distance a cell range is cut at, far above float rounding."""
HEADER = ("filed", "min_nodes", "cells_0", "cells_1", "cells_2", "origin_0", "origin_1",
          "origin_2", "side")  # fmt: skip
"""The grid array's first entries (axes past d: one cell, origin 0)."""
FILED, MIN_NODES, CELLS, ORIGIN, SIDE = 0, 1, 2, 5, 8
LISTS = len(HEADER)
"""Where the cells' first nodes begin."""


def make_grid(
    bounds: np.ndarray, max_radius: float, capacity: int, min_nodes: int = 0
) -> np.ndarray:
    """An empty grid over ``bounds`` (2, d) with cells of about half ``max_radius`` a side.

    The near radius never exceeds ``max_radius``, so a near query reads at most 5 cells per
    axis. For d > 3 the grid is disabled (cell side 0: never read). While the tree has fewer
    than ``min_nodes`` nodes the queries still scan (the kernel tests use it).
    """
    bounds = np.asarray(bounds, dtype=np.float64)
    dim = bounds.shape[1]
    extent = bounds[1] - bounds[0]
    side = 0.5 * float(max_radius)
    counts = np.ones(3)
    usable = dim <= 3 and math.isfinite(side) and side > 0 and bool(np.all(extent > 0))
    if usable:
        if float(np.prod(extent / side)) > MAX_CELLS:  # coarser, to stay within MAX_CELLS
            side = 1.01 * (float(np.prod(extent)) / MAX_CELLS) ** (1.0 / dim)
        counts[:dim] = np.maximum(1.0, np.ceil(extent / side))
        usable = bool(math.isfinite(side) and side > 0 and np.prod(counts) <= MAX_CELLS)
    if not usable:
        counts[:] = 1.0
    grid = np.empty(LISTS + int(np.prod(counts)) + capacity)
    grid[FILED], grid[MIN_NODES] = 0.0, float(min_nodes)
    grid[CELLS : CELLS + 3] = counts
    grid[ORIGIN : ORIGIN + 3] = 0.0
    if usable:
        grid[ORIGIN : ORIGIN + dim] = bounds[0]
    grid[SIDE] = side if usable else 0.0
    grid[LISTS : LISTS + int(np.prod(counts))] = -1.0
    return grid


NO_GRID = np.zeros(LISTS + 1)
"""The grid of a tree that has none (cell side 0: never read, never written)."""


def grown(grid: np.ndarray, capacity: int) -> np.ndarray:
    """``grid`` with room for ``capacity`` nodes (the filed nodes' links copied)."""
    start = _links(grid)
    more = np.empty(start + capacity)
    more[: start + int(grid[FILED])] = grid[: start + int(grid[FILED])]
    return more


@numba.njit(cache=True, nogil=True, inline="always")
def _axis_cell(x, origin, side, count):
    """The cell index of coordinate ``x`` along one axis, held within ``0 .. count - 1``.

    Monotone in ``x``; an infinite ``x`` (a box reaching past float range) is held too.
    """
    cell = (x - origin) / side
    if not cell >= 0.0:
        return 0
    if cell >= count:
        return int(count) - 1
    return int(math.floor(cell))


@numba.njit(cache=True, nogil=True, inline="always")
def _links(grid):
    """Where the per-node links begin: past the header and every cell's first node."""
    return LISTS + int(grid[CELLS]) * int(grid[CELLS + 1]) * int(grid[CELLS + 2])


@numba.njit(cache=True, nogil=True)
def _cell_of(point, grid, dim):
    """The flat index of the cell holding ``point`` (axis 0 slowest)."""
    flat = 0
    for k in range(dim):
        count = grid[CELLS + k]
        flat = flat * int(count) + _axis_cell(point[k], grid[ORIGIN + k], grid[SIDE], count)
    return flat


@numba.njit(cache=True, nogil=True)
def _file_new_nodes(positions, count, grid):
    """File the nodes added since the last query (positions never change once added)."""
    dim = positions.shape[1]
    following = _links(grid)
    for node in range(int(grid[FILED]), count):
        head = LISTS + _cell_of(positions[node], grid, dim)
        grid[following + node] = grid[head]
        grid[head] = node
    grid[FILED] = max(grid[FILED], count)


@numba.njit(cache=True, nogil=True, inline="always")
def in_use(grid, count, point) -> bool:
    """Whether the queries read the grid (else they scan): enabled, big tree, finite point."""
    if grid[SIDE] <= 0.0 or count < grid[MIN_NODES]:
        return False
    for k in range(point.shape[0]):
        if not np.isfinite(point[k]):
            return False
    return True


@numba.njit(cache=True, nogil=True)
def within_box(positions, count, point, reach, grid, out) -> int:
    """Every node whose cell meets the box ``point +- reach`` per axis, ascending, into ``out``.

    ``out`` has room for ``count`` entries; returns how many it got. A superset of the nodes
    within ``reach`` of ``point`` (the caller tests each); every node of a cell is listed.
    """
    found = _within_box_unsorted(positions, count, point, reach, grid, out, count)
    out[:found].sort()
    return found


@numba.njit(cache=True, nogil=True)
def _within_box_unsorted(positions, count, point, reach, grid, out, limit) -> int:
    """`within_box`'s nodes in the order the cells list them, unsorted; -1 past ``limit``.

    The nearest query needs no order: it breaks ties by index itself.
    """
    _file_new_nodes(positions, count, grid)
    dim = positions.shape[1]
    side = grid[SIDE]
    reach = reach * (1.0 + MARGIN)
    low = np.zeros(3, dtype=np.int64)
    high = np.zeros(3, dtype=np.int64)
    for k in range(dim):
        low[k] = _axis_cell(point[k] - reach, grid[ORIGIN + k], side, grid[CELLS + k])
        high[k] = _axis_cell(point[k] + reach, grid[ORIGIN + k], side, grid[CELLS + k])
    count_1, count_2 = int(grid[CELLS + 1]), int(grid[CELLS + 2])
    following = _links(grid)
    found = 0
    for a in range(low[0], high[0] + 1):
        for b in range(low[1], high[1] + 1):
            for c in range(low[2], high[2] + 1):
                node = int(grid[LISTS + (a * count_1 + b) * count_2 + c])
                while node >= 0:
                    if node < count:  # filed by a query on a bigger tree (only in tests)
                        if found == limit:
                            return -1
                        out[found] = node
                        found += 1
                    node = int(grid[following + node])
    return found


@numba.njit(cache=True, nogil=True)
def scan_nearest(positions, count, point):
    """``(node, squared distance)`` of the first node nearest ``point``, scanning them all.

    The answer the grid must give, and the query of a tree without one (`_kernels.nearest`).
    """
    dim = positions.shape[1]
    best = 0
    best_sq = np.inf
    for i in range(count):
        sq = squared_distance_to(positions, i, point, dim)
        if sq < best_sq:
            best_sq = sq
            best = i
    return best, best_sq


@numba.njit(cache=True, nogil=True, inline="always")
def squared_distance_to(positions, i, point, dim):
    """``|positions[i] - point|^2``, summed over the coordinates in order.

    The tree kernels' one formula, so that the grid and the scans compare the same numbers.
    """
    sq = 0.0
    for k in range(dim):
        diff = positions[i, k] - point[k]
        sq += diff * diff
    return sq


@numba.njit(cache=True, nogil=True)
def grid_nearest(positions, count, point, grid, scratch):
    """``(node, squared distance)`` of the node nearest ``point``: the scan's answer.

    Needs `in_use`. A first node comes from the cells around ``point`` (a widening box until
    one holds a node); every cell within its distance is then read, and the least squared
    distance wins, the lowest index among equals. The nodes are read in cell order, unsorted:
    a tree crowded into a trap puts thousands of nodes in the box of a far sample, and sorting
    them for every query made such plans several times slower. ``scratch`` holds ``count``
    int64.
    """
    dim = positions.shape[1]
    limit = count // CROWDED
    reach = grid[SIDE]
    found = _within_box_unsorted(positions, count, point, reach, grid, scratch, limit)
    while found == 0:
        reach *= 2.0
        found = _within_box_unsorted(positions, count, point, reach, grid, scratch, limit)
    if found < 0:
        return scan_nearest(positions, count, point)
    probe_sq = np.inf
    for j in range(found):
        probe_sq = min(probe_sq, squared_distance_to(positions, scratch[j], point, dim))
    found = _within_box_unsorted(positions, count, point, math.sqrt(probe_sq), grid, scratch,
                                 limit)  # fmt: skip
    if found < 0:
        return scan_nearest(positions, count, point)
    best = -1
    best_sq = np.inf
    for j in range(found):  # in cell order: ties go to the lowest index, as in the scan
        node = scratch[j]
        sq = squared_distance_to(positions, node, point, dim)
        if sq < best_sq or (sq == best_sq and node < best):
            best_sq = sq
            best = node
    if best < 0:  # every squared distance overflowed: the whole tree was read, and the
        best = 0  # scan, which starts from the root and moves only on "closer", keeps it
    return best, best_sq


__all__ = [
    "GRID_MIN_NODES",
    "grid_nearest",
    "grown",
    "in_use",
    "make_grid",
    "scan_nearest",
    "within_box",
]
