"""`MPT`: the Motion Planning Transformer (paper, Section III-B, Eq. 2-4).

The input sequence, after token embedding and a learnable positional encoding, is

| position | token | embedded from |
|---|---|---|
| 0 | OUT | a learned token plus an embedding of the current node x_c and of goal - x_c |
| 1 .. n | SEI | the EISE's tokens S (a linear map each) |
| n + 1 | Goal | the normalized goal and the goal radius |
| n + 2 | Start | the normalized start |
| n + 3 .. n + 2 + L | HPD | the path so far, a token per node; padding rows are masked |

The prediction is read from the dedicated output token (rather than the last valid history
token): its position is the same for every path length, it is the query whose attention over
SEI, Goal, Start and HPD the paper plots (`temp_gym.models.attention`), and it carries the
current node x_c (the last valid HPD row) and the offset to the goal, so the query that decides
the next sample knows where the tree is and where it is headed. Putting it first means
trailing padding can be cut off without changing any result: `MPT.forward` trims the path to
the longest valid one in the batch.

The positional encoding of the HPD tokens counts back from the newest node (the current
node has HPD position 0, its parent 1, ...), so "the most recent nodes" are at the same
positions whatever the path length.

Each of the M layers is pre-norm: ``z = z + MHA(LN(z))``, ``z = z + FFN(LN(z))`` with
``FFN(x) = max(0, x W1 + b1) W2 + b2`` (Eq. 3-4); a final LayerNorm and a linear head with
tanh map the output token to the normalized configuration space [-1, 1]^d, in one of two ways
(``prediction``):

* ``offset`` (default): ``x̂ = clip(x_c + offset_scale · tanh(head(z_out)), -1, 1)`` where x_c
  is the current node, the last valid HPD row. The next node is a step away from x_c, so a
  bounded offset is learned far more precisely than an absolute position.
* ``absolute``: ``x̂ = tanh(head(z_out))``.

**Chunks.** With ``chunk = k > 1`` the head predicts the next k nodes of the path in one call
(action chunking, as in behaviour cloning for manipulation): ``x̂_1`` as above, then each
``x̂_j = clip(x̂_{j-1} + offset_scale · tanh(head_j(z_out)), -1, 1)`` continues from the
previous prediction (``absolute``: ``x̂_j = tanh(head_j(z_out))``). The planner then runs the
MPT once per k nodes while its proposals keep extending the tree, which divides the model's
share of a node's cost, and training on the summed loss over the chunk penalizes a policy that
drifts (`temp_gym.models.loss.TEMPLoss`). ``chunk = 1`` is the paper's MPT.

The attention is written out (not `torch.nn.MultiheadAttention`) so that every layer's and
head's softmax weights can be returned, ``(B, layers, heads, queries, keys)``.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn


class SelfAttention(nn.Module):
    """Multi-head self-attention (Eq. 2) that can return its per-head softmax weights."""

    def __init__(self, token_dim: int, num_heads: int, dropout: float) -> None:
        super().__init__()
        if token_dim % num_heads:
            raise ValueError(f"token_dim {token_dim} is not divisible by num_heads {num_heads}")
        self.num_heads = num_heads
        self.head_dim = token_dim // num_heads
        self.qkv = nn.Linear(token_dim, 3 * token_dim)
        self.out = nn.Linear(token_dim, token_dim)
        self.dropout = nn.Dropout(dropout)

    def forward(
        self, z: torch.Tensor, key_bias: torch.Tensor | None, need_weights: bool
    ) -> tuple[torch.Tensor, torch.Tensor | None]:
        """Attend; ``key_bias`` is ``(B, 1, 1, K)`` with -inf on masked keys, or None."""
        batch, tokens, width = z.shape
        qkv = self.qkv(z).reshape(batch, tokens, 3, self.num_heads, self.head_dim)
        query, key, value = qkv.permute(2, 0, 3, 1, 4)  # each (B, heads, T, head_dim)
        if need_weights:
            scores = query @ key.transpose(-2, -1) * (1.0 / math.sqrt(self.head_dim))
            if key_bias is not None:
                scores = scores + key_bias
            weights = torch.softmax(scores, dim=-1)
            mixed = self.dropout(weights) @ value
        else:  # the same computation, fused (faster on CPU and GPU); no weights to return
            weights = None
            mixed = F.scaled_dot_product_attention(
                query,
                key,
                value,
                attn_mask=key_bias,
                dropout_p=self.dropout.p if self.training else 0.0,
            )
        mixed = mixed.transpose(1, 2).reshape(batch, tokens, width)
        return self.out(mixed), weights


class MPTLayer(nn.Module):
    """One pre-norm transformer layer: attention and FFN, each with LayerNorm and a residual."""

    def __init__(self, token_dim: int, num_heads: int, ffn_dim: int, dropout: float) -> None:
        super().__init__()
        self.norm_attention = nn.LayerNorm(token_dim)
        self.attention = SelfAttention(token_dim, num_heads, dropout)
        self.norm_ffn = nn.LayerNorm(token_dim)
        self.ffn = nn.Sequential(
            nn.Linear(token_dim, ffn_dim), nn.ReLU(), nn.Linear(ffn_dim, token_dim)
        )
        self.dropout = nn.Dropout(dropout)

    def forward(
        self, z: torch.Tensor, key_bias: torch.Tensor | None, need_weights: bool
    ) -> tuple[torch.Tensor, torch.Tensor | None]:
        """Apply the layer; returns the new tokens and (optionally) the attention weights."""
        attended, weights = self.attention(self.norm_attention(z), key_bias, need_weights)
        z = z + self.dropout(attended)
        z = z + self.dropout(self.ffn(self.norm_ffn(z)))
        return z, weights


class MPT(nn.Module):
    """SEI, task and path so far -> the next sample, normalized to [-1, 1]^d.

    Args:
        dim: configuration-space dimension d.
        token_dim: token width (the SEI tokens have this width too).
        num_heads: attention heads per layer.
        num_layers: M, the number of layers.
        ffn_dim: hidden width of the FFN.
        num_sei_tokens: how many SEI tokens the EISE produces.
        max_path_length: L, the most HPD tokens.
        dropout: dropout on attention weights and residual branches (training only).
        prediction: ``offset`` (from the current node) or ``absolute`` (module docstring).
        offset_scale: the largest offset per coordinate, normalized units (``offset`` only).
        chunk: k, the nodes predicted per call (module docstring).
    """

    def __init__(
        self,
        dim: int,
        token_dim: int,
        num_heads: int,
        num_layers: int,
        ffn_dim: int,
        num_sei_tokens: int,
        max_path_length: int,
        dropout: float = 0.0,
        prediction: str = "offset",
        offset_scale: float = 0.5,
        chunk: int = 1,
    ) -> None:
        super().__init__()
        if prediction not in ("offset", "absolute"):
            raise ValueError(f"prediction: expected 'offset' or 'absolute', got {prediction!r}")
        if isinstance(chunk, bool) or not isinstance(chunk, int) or chunk < 1:
            raise ValueError(f"chunk: expected an integer of at least 1, got {chunk!r}")
        self.chunk = chunk
        self.prediction = prediction
        self.offset_scale = float(offset_scale)
        self.dim = int(dim)
        self.num_sei_tokens = int(num_sei_tokens)
        self.max_path_length = int(max_path_length)
        self.output_token = nn.Parameter(torch.zeros(1, 1, token_dim))
        self.embed_sei = nn.Linear(token_dim, token_dim)
        self.embed_goal = nn.Linear(dim + 1, token_dim)  # goal and goal radius
        self.embed_start = nn.Linear(dim, token_dim)
        self.embed_path = nn.Linear(dim, token_dim)
        self.embed_current = nn.Linear(2 * dim, token_dim)  # x_c and goal - x_c
        self.position = nn.Parameter(torch.zeros(1, self.num_prefix, token_dim))
        self.path_position = nn.Parameter(torch.zeros(max_path_length, token_dim))
        nn.init.normal_(self.position, std=0.02)
        nn.init.normal_(self.path_position, std=0.02)
        nn.init.normal_(self.output_token, std=0.02)
        self.layers = nn.ModuleList(
            MPTLayer(token_dim, num_heads, ffn_dim, dropout) for _ in range(num_layers)
        )
        self.norm = nn.LayerNorm(token_dim)
        self.head = nn.Linear(token_dim, chunk * dim)

    @property
    def num_prefix(self) -> int:
        """Tokens before the first HPD token: OUT, the SEI tokens, Goal, Start."""
        return self.num_sei_tokens + 3

    def forward(
        self,
        sei: torch.Tensor,
        goal: torch.Tensor,
        goal_radius: torch.Tensor,
        start: torch.Tensor,
        path: torch.Tensor,
        path_length: torch.Tensor,
        need_weights: bool = False,
    ) -> tuple[torch.Tensor, torch.Tensor | None]:
        """Predict the next ``chunk`` samples.

        Args:
            sei: ``(B, n, token_dim)`` SEI tokens.
            goal: ``(B, d)`` normalized goal.
            goal_radius: ``(B, 1)``.
            start: ``(B, d)`` normalized start.
            path: ``(B, L', d)`` path so far, zero-padded, ``L' <= L``.
            path_length: ``(B,)`` or ``(B, 1)`` valid rows of ``path`` (at least 1).
            need_weights: also return the attention weights.

        Returns:
            The samples ``(B, chunk, d)`` in [-1, 1] (the next node first), and the attention
            weights
            ``(B, layers, heads, T, T)`` (or None), ``T = num_prefix + L''`` where ``L''`` is
            the longest valid path of the batch (trailing padding is dropped).
        """
        batch = sei.shape[0]
        lengths = path_length.reshape(batch).long()
        rows = int(lengths.max()) if batch else 1
        if rows > path.shape[1] or rows > self.max_path_length or bool((lengths < 1).any()):
            raise ValueError(
                f"path_length: expected 1..{min(path.shape[1], self.max_path_length)}, "
                f"got {lengths.tolist()}"
            )
        path = path[:, :rows]
        current = path[torch.arange(batch, device=path.device), lengths - 1]
        output_token = self.output_token + self.embed_current(
            torch.cat([current, goal - current], dim=-1)
        ).unsqueeze(1)
        prefix = torch.cat(
            [
                output_token,
                self.embed_sei(sei),
                self.embed_goal(torch.cat([goal, goal_radius], dim=-1)).unsqueeze(1),
                self.embed_start(start).unsqueeze(1),
            ],
            dim=1,
        )
        # HPD positions count back from the newest node; padding rows get position 0 (masked).
        recency = (lengths.unsqueeze(1) - 1 - torch.arange(rows, device=path.device)).clamp(min=0)
        z = torch.cat(
            [prefix + self.position, self.embed_path(path) + self.path_position[recency]], dim=1
        )
        key_bias = None
        if bool((lengths < rows).any()):  # some rows are padding: mask them as keys
            padded = torch.arange(rows, device=path.device).unsqueeze(0) >= lengths.unsqueeze(1)
            bias = torch.zeros(batch, z.shape[1], device=path.device, dtype=z.dtype)
            bias[:, self.num_prefix :] = bias[:, self.num_prefix :].masked_fill(
                padded, float("-inf")
            )
            key_bias = bias[:, None, None, :]
        weights = []
        for layer in self.layers:
            z, layer_weights = layer(z, key_bias, need_weights)
            weights.append(layer_weights)
        output = torch.tanh(self.head(self.norm(z[:, 0]))).reshape(batch, self.chunk, -1)
        if self.prediction == "offset":
            samples = []
            previous = current
            for j in range(self.chunk):
                previous = torch.clamp(previous + self.offset_scale * output[:, j], -1.0, 1.0)
                samples.append(previous)
            sample = torch.stack(samples, dim=1)
        else:
            sample = output
        return sample, (torch.stack(weights, dim=1) if need_weights else None)
