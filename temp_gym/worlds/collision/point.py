"""Exact collision checking for point robots among axis-aligned boxes.

A point robot's motion is a straight segment, so the motion check is the analytic
segment-versus-box "slab" test: no interpolation resolution, nothing can be stepped over,
however thin the box. Boxes are closed: touching a face counts as a collision, so a path
this checker accepts keeps strictly clear of every box.

The test holds at every scale the problem format accepts (sides from 1e-30 to 1e30): it has
no absolute tolerance. Only a change of exactly zero along an axis makes the segment parallel
to that axis's faces; any other change, however small, is divided by (a quotient that
overflows to infinity still orders correctly against the segment's ``[0, 1]``).
"""

from __future__ import annotations

import numba
import numpy as np

from temp_gym.worlds.cells import next_cell
from temp_gym.worlds.collision.arm_inputs import as_edges, as_path, as_state, as_states
from temp_gym.worlds.collision.compiled import register_motion_kernel


@numba.njit(cache=True, nogil=True)
def _point_free(point, lower_bounds, upper_bounds, box_lower, box_upper) -> bool:
    dim = point.shape[0]
    for k in range(dim):
        if point[k] < lower_bounds[k] or point[k] > upper_bounds[k]:
            return False
    for b in range(box_lower.shape[0]):
        inside = True
        for k in range(dim):
            if point[k] < box_lower[b, k] or point[k] > box_upper[b, k]:
                inside = False
                break
        if inside:
            return False
    return True


@numba.njit(cache=True, nogil=True)
def _segment_hits_box(start, end, lower, upper) -> bool:
    """Slab test: does the closed segment start->end meet the closed box [lower, upper]?"""
    t_enter = 0.0
    t_exit = 1.0
    for k in range(start.shape[0]):
        delta = end[k] - start[k]
        if delta == 0.0:
            if start[k] < lower[k] or start[k] > upper[k]:
                return False
        else:
            t0 = (lower[k] - start[k]) / delta
            t1 = (upper[k] - start[k]) / delta
            if t0 > t1:
                t0, t1 = t1, t0
            if t0 > t_enter:
                t_enter = t0
            if t1 < t_exit:
                t_exit = t1
            if t_enter > t_exit:
                return False
    return True


@numba.njit(cache=True, nogil=True)
def _segment_free(start, end, lower_bounds, upper_bounds, box_lower, box_upper) -> bool:
    # The configuration space is a box, so a segment with both ends in bounds stays in bounds.
    for k in range(start.shape[0]):
        if start[k] < lower_bounds[k] or start[k] > upper_bounds[k]:
            return False
        if end[k] < lower_bounds[k] or end[k] > upper_bounds[k]:
            return False
    for b in range(box_lower.shape[0]):
        if _segment_hits_box(start, end, box_lower[b], box_upper[b]):
            return False
    return True


@numba.njit(cache=True, nogil=True)
def _context_segment_free(context, start, end) -> bool:
    """`_segment_free` for the compiled context of `PointBoxChecker.compiled_context`."""
    lower_bounds, upper_bounds, box_lower, box_upper = context
    return _segment_free(start, end, lower_bounds, upper_bounds, box_lower, box_upper)


@numba.njit(cache=True, nogil=True)
def _states_free(states, lower_bounds, upper_bounds, box_lower, box_upper):
    out = np.empty(states.shape[0], dtype=np.bool_)
    for i in range(states.shape[0]):
        out[i] = _point_free(states[i], lower_bounds, upper_bounds, box_lower, box_upper)
    return out


@numba.njit(cache=True, nogil=True)
def _edges_free(starts, ends, lower_bounds, upper_bounds, box_lower, box_upper):
    out = np.empty(starts.shape[0], dtype=np.bool_)
    for i in range(starts.shape[0]):
        out[i] = _segment_free(starts[i], ends[i], lower_bounds, upper_bounds, box_lower, box_upper)
    return out


@numba.njit(cache=True, nogil=True)
def _path_free(path, lower_bounds, upper_bounds, box_lower, box_upper) -> bool:
    if path.shape[0] == 1:
        return _point_free(path[0], lower_bounds, upper_bounds, box_lower, box_upper)
    for i in range(path.shape[0] - 1):
        if not _segment_free(
            path[i], path[i + 1], lower_bounds, upper_bounds, box_lower, box_upper
        ):
            return False
    return True


