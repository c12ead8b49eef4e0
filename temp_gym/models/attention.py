"""Attention read-out: how much the MPT looks at SEI, Goal, Start and HPD (paper, Eq. 7-8).

`MPT.forward` with ``need_weights=True`` returns every layer's and head's softmax weights,
``(layers, heads, queries, keys)`` for one sample. `group_attention` sums them over the keys
of each token group, for the query of the output token (the one the sample is read from),
after the paper's head average (Eq. 8):

    ω = (1/h) Σ_i softmax(Q_i K_iᵀ / √d_k)

`normalized_group_attention` does this for each step of a plan and applies the per-group
min-max normalization over the steps (Eq. 7):

    ω̂_j^k = (ω_j^k - min Ω^k) / (max Ω^k - min Ω^k)

The output token's attention to itself belongs to no group and is left out.

Examples:
    >>> maps = [policy.last_attention for each step]     # each (layers, heads, T, T)
    >>> weights = normalized_group_attention(maps, num_sei_tokens=8)
    >>> weights["SEI"].shape                             # (steps,)
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

GROUPS = ("SEI", "Goal", "Start", "HPD")
"""Token groups in the order of the sequence (after the output token)."""


def group_slices(num_sei_tokens: int, num_keys: int) -> dict[str, slice]:
    """Key positions of each group in a sequence of ``num_keys`` tokens (see `MPT`)."""
    first_path = num_sei_tokens + 3
    if num_keys <= first_path:
        raise ValueError(f"num_keys: expected more than {first_path} tokens, got {num_keys}")
    return {
        "SEI": slice(1, 1 + num_sei_tokens),
        "Goal": slice(1 + num_sei_tokens, 2 + num_sei_tokens),
        "Start": slice(2 + num_sei_tokens, first_path),
        "HPD": slice(first_path, num_keys),
    }


def group_attention(
    attention: torch.Tensor | np.ndarray,
    num_sei_tokens: int,
    layer: int | str = -1,
    query: int = 0,
) -> dict[str, float]:
    """Head-averaged attention mass of one query on each token group, for one step.

    Args:
        attention: ``(layers, heads, queries, keys)`` weights of one sample.
        num_sei_tokens: SEI tokens in the sequence.
        layer: which layer (an index; -1 is the last) or ``"mean"`` over layers.
        query: the query position; 0 is the output token.

    Returns:
        ``{group: ω}`` for ``GROUPS``; the values sum to at most 1 (the rest is on the
        output token itself).
    """
    weights = torch.as_tensor(
        np.asarray(attention) if not torch.is_tensor(attention) else attention
    )
    if weights.ndim != 4:
        raise ValueError(f"attention: expected (layers, heads, queries, keys), got {weights.shape}")
    weights = weights.double()
    if layer == "mean":
        per_head = weights.mean(dim=0)
    elif isinstance(layer, int):
        per_head = weights[layer]
    else:
        raise ValueError(f"layer: expected an int or 'mean', got {layer!r}")
    omega = per_head.mean(dim=0)[query]  # Eq. 8: average over heads; then one query's row
    slices = group_slices(num_sei_tokens, omega.shape[-1])
    return {group: float(omega[part].sum()) for group, part in slices.items()}


def normalized_group_attention(
    attentions: Sequence[torch.Tensor | np.ndarray],
    num_sei_tokens: int,
    layer: int | str = -1,
    query: int = 0,
) -> dict[str, np.ndarray]:
    """Per-group attention along a plan, min-max normalized per group over the steps (Eq. 7).

    Args:
        attentions: one ``(layers, heads, queries, keys)`` map per step; the key count may
            change from step to step (the path grows).
        num_sei_tokens: SEI tokens in the sequence.
        layer: as in `group_attention`.
        query: as in `group_attention`.

    Returns:
        ``{group: array (steps,)}`` in [0, 1]; a group whose weight never changes maps to 0.
        The raw ω values are under ``"raw_" + group``.
    """
    if len(attentions) == 0:
        raise ValueError("attentions: need at least one step")
    rows = [group_attention(step, num_sei_tokens, layer, query) for step in attentions]
    result: dict[str, np.ndarray] = {}
    for group in GROUPS:
        raw = np.array([row[group] for row in rows])
        span = raw.max() - raw.min()
        result[group] = (raw - raw.min()) / span if span > 0 else np.zeros_like(raw)
        result["raw_" + group] = raw
    return result


def attention_figure(normalized: dict[str, np.ndarray], title: str = "attention per group"):
    """A matplotlib `Figure` heatmap: groups (rows) by plan steps (columns)."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(6, 2.4))
    axes = figure.add_subplot()
    image = np.stack([normalized[group] for group in GROUPS])
    artist = axes.imshow(image, aspect="auto", cmap="viridis", vmin=0.0, vmax=1.0)
    axes.set_yticks(range(len(GROUPS)), GROUPS)
    axes.set_xlabel("sampling step")
    axes.set_title(title)
    figure.colorbar(artist, ax=axes)
    figure.tight_layout()
    return figure
