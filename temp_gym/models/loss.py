"""`TEMPLoss`: the EISE/MPT training objective (paper, Eq. 1).

``L = λ · L_recons(O, Ô) + η · L_semantic(x, x̂)``

* ``L_recons``: binary cross-entropy between the 0/1 occupancy grid O and the EISE decoder's
  logits (Ô = sigmoid(logits)), averaged over cells, then over the batch's *samples* (each
  sample's workspace grid; when a batch stores each distinct grid once, ``occupancy_index``
  maps samples to grids). Both terms are per-sample means, so the loss of a batch is the
  size-weighted mean of the losses of its parts: what makes data-parallel training equal to
  single-process training (`trainers/bc.py`).
* ``L_semantic``: mean squared error between the expert's next node x and the MPT's sample x̂,
  both normalized to [-1, 1]^d, averaged over samples and dimensions. A chunked MPT
  (`temp_gym.models.mpt.MPT`, ``chunk = k``) is compared with the expert's next k nodes: per
  sample, the mean over the chunk's valid entries (``target_mask``: a path that ends sooner
  has fewer), then over samples, so it stays a per-sample mean; for k = 1 it is the MSE
  above.

λ is ``loss.recons_weight`` and η is ``loss.semantic_weight`` in the config.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn


class TEMPLoss(nn.Module):
    """Weighted sum of the reconstruction and semantic terms.

    Args:
        recons_weight: λ.
        semantic_weight: η.
    """

    def __init__(self, recons_weight: float = 1.0, semantic_weight: float = 1.0) -> None:
        super().__init__()
        self.recons_weight = float(recons_weight)
        self.semantic_weight = float(semantic_weight)

    def forward(
        self,
        recons_logits: torch.Tensor,
        occupancy: torch.Tensor,
        sample: torch.Tensor,
        target: torch.Tensor,
        occupancy_index: torch.Tensor | None = None,
        target_mask: torch.Tensor | None = None,
    ) -> dict[str, torch.Tensor]:
        """Return ``loss`` (the weighted sum), ``recons`` and ``semantic`` (unweighted).

        ``sample`` and ``target`` are ``(B, d)``, or ``(B, k, d)`` for a chunk with
        ``target_mask`` ``(B, k)`` marking the entries to compare (all, when None).
        """
        per_grid = (
            F.binary_cross_entropy_with_logits(recons_logits, occupancy, reduction="none")
            .flatten(1)
            .mean(dim=1)
        )
        recons = (per_grid if occupancy_index is None else per_grid[occupancy_index]).mean()
        if sample.shape != target.shape:
            raise ValueError(
                f"sample, target: shapes {tuple(sample.shape)} and {tuple(target.shape)} differ"
            )
        if sample.dim() == 2:
            semantic = F.mse_loss(sample, target)
        else:
            squared = (sample - target).pow(2).mean(dim=-1)  # (B, k)
            if target_mask is None:
                semantic = squared.mean()
            else:
                mask = target_mask.to(squared.dtype)
                semantic = ((squared * mask).sum(dim=1) / mask.sum(dim=1).clamp(min=1.0)).mean()
        loss = self.recons_weight * recons + self.semantic_weight * semantic
        return {"loss": loss, "recons": recons, "semantic": semantic}
