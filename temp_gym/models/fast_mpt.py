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

Examples:
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
from typing import TYPE_CHECKING

import numpy as np

from temp_gym.models.array_backed import ArrayBacked
from temp_gym.planning.mpt_kernel import forward_kernel, prefix_kernel, task_prefix_kernel

if TYPE_CHECKING:  # PyTorch is imported only to take a snapshot of a model (`mpt_arrays`)
    from temp_gym.models.mpt import MPT


def _array(tensor) -> np.ndarray:
    """A contiguous float32 numpy copy of a tensor (never a view of its memory)."""
    return np.array(tensor.detach().cpu().numpy(), dtype=np.float32, order="C", copy=True)


WEIGHT_NAMES = (
    "output_token", "embed_current", "embed_path", "path_position", "ln", "wqkv", "bqkv",
    "w_split", "out_w", "out_b", "ffn_in_w", "ffn_in_b", "ffn_out_w", "ffn_out_b", "norm",
    "head_w", "head_b",
)  # fmt: skip
"""The weight arguments of `forward_kernel` after the per-problem ones, in its order."""

EMBEDDING_NAMES = ("sei_w", "sei_b", "goal_w", "goal_b", "start_w", "start_b")
"""The SEI, Goal and Start embeddings (weight transposed, bias), in `prefix_kernel`'s order."""

SIZE_NAMES = ("dim", "num_sei_tokens", "max_path_length", "chunk", "num_heads")
"""The integer sizes a snapshot stores beside its arrays."""