@numba.njit(cache=True, nogil=True)
def _union_volume(lower, upper) -> float:
    """`union_volume` of boxes already clipped to the bounds and non-empty.

    Each box adds +1 where it starts and -1 where it ends along the last axis, on every row of
    cells its other axes cover; a running sum along each row then gives the covered length.
    """
    count, dim = lower.shape
    last = dim - 1
    cuts = np.empty((dim, 2 * count))
    sizes = np.empty(dim, dtype=np.int64)
    for k in range(dim):
        axis = np.unique(np.concatenate((lower[:, k], upper[:, k])))
        sizes[k] = axis.shape[0]
        cuts[k, : axis.shape[0]] = axis
    strides = np.ones(dim, dtype=np.int64)  # of a row's index over the axes but the last
    rows = 1
    for k in range(last - 1, -1, -1):
        strides[k] = rows
        rows *= sizes[k] - 1
    steps = np.zeros((rows, sizes[last]), dtype=np.int32)
    first = np.empty(dim, dtype=np.int64)
    stop = np.empty(dim, dtype=np.int64)
    cell = np.empty(dim, dtype=np.int64)
    for b in range(count):
        for k in range(dim):
            first[k] = np.searchsorted(cuts[k, : sizes[k]], lower[b, k])
            stop[k] = np.searchsorted(cuts[k, : sizes[k]], upper[b, k])
            cell[k] = first[k]
        while True:  # every row of the box, an odometer over the axes but the last
            row = 0
            for k in range(last):
                row += cell[k] * strides[k]
            steps[row, first[last]] += 1
            steps[row, stop[last]] -= 1
            if not next_cell(cell, first, stop, last):
                break
    volume = 0.0
    for row in range(rows):
        depth = 0
        length = 0.0
        for j in range(sizes[last] - 1):
            depth += steps[row, j]
            if depth > 0:
                length += cuts[last, j + 1] - cuts[last, j]
        if length > 0.0:
            rest = row
            for k in range(last):
                index = rest // strides[k]
                rest -= index * strides[k]
                length *= cuts[k, index + 1] - cuts[k, index]
            volume += length
    return volume


MAX_UNION_CELLS = 2**24
"""Most cells of the grid `union_volume` computes exactly on (64 MB of counts, a second or so);
beyond, it estimates. The boxes' faces cut each axis, so the grid grows as ``(2 n)^d`` for n
boxes: a few thousand boxes in 2D, about 120 in 3D, more when boxes share coordinates."""
UNION_SAMPLES = 2**14
"""Seeded uniform samples of `union_volume`'s estimate: about 0.4% of the bounds' volume at
worst (one standard deviation), ample for the rewiring radius, which is all it serves."""


def union_volume(
    box_lower: np.ndarray, box_upper: np.ndarray, lower_bounds: np.ndarray, upper_bounds: np.ndarray
) -> float:
    """The volume of the union of the boxes ``[box_lower[i], box_upper[i]]`` within the bounds.

    Exact, by coordinate compression: the box faces cut each axis into intervals, and every
    cell of that grid is either inside some box or outside all of them, so overlaps count once
    and parts outside the bounds not at all. When that grid would exceed `MAX_UNION_CELLS`
    cells (many boxes in 3D), memory and time would grow as ``(2 n)^d``; the volume is then
    estimated from `UNION_SAMPLES` uniform samples of the bounds with a fixed seed, so it is
    still the same number on every call.
    """
    lower = np.clip(box_lower, lower_bounds, upper_bounds)
    upper = np.clip(box_upper, lower_bounds, upper_bounds)
    kept = np.all(upper > lower, axis=1)
    if not np.any(kept):
        return 0.0
    lower = np.ascontiguousarray(lower[kept])
    upper = np.ascontiguousarray(upper[kept])
    cells = 1
    for k in range(lower.shape[1]):
        cells *= len(np.unique(np.concatenate((lower[:, k], upper[:, k])))) - 1
        if cells > MAX_UNION_CELLS:
            rng = np.random.default_rng(0)
            low = np.asarray(lower_bounds, dtype=np.float64)
            high = np.asarray(upper_bounds, dtype=np.float64)
            samples = rng.uniform(low, high, size=(UNION_SAMPLES, lower.shape[1]))
            covered = np.count_nonzero(~_states_free(samples, low, high, lower, upper))
            return float(covered / UNION_SAMPLES * np.prod(high - low))
    return float(_union_volume(lower, upper))


