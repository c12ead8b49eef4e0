"""Visiting every cell of a block of a grid from compiled code: an odometer over its axes.

The occupancy grid (`temp_gym.worlds.encoding`) marks the cells a box covers, and the point
robots' exact free volume (`temp_gym.worlds.collision.point.union_volume`) the rows of cells
it covers; both walk the block ``[first, stop)`` of cell indices the same way.
"""

from __future__ import annotations

import numba


@numba.njit(cache=True, nogil=True)
def next_cell(index, first, stop, axes) -> bool:
    """Step ``index`` to the next cell of the block ``[first, stop)``, in C order.

    Only the first ``axes`` axes are walked, the last of them fastest. Returns False, with
    ``index`` back at ``first``, once every cell has been visited; start from
    ``index = first`` with a non-empty block.
    """
    k = axes - 1
    while k >= 0:
        index[k] += 1
        if index[k] < stop[k]:
            return True
        index[k] = first[k]
        k -= 1
    return False