def mpt_arrays(mpt: MPT) -> dict[str, np.ndarray]:
    """An `MPT`'s batch-1 inference snapshot: named float32 arrays and 0-d sizes (a copy).

    What `FastMPT.from_arrays` reads: the kernels' weights with the attention's
    1/sqrt(head_dim) folded into the queries, the token positions, the embeddings, the sizes
    (`SIZE_NAMES`), ``prediction`` and ``offset_scale``. Plain numpy, so it can be stored
    beside a checkpoint and read back without PyTorch (`temp_gym.models.snapshot`).
    """
    import torch  # the only place a FastMPT needs PyTorch: reading the model's parameters

    layers = list(mpt.layers)
    num_heads = layers[0].attention.num_heads
    width = mpt.output_token.shape[-1]

    def stack(get) -> np.ndarray:
        return np.ascontiguousarray(np.stack([_array(get(layer)) for layer in layers]))

    with torch.no_grad():
        position = mpt.position[0]  # (P, width), torch's token order
        embeddings = [
            _array(tensor)
            for embed in (mpt.embed_sei, mpt.embed_goal, mpt.embed_start)
            for tensor in (embed.weight.T, embed.bias)
        ]
        wqkv = stack(lambda layer: layer.attention.qkv.weight.T)
        bqkv = stack(lambda layer: layer.attention.qkv.bias)
        # The attention's 1/sqrt(head_dim) goes into the queries' weights (exact for
        # head_dim 4, 16, 64, ...: a power of two).
        scale = np.float32(1.0 / math.sqrt(width // num_heads))
        wqkv[:, :, :width] *= scale
        bqkv[:, :width] *= scale
        weights = [
            _array(mpt.output_token[0, 0] + mpt.embed_current.bias + position[0]),
            _array(mpt.embed_current.weight.T),
            _array(mpt.embed_path.weight.T),
            _array(mpt.path_position + mpt.embed_path.bias),
            stack(
                lambda layer: torch.stack(
                    [
                        layer.norm_attention.weight,
                        layer.norm_attention.bias,
                        layer.norm_ffn.weight,
                        layer.norm_ffn.bias,
                    ]
                )
            ),
            wqkv,
            bqkv,
            _split_heads(wqkv),
            stack(lambda layer: layer.attention.out.weight.T),
            stack(lambda layer: layer.attention.out.bias),
            stack(lambda layer: layer.ffn[0].weight.T),
            stack(lambda layer: layer.ffn[0].bias),
            stack(lambda layer: layer.ffn[2].weight.T),
            stack(lambda layer: layer.ffn[2].bias),
            _array(torch.stack([mpt.norm.weight, mpt.norm.bias])),
            _array(mpt.head.weight.T),
            _array(mpt.head.bias),
        ]
        arrays = {"position": _array(position)}
    arrays.update(zip(EMBEDDING_NAMES, embeddings, strict=True))
    arrays.update(zip(WEIGHT_NAMES, weights, strict=True))
    sizes = (mpt.dim, mpt.num_sei_tokens, mpt.max_path_length, mpt.chunk, num_heads)
    arrays.update((name, np.array(int(size))) for name, size in zip(SIZE_NAMES, sizes))
    arrays["prediction"] = np.array(str(mpt.prediction))
    arrays["offset_scale"] = np.array(float(mpt.offset_scale), np.float64)
    return arrays


def _split_heads(wqkv: np.ndarray) -> np.ndarray:
    """``(M, w, 3w)`` -> ``(M, 3, w, w)``: the query, key and value weights apart."""
    layers, width = wqkv.shape[0], wqkv.shape[1]
    return np.ascontiguousarray(wqkv.reshape(layers, width, 3, width).transpose(0, 2, 1, 3))


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


class FastMPT(ArrayBacked):
    """An `MPT`'s weights as float32 numpy arrays and its batch-1 forward pass in numba.

    Args:
        mpt: the model; its parameters are copied (a snapshot), so build a new `FastMPT`
            after changing them. `from_arrays` builds one from a stored snapshot instead
            (`mpt_arrays`' dict), without PyTorch.
    """

    NAMES = ("position", *EMBEDDING_NAMES, *WEIGHT_NAMES, *SIZE_NAMES, "prediction",
             "offset_scale")  # fmt: skip
    KIND = "MPT snapshot"

    def __init__(self, mpt: MPT) -> None:
        self._set(mpt_arrays(mpt))

    def _load(self, arrays: dict[str, np.ndarray]) -> None:
        self.dim, self.num_sei_tokens, self.max_path_length, self.chunk, self.num_heads = (
            int(arrays[name]) for name in SIZE_NAMES
        )
        self.prediction = str(arrays["prediction"])
        self.width = width = int(arrays["output_token"].shape[-1])
        if arrays["wqkv"].shape[1:] != (width, 3 * width) or arrays["head_w"].shape != (
            width, self.chunk * self.dim,
        ):  # fmt: skip
            raise ValueError(
                f"MPT snapshot: weights of shapes wqkv {arrays['wqkv'].shape}, head_w "
                f"{arrays['head_w'].shape} do not fit width {width}, chunk {self.chunk} and "
                f"d = {self.dim}"
            )
        self._embeddings = tuple(arrays[name] for name in EMBEDDING_NAMES)
        self._prefix_position = np.ascontiguousarray(arrays["position"][1:])
        offset_scale = float(arrays["offset_scale"]) if self.prediction == "offset" else 0.0
        self._weights = (*(arrays[name] for name in WEIGHT_NAMES), self.num_heads, offset_scale)
        self._ln, self._wqkv, self._bqkv = arrays["ln"], arrays["wqkv"], arrays["bqkv"]

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

    def task_prefix(
        self,
        sei: np.ndarray,
        start: np.ndarray,
        goal: np.ndarray,
        bounds: np.ndarray,
        ratio: float,
    ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray], Prefix]:
        """A problem's task as the model reads it and its `prefix`, from world units.

        Args:
            sei: ``(n, width)`` float32 SEI tokens of the workspace.
            start: ``(d,)`` world state.
            goal: ``(d,)`` world state.
            bounds: ``(2, d)`` the configuration bounds the model normalizes by.
            ratio: the goal radius ratio (`temp_gym.worlds.normalization.goal_radius_ratio`).

        Returns:
            ``(goal, ratio, start)`` float32 (normalized; ``(d,)``, ``(1,)``, ``(d,)``), and
            the `Prefix` that `prefix` makes of them: the same arrays, in one compiled call.
        """
        goal32, ratio32, start32, z, qkv = task_prefix_kernel(
            np.ascontiguousarray(sei, np.float32).reshape(self.num_sei_tokens, self.width),
            np.ascontiguousarray(start, np.float64).reshape(self.dim),
            np.ascontiguousarray(goal, np.float64).reshape(self.dim),
            np.ascontiguousarray(bounds, np.float64).reshape(2, self.dim),
            float(ratio), self._embeddings, self._prefix_position, self._ln, self._wqkv,
            self._bqkv,
        )  # fmt: skip
        return (goal32, ratio32, start32), Prefix(goal32, z, qkv)

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