@numba.njit(cache=True, nogil=True)
def _block_sum(values, start, count):
    """The sum of at most 128 values as numpy's pairwise summation adds them (its leaves)."""
    if count < 8:
        total = 0.0
        for i in range(start, start + count):
            total += values[i]
        return total
    r0, r1, r2, r3 = values[start], values[start + 1], values[start + 2], values[start + 3]
    r4, r5, r6, r7 = values[start + 4], values[start + 5], values[start + 6], values[start + 7]
    i = start + 8
    blocks_end = start + count - count % 8
    while i < blocks_end:
        r0 += values[i]
        r1 += values[i + 1]
        r2 += values[i + 2]
        r3 += values[i + 3]
        r4 += values[i + 4]
        r5 += values[i + 5]
        r6 += values[i + 6]
        r7 += values[i + 7]
        i += 8
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < start + count:
        total += values[i]
        i += 1
    return total


@numba.njit(cache=True, nogil=True)
def _split(count: int) -> int:
    """Where numpy's pairwise summation splits ``count`` values: half, less half mod 8."""
    half = count // 2
    return half - half % 8


@numba.njit(cache=True, nogil=True)
def _numpy_sum(values, start, count):
    """``np.sum(values[start:start + count])`` to the bit: numpy's pairwise summation.

    Fewer than 8 values are added in order; up to 128 go to eight running sums combined as
    ``((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))``, then the remainder in order; more
    are split in two (`_split`) and the halves' sums added. Written out so that a compiled
    caller gets the value numpy computes, not merely a close one. The halving runs on an
    explicit stack: numba's cache does not load recursive functions safely.
    """
    if count <= 128:
        return _block_sum(values, start, count)
    depth = 64  # halving 2**63 values 64 times reaches a block
    starts = np.empty(depth, np.int64)
    counts = np.empty(depth, np.int64)
    stages = np.empty(depth, np.int64)  # 0: not split yet; 1: left half running; 2: right
    lefts = np.empty(depth)
    starts[0], counts[0], stages[0] = start, count, 0
    size = 1
    value = 0.0
    while True:
        top = size - 1
        if stages[top] == 0 and counts[top] <= 128:  # a block: its sum goes to its parent
            value = _block_sum(values, starts[top], counts[top])
            size -= 1
        elif stages[top] == 0:  # split: the left half first
            stages[top] = 1
            starts[size], counts[size], stages[size] = starts[top], _split(counts[top]), 0
            size += 1
            continue
        elif stages[top] == 1:  # the left half's sum is in: the right half next
            lefts[top] = value
            stages[top] = 2
            half = _split(counts[top])
            starts[size], counts[size], stages[size] = starts[top] + half, counts[top] - half, 0
            size += 1
            continue
        else:  # both halves are in
            value = lefts[top] + value
            size -= 1
        if size == 0:
            return value


@numba.njit(cache=True, nogil=True)
def _volume_floor(lower_bounds, upper_bounds, box_lower, box_upper) -> float:
    """`PointBoxChecker.free_volume_floor` in one compiled call, to the bit of numpy's formula."""
    count, dim = box_lower.shape
    volumes = np.empty(count)
    for b in range(count):
        volume = 1.0
        for k in range(dim):
            low = min(max(box_lower[b, k], lower_bounds[k]), upper_bounds[k])
            high = min(max(box_upper[b, k], lower_bounds[k]), upper_bounds[k])
            volume *= max(high - low, 0.0)
        volumes[b] = volume
    boxes = _numpy_sum(volumes, 0, count)
    total = 1.0
    for k in range(dim):
        total *= upper_bounds[k] - lower_bounds[k]
    return total - boxes - 1e-9 * total


