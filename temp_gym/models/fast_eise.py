"""`FastEISE`: the EISE encoder for one occupancy grid, as a numba kernel on numpy weights.

The planner encodes every new workspace once: one `EISE` forward pass on one grid. In PyTorch
that call is dominated by fixed costs, and in a planning loop, where the previous plan has
pushed the weights out of the cache, it costs several times its warm time. The grid is 0/1
(`temp_gym.worlds.encoding.occupancy_grid`), so the first layer's product is a sum of the
weight rows of the occupied cells, and after the ReLU many hidden units are 0,
so the second layer reads only the rows of the active ones. `FastEISE` does exactly that and
touches a fraction of the weights.

It computes what `EISE.forward` computes for a batch of one, up to float rounding: sums are
accumulated in float64 and rounded to float32 once per layer (torch sums in float32, in its
own order). Any grid values work, not only 0 and 1: a cell of value v adds v times its row,
and a cell of 0 adds nothing.

Examples:
    >>> fast = FastEISE(model.eise)          # once: copies the encoder's weights
    >>> sei = fast(grid)                     # (*grid_shape) -> (num_tokens, token_dim) float32

The weights are a snapshot, as `temp_gym.models.fast_mpt.FastMPT`'s: build a new `FastEISE`
after changing the model's parameters.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numba
import numpy as np

from temp_gym.models.array_backed import ArrayBacked
from temp_gym.problem import Workspace
from temp_gym.worlds.encoding import mark_obstacles, occupancy_obstacles

if TYPE_CHECKING:  # PyTorch is imported only to take a snapshot of a model (`eise_arrays`)
    import torch

    from temp_gym.models.eise import EISE


@numba.njit(cache=True, nogil=True)
def _encode_kernel(
    grid: np.ndarray,
    w1: np.ndarray,
    b1: np.ndarray,
    w2: np.ndarray,
    b2: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out = relu(relu(grid @ w1 + b1) @ w2 + b2)``, skipping zero cells and hidden units.

    ``grid`` is ``(cells,)``, ``w1`` ``(cells, hidden)``, ``w2`` ``(hidden, code)``, all
    float32; ``out`` is ``(code,)`` float32.
    """
    hidden_size = w1.shape[1]
    code_size = w2.shape[1]
    hidden = np.zeros(hidden_size, np.float64)
    for cell in range(grid.shape[0]):
        value = np.float64(grid[cell])
        if value != 0.0:  # NaN passes, and spreads as it does in torch
            row = w1[cell]
            for unit in range(hidden_size):
                hidden[unit] += value * row[unit]
    code = np.zeros(code_size, np.float64)
    for unit in range(hidden_size):
        activation = np.float64(np.float32(hidden[unit] + b1[unit]))
        if activation > 0.0 or activation != activation:  # ReLU; NaN spreads
            row = w2[unit]
            for k in range(code_size):
                code[k] += activation * row[k]
    for k in range(code_size):
        value = np.float32(code[k] + b2[k])
        out[k] = value if value > 0 or value != value else np.float32(0.0)


@numba.njit(cache=True, nogil=True)
def _encode_obstacles_kernel(
    region, codes, centers, halves, rotations, lower, upper, resolution, w1, b1, w2, b2, out
) -> None:
    """`_encode_kernel` of the occupancy grid (`mark_obstacles`' grid), in one call."""
    occupied = np.zeros(resolution ** region.shape[1], np.bool_)
    mark_obstacles(occupied, region, codes, centers, halves, rotations, lower, upper, resolution)
    _encode_kernel(occupied.astype(np.float32), w1, b1, w2, b2, out)


def _weights(layer: torch.nn.Linear) -> tuple[np.ndarray, np.ndarray]:
    """A linear layer's weight as a contiguous float32 ``(in, out)`` copy, and its bias."""
    import torch

    with torch.no_grad():
        weight = np.array(layer.weight.detach().cpu().numpy().T, np.float32, order="C")
        bias = np.array(layer.bias.detach().cpu().numpy(), np.float32, order="C")
    return weight, bias


