"""The model, loss, optimizer and optimization step of a config's sections."""

from __future__ import annotations

import torch

from temp_gym.config import Config, ConfigError
from temp_gym.models.loss import TEMPLoss
from temp_gym.models.temp import TEMPModel
from temp_gym.worlds.robots import robot_spec


def make_model(config: Config) -> TEMPModel:
    """`TEMPModel` from the ``model`` section and the env's robot, resolution and L.

    A null ``env.encoding_resolution`` is the robot's own, as in the dataset's settings.
    """
    env = config.env
    resolution = env.encoding_resolution or robot_spec(env.robot).encoding_resolution
    return TEMPModel.from_config(config.model, env.robot, resolution, env.max_path_length)


def make_loss(config: Config) -> TEMPLoss:
    """`TEMPLoss` with λ = ``loss.recons_weight`` and η = ``loss.semantic_weight``."""
    return TEMPLoss(config.loss.recons_weight, config.loss.semantic_weight)


def make_optimizer(
    config: Config, model: torch.nn.Module
) -> tuple[torch.optim.Optimizer, torch.optim.lr_scheduler.ReduceLROnPlateau]:
    """Adam and ReduceLROnPlateau on the validation loss (the paper's schedule)."""
    optim = config.optim
    if len(optim.betas) != 2:
        raise ConfigError(f"optim.betas: expected two numbers, got {optim.betas}")
    optimizer = torch.optim.Adam(
        model.parameters(),
        lr=optim.lr,
        betas=(optim.betas[0], optim.betas[1]),
        eps=optim.eps,
        weight_decay=optim.weight_decay,
    )
    scheduler = torch.optim.lr_scheduler.ReduceLROnPlateau(
        optimizer,
        mode="min",
        factor=optim.lr_factor,
        patience=optim.lr_patience,
        threshold=optim.lr_threshold,
        threshold_mode="rel",
        min_lr=optim.min_lr,
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