def _finite_rows(states: np.ndarray) -> np.ndarray:
    """``bool[N]``: the rows without NaN or inf.

    A NaN passes the kernels' comparisons: it would count as inside the bounds and outside a box.
    """
    return np.isfinite(states).all(axis=1)


class PointBoxChecker:
    """Fast *and* exact checker for a point robot among axis-aligned boxes.

    Args:
        bounds: ``(2, d)`` configuration-space bounds; states outside are not free.
        box_lower: ``(M, d)`` lower box corners.
        box_upper: ``(M, d)`` upper box corners.
    """

    def __init__(self, bounds: np.ndarray, box_lower: np.ndarray, box_upper: np.ndarray) -> None:
        bounds = np.ascontiguousarray(bounds, dtype=np.float64)
        self.dim = bounds.shape[1]
        self._lower_bounds = bounds[0].copy()
        self._upper_bounds = bounds[1].copy()
        self._box_lower = np.ascontiguousarray(box_lower, dtype=np.float64).reshape(-1, self.dim)
        self._box_upper = np.ascontiguousarray(box_upper, dtype=np.float64).reshape(-1, self.dim)
        self.description = f"analytic segment-vs-box test, {len(self._box_lower)} boxes"
        self._context: tuple[np.ndarray, ...] | None = None

    def free_volume(self) -> float:
        """The volume of the free space: the bounds less the union of the boxes.

        Exact, unless the boxes cut the bounds into more than `MAX_UNION_CELLS` cells; then a
        seeded estimate (`union_volume`).
        """
        total = float(np.prod(self._upper_bounds - self._lower_bounds))
        return total - union_volume(
            self._box_lower, self._box_upper, self._lower_bounds, self._upper_bounds
        )

    def free_volume_floor(self) -> float:
        """A lower bound of `free_volume` at a fraction of its cost.

        The bounds less the sum of the boxes' volumes within them (an overlap is subtracted
        twice), less a margin of ``1e-9`` of the bounds for rounding, so the bound holds for the
        computed `free_volume` too. May be negative.
        """
        return float(
            _volume_floor(self._lower_bounds, self._upper_bounds, self._box_lower, self._box_upper)
        )

    def compiled_context(self) -> tuple[np.ndarray, ...]:
        """Bounds and boxes for `temp_gym.worlds.collision.compiled.motion_free` (made once)."""
        if self._context is None:
            context = (self._lower_bounds, self._upper_bounds, self._box_lower, self._box_upper)
            register_motion_kernel(context, _context_segment_free)
            self._context = context
        return self._context

    def _as_states(self, states: np.ndarray) -> np.ndarray:
        return as_states(states, self.dim)

    def states_free(self, states: np.ndarray) -> np.ndarray:
        """Return ``bool[N]``: each state is inside the bounds and outside every box."""
        states = self._as_states(states)
        free = _states_free(
            states, self._lower_bounds, self._upper_bounds, self._box_lower, self._box_upper
        )
        return free & _finite_rows(states)

    def edge_free(self, start: np.ndarray, end: np.ndarray) -> bool:
        """Whether the closed segment ``start``-``end`` misses every box (exact)."""
        start = as_state(start, "start", self.dim)
        end = as_state(end, "end", self.dim)
        if not (np.all(np.isfinite(start)) and np.all(np.isfinite(end))):
            return False  # NaN passes every comparison: never free
        return bool(
            _segment_free(
                start, end, self._lower_bounds, self._upper_bounds, self._box_lower, self._box_upper
            )
        )

    def edges_free(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """Return ``bool[N]``: `edge_free` for each row pair of ``starts`` and ``ends``."""
        starts, ends = as_edges(starts, ends, self.dim)
        free = _edges_free(
            starts, ends, self._lower_bounds, self._upper_bounds, self._box_lower, self._box_upper
        )
        return free & _finite_rows(starts) & _finite_rows(ends)

    def path_free(self, path: np.ndarray) -> bool:
        """Whether every segment of the polyline ``path`` (K x d, K >= 1) is free."""
        path = as_path(path, self.dim)
        return bool(_finite_rows(path).all()) and bool(
            _path_free(
                path, self._lower_bounds, self._upper_bounds, self._box_lower, self._box_upper
            )
        )