def eise_arrays(eise: EISE) -> dict[str, np.ndarray]:
    """An `EISE` encoder's inference snapshot: its two layers and its sizes, as numpy (a copy).

    What `FastEISE.from_arrays` reads; the reconstruction decoder is not part of it.
    """
    first, _, second, _ = eise.encoder
    (w1, b1), (w2, b2) = _weights(first), _weights(second)
    return {
        "w1": w1, "b1": b1, "w2": w2, "b2": b2,
        "grid_shape": np.array(eise.grid_shape, np.int64),
        "num_tokens": np.array(int(eise.num_tokens)),
        "token_dim": np.array(int(eise.token_dim)),
    }  # fmt: skip


class FastEISE(ArrayBacked):
    """An `EISE` encoder's weights as float32 numpy arrays and its one-grid forward in numba.

    Args:
        eise: the encoder; its parameters are copied (a snapshot). `from_arrays` builds one
            from a stored snapshot instead (`eise_arrays`' dict), without PyTorch.
    """

    NAMES = ("w1", "b1", "w2", "b2", "grid_shape", "num_tokens", "token_dim")
    KIND = "EISE snapshot"

    def __init__(self, eise: EISE) -> None:
        self._set(eise_arrays(eise))

    def _load(self, arrays: dict[str, np.ndarray]) -> None:
        self.grid_shape = tuple(int(size) for size in arrays["grid_shape"])
        self.num_tokens = int(arrays["num_tokens"])
        self.token_dim = int(arrays["token_dim"])
        self._w1, self._b1, self._w2, self._b2 = (arrays[name] for name in self.NAMES[:4])
        cells, hidden = self._w1.shape
        if (
            cells != math.prod(self.grid_shape)
            or self._b1.shape != (hidden,)
            or self._w2.shape != (hidden, self.num_tokens * self.token_dim)
            or self._b2.shape != (self.num_tokens * self.token_dim,)
        ):
            raise ValueError(
                f"EISE snapshot: w1 {self._w1.shape}, w2 {self._w2.shape} do not fit a grid of "
                f"{self.grid_shape} and {self.num_tokens} tokens of {self.token_dim}"
            )

    def __call__(self, occupancy: np.ndarray) -> np.ndarray:
        """The SEI tokens ``(num_tokens, token_dim)`` float32 of one grid of ``grid_shape``."""
        grid = np.asarray(occupancy)
        if grid.shape != self.grid_shape:
            raise ValueError(
                f"occupancy: expected a grid of shape {self.grid_shape}, got {grid.shape}"
            )
        flat = np.ascontiguousarray(grid, np.float32).reshape(math.prod(self.grid_shape))
        out = np.empty(self.num_tokens * self.token_dim, np.float32)
        _encode_kernel(flat, self._w1, self._b1, self._w2, self._b2, out)
        return out.reshape(self.num_tokens, self.token_dim)

    def encode_workspace(self, workspace: Workspace) -> np.ndarray:
        """The SEI tokens of a workspace's occupancy grid: ``self(occupancy_grid(...))``.

        The grid is made and encoded in one compiled call, with nothing cached: what a
        policy pays once per new workspace, at the start of a plan. The encoder's grid must
        be the workspace's: one axis per workspace dimension, all of one resolution.
        """
        region, *obstacles = occupancy_obstacles(workspace)
        resolution = self.grid_shape[0]
        if self.grid_shape != (resolution,) * region.shape[1]:
            raise ValueError(
                f"workspace: a {region.shape[1]}D workspace has no occupancy grid of the "
                f"encoder's shape {self.grid_shape}"
            )
        out = np.empty(self.num_tokens * self.token_dim, np.float32)
        _encode_obstacles_kernel(
            region, *obstacles, resolution, self._w1, self._b1, self._w2, self._b2, out
        )
        return out.reshape(self.num_tokens, self.token_dim)


__all__ = ["FastEISE"]
