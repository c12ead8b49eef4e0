"""The model, loss, optimizer and optimization step of a config's sections."""

from __future__ import annotations

from typing import Any

import torch

from temp_gym.models.loss import TEMPLoss
from temp_gym.models.temp import TEMPModel


def make_model(config: dict[str, Any]) -> TEMPModel:
    """`TEMPModel` from the ``model`` section and the env's robot, resolution and L."""
    env = config["env"]
    return TEMPModel.from_config(
        config.get("model"), env["robot"], env["encoding_resolution"], env["max_path_length"]
    )


def make_loss(config: dict[str, Any]) -> TEMPLoss:
    """`TEMPLoss` with λ = ``loss.recons_weight`` and η = ``loss.semantic_weight``."""
    loss = config.get("loss", {})
    return TEMPLoss(loss.get("recons_weight", 1.0), loss.get("semantic_weight", 1.0))


def make_optimizer(
    config: dict[str, Any], model: torch.nn.Module
) -> tuple[torch.optim.Optimizer, torch.optim.lr_scheduler.ReduceLROnPlateau]:
    """Adam and ReduceLROnPlateau on the validation loss (the paper's schedule)."""
    optim = config.get("optim", {})
    optimizer = torch.optim.Adam(
        model.parameters(),
        lr=float(optim.get("lr", 1e-3)),
        betas=tuple(float(beta) for beta in optim.get("betas", (0.9, 0.999))),
        eps=float(optim.get("eps", 1e-8)),
        weight_decay=float(optim.get("weight_decay", 0.0)),
    )
    scheduler = torch.optim.lr_scheduler.ReduceLROnPlateau(
        optimizer,
        mode="min",
        factor=float(optim.get("lr_factor", 0.1)),
        patience=int(optim.get("lr_patience", 10)),
        threshold=float(optim.get("lr_threshold", 0.1)),
        threshold_mode="rel",
        min_lr=float(optim.get("min_lr", 1e-6)),
    )
    return optimizer, scheduler


def model_step(
    model: TEMPModel, loss_module: TEMPLoss, batch: dict[str, torch.Tensor]
) -> dict[str, torch.Tensor]:
    """Forward pass and loss terms for one batch."""
    out = model(batch)
    if "targets" in batch:  # the expert's next nodes, as many as the MPT's chunk
        return loss_module(
            out["recons_logits"],
            batch["occupancy"],
            out["samples"],
            batch["targets"],
            batch.get("occupancy_index"),
            batch["target_mask"],
        )
    return loss_module(
        out["recons_logits"],
        batch["occupancy"],
        out["sample"],
        batch["target"],
        batch.get("occupancy_index"),
    )
