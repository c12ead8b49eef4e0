"""`FastMPT`: the MPT's forward pass for one sample, as numba kernels on numpy weights.

The TEMP planner asks the MPT for one sample per tree extension (batch 1). The model is tiny
(a few layers of 64-wide tokens), so in PyTorch nearly all of a call is per-operator overhead:
about 0.5 ms, against ~20 us for a whole RRT* extension. `FastMPT` copies the weights of an
`MPT` once into numpy arrays and runs the same computation (eval mode, no dropout) as numba
kernels and BLAS calls: 5-10x faster on one core for paths of up to ~30 nodes, ~4x at L = 64
(``python benchmarks/inference.py``).

It computes exactly what `MPT.forward` computes for a batch of one whose path is trimmed to its
valid rows (so there is no padding and no mask), up to float rounding, plus two savings that do
not change the result:

* **Per-problem prefix.** The SEI, Goal and Start tokens (and their positions) depend only on
  the problem, and so do the first layer's LayerNorm and query/key/value rows of those tokens:
  `FastMPT.prefix` computes them once (`TEMPPolicy.reset` does so per problem) and
  `FastMPT.predict` reuses them every step.
* **Last layer, output token only.** Only the output token (torch's position 0) of the last
  layer is read, so that layer computes keys and values for every token but the query,
  attention, output projection and FFN for the output token alone.

Example:
    >>> fast = FastMPT(model.mpt)                               # once: copies the weights
    >>> prefix = fast.prefix(sei, goal, goal_radius, start)     # once per problem
    >>> samples = fast.predict(prefix, path, path_length)  # every call, (chunk, d) float32

The weights are a snapshot: build a new `FastMPT` after changing the model's parameters.

The kernels themselves (`temp_gym.planning.mpt_kernel`) belong to the planning layer, whose
compiled attention loop calls them with `FastMPT.kernel_weights`; this module holds the
model side: copying an `MPT`'s weights into the arrays they read.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from temp_gym.models.mpt import MPT
from temp_gym.planning.mpt_kernel import forward_kernel, prefix_kernel


def _array(tensor: torch.Tensor) -> np.ndarray:
    """A contiguous float32 numpy copy of a tensor (never a view of its memory)."""
    return np.array(tensor.detach().cpu().numpy(), dtype=np.float32, order="C", copy=True)


@dataclass(frozen=True)
class Prefix:
    """The per-problem constants of `FastMPT.predict` (`FastMPT.prefix` builds them).

    Attributes:
        goal: ``(d,)`` the normalized goal (the output token embeds ``goal - x_c``).
        z: ``(S, width)`` the SEI, Goal and Start tokens plus their positions, a row each.
        qkv: ``(S, 3 * width)`` layer 0's queries, keys and values of those tokens.
    """

    goal: np.ndarray
    z: np.ndarray
    qkv: np.ndarray


class FastMPT:
    """An `MPT`'s weights as float32 numpy arrays and its batch-1 forward pass in numba.

    Args:
        mpt: the model; its parameters are copied (a snapshot), so build a new `FastMPT`
            after changing them.
    """

    def __init__(self, mpt: MPT) -> None:
        self.dim = mpt.dim
        self.num_sei_tokens = mpt.num_sei_tokens
        self.max_path_length = mpt.max_path_length
        self.prediction = mpt.prediction
        self.chunk = mpt.chunk
        layers = list(mpt.layers)
        self.num_heads = layers[0].attention.num_heads
        self.width = width = mpt.output_token.shape[-1]

        def stack(get) -> np.ndarray:
            return np.ascontiguousarray(np.stack([_array(get(layer)) for layer in layers]))

        with torch.no_grad():
            position = mpt.position[0]  # (P, width), torch's token order
            self._position = _array(position)
            self._embeddings = tuple(
                _array(tensor)
                for embed in (mpt.embed_sei, mpt.embed_goal, mpt.embed_start)
                for tensor in (embed.weight.T, embed.bias)
            )
            self._prefix_position = np.ascontiguousarray(self._position[1:])
            ln = stack(
                lambda layer: torch.stack(
                    [
                        layer.norm_attention.weight,
                        layer.norm_attention.bias,
                        layer.norm_ffn.weight,
                        layer.norm_ffn.bias,
                    ]
                )
            )
            wqkv = stack(lambda layer: layer.attention.qkv.weight.T)
            bqkv = stack(lambda layer: layer.attention.qkv.bias)
            # The attention's 1/sqrt(head_dim) goes into the queries' weights (exact for
            # head_dim 4, 16, 64, ...: a power of two).
            scale = np.float32(1.0 / math.sqrt(width // self.num_heads))
            wqkv[:, :, :width] *= scale
            bqkv[:, :width] *= scale
            w_split = np.ascontiguousarray(
                wqkv.reshape(len(layers), width, 3, width).transpose(0, 2, 1, 3)
            )
            # The arguments of `forward_kernel` after the per-problem ones, in its order.
            self._weights = (
                _array(mpt.output_token[0, 0] + mpt.embed_current.bias + position[0]),
                _array(mpt.embed_current.weight.T),
                _array(mpt.embed_path.weight.T),
                _array(mpt.path_position + mpt.embed_path.bias),
                ln,
                wqkv,
                bqkv,
                w_split,
                stack(lambda layer: layer.attention.out.weight.T),
                stack(lambda layer: layer.attention.out.bias),
                stack(lambda layer: layer.ffn[0].weight.T),
                stack(lambda layer: layer.ffn[0].bias),
                stack(lambda layer: layer.ffn[2].weight.T),
                stack(lambda layer: layer.ffn[2].bias),
                _array(torch.stack([mpt.norm.weight, mpt.norm.bias])),
                _array(mpt.head.weight.T),
                _array(mpt.head.bias),
                self.num_heads,
                mpt.offset_scale if mpt.prediction == "offset" else 0.0,
            )
        self._ln, self._wqkv, self._bqkv = ln, wqkv, bqkv

    @property
    def kernel_weights(self) -> tuple:
        """The weight arguments of the forward kernel, for compiled callers (read-only use)."""
        return self._weights

    def prefix(
        self, sei: np.ndarray, goal: np.ndarray, goal_radius: float, start: np.ndarray
    ) -> Prefix:
        """The per-problem constants: the SEI, Goal, Start tokens and layer 0's qkv of them.

        Args:
            sei: ``(n, width)`` SEI tokens of the workspace (or ``(1, n, width)``).
            goal: ``(d,)`` normalized goal.
            goal_radius: normalized goal radius.
            start: ``(d,)`` normalized start.
        """
        sei = np.ascontiguousarray(sei, np.float32).reshape(self.num_sei_tokens, self.width)
        goal = np.ascontiguousarray(goal, np.float32).reshape(self.dim)
        start = np.ascontiguousarray(start, np.float32).reshape(self.dim)
        task = np.empty(self.dim + 1, np.float32)
        task[:-1] = goal
        task[-1] = np.asarray(goal_radius, np.float32).reshape(-1)[0]
        z, qkv = prefix_kernel(sei, task, start, self._embeddings, self._prefix_position,
                                self._ln, self._wqkv, self._bqkv)  # fmt: skip
        return Prefix(goal, z, qkv)

    def predict(
        self, prefix: Prefix, path: np.ndarray, path_length: int, out: np.ndarray | None = None
    ) -> np.ndarray:
        """The next samples, float32 ``(chunk, d)`` in [-1, 1]: `MPT.forward` for one sample.

        Args:
            prefix: `prefix` of this problem.
            path: ``(>= path_length, d)`` the path so far (float32 avoids a copy); rows from
                ``path_length`` on are ignored (padding).
            path_length: valid rows of ``path``, 1 .. L.
            out: float32 ``(chunk, d)`` to write the samples to (a fresh array if None).
        """
        path = np.ascontiguousarray(path, np.float32)
        length = int(path_length)
        if path.ndim != 2 or path.shape[1] != self.dim:
            raise ValueError(f"path: expected (L, {self.dim}), got {path.shape}")
        if not 1 <= length <= min(path.shape[0], self.max_path_length):
            raise ValueError(
                f"path_length: expected 1..{min(path.shape[0], self.max_path_length)}, got {length}"
            )
        if out is None:
            out = np.empty((self.chunk, self.dim), np.float32)
        forward_kernel(path, length, prefix.goal, prefix.z, prefix.qkv, *self._weights, out)
        return out

    def forward(
        self,
        sei: np.ndarray,
        goal: np.ndarray,
        goal_radius: float,
        start: np.ndarray,
        path: np.ndarray,
        path_length: int,
    ) -> np.ndarray:
        """`prefix` then `predict`: `MPT.forward` of one sample, ``(chunk, d)``."""
        return self.predict(self.prefix(sei, goal, goal_radius, start), path, path_length)
