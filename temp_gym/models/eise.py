"""`EISE`: the Environmental Information Semantic Encoder (paper, Section III-A).

A fully connected encoder with ReLU turns the flattened occupancy grid O into the semantic
environment information S, a short sequence of ``num_tokens`` tokens of width ``token_dim``
that the Motion Planning Transformer attends to. A fully connected decoder maps S back to
reconstruction **logits** Ô of the grid; the reconstruction loss is binary cross-entropy with
logits (the grid is 0/1), see `temp_gym.models.loss`. S is trained by both the reconstruction
and the planning (semantic) loss, so it learns what the planner needs, not only what the grid
looks like.

Examples:
    >>> eise = EISE(grid_shape=(32, 32), hidden=256, num_tokens=8, token_dim=64)
    >>> sei = eise(occupancy)          # (B, 32, 32) -> (B, 8, 64)
    >>> logits = eise.decode(sei)      # (B, 32, 32)
"""

from __future__ import annotations

import math

import torch
from torch import nn


class EISE(nn.Module):
    """Occupancy grid -> SEI tokens, and SEI tokens -> reconstruction logits.

    Args:
        grid_shape: shape of one occupancy grid, ``(R,) * w``.
        hidden: width of the hidden layer of the encoder and of the decoder.
        num_tokens: number of SEI tokens.
        token_dim: width of each SEI token.
    """

    def __init__(
        self, grid_shape: tuple[int, ...], hidden: int, num_tokens: int, token_dim: int
    ) -> None:
        super().__init__()
        self.grid_shape = tuple(int(size) for size in grid_shape)
        self.num_tokens = int(num_tokens)
        self.token_dim = int(token_dim)
        cells = math.prod(self.grid_shape)
        code = self.num_tokens * self.token_dim
        self.encoder = nn.Sequential(
            nn.Linear(cells, hidden), nn.ReLU(), nn.Linear(hidden, code), nn.ReLU()
        )
        self.decoder = nn.Sequential(nn.Linear(code, hidden), nn.ReLU(), nn.Linear(hidden, cells))

    def forward(self, occupancy: torch.Tensor) -> torch.Tensor:
        """Encode ``(B, *grid_shape)`` grids into SEI tokens ``(B, num_tokens, token_dim)``."""
        flat = occupancy.reshape(occupancy.shape[0], -1)
        if flat.shape[1] != math.prod(self.grid_shape):
            raise ValueError(
                f"occupancy: expected grids of shape {self.grid_shape}, got "
                f"{tuple(occupancy.shape[1:])}"
            )
        return self.encoder(flat).reshape(-1, self.num_tokens, self.token_dim)

    def decode(self, sei: torch.Tensor) -> torch.Tensor:
        """Reconstruction logits ``(B, *grid_shape)`` of the grids (sigmoid gives Ô)."""
        return self.decoder(sei.reshape(sei.shape[0], -1)).reshape(-1, *self.grid_shape)
