"""Training logs: TensorBoard (or none) through `Logger`, tag descriptions, chart layout."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from temp_gym.config import Config
from temp_gym.config.checks import CHOICES
from temp_gym.tensorboard_summaries import add_hparams, add_scalar

_VAL_RECONS = (
    "EISE reconstruction (BCE of the occupancy grid) on validation workspaces, which training "
    "never saw. It may rise while everything else improves: with few training workspaces the "
    "encoder learns to reconstruct those grids, not unseen ones. That is not divergence: "
    "planning needs SEI tokens that help the MPT, not a faithful picture (see val/semantic "
    "and eval/*)."
)
TAG_DESCRIPTIONS = {
    "train/loss": "Training loss L = recons_weight * L_recons + semantic_weight * L_semantic, "
    "mean over the epoch's batches. Step: epochs completed.",
    "train/recons": "EISE reconstruction term (BCE of the occupancy grid) on training "
    "workspaces, epoch mean.",
    "train/semantic": "MPT next-node term (MSE between the predicted and the expert's next "
    "node, normalized units) on training samples, epoch mean.",
    "train/grad_norm": "Gradient norm before clipping (optim.grad_clip), epoch mean.",
    "train/lr": "Learning rate after the epoch's ReduceLROnPlateau step; training stops at "
    "optim.min_lr.",
    "val/loss": "Validation loss on unseen workspaces. It can rise while planning improves, "
    "because its reconstruction term does (val/recons). The lr schedule and best.pt follow "
    "train.monitor; the main job monitors val/semantic.",
    "val/recons": _VAL_RECONS,
    "val/semantic": "MPT next-node error on validation workspaces: whether the policy "
    "generalizes to unseen workspaces. Lower is better; the main job picks best.pt on it.",
    "eval/success": "TEMP planning during training: share of train_eval.periodic_tasks "
    "held-out test tasks solved within train_eval.max_nodes, every train_eval.every epochs.",
    "eval/nodes": "TEMP planning during training: mean nodes to the first solution on the "
    "held-out tasks (a failure counts as the whole budget).",
    "eval/cost": "TEMP planning during training: mean path cost over the solved held-out tasks.",
    "time/epoch": "Wall seconds of the epoch's training batches (validation excluded).",
    "time/samples_per_s": "Training samples per wall second in the epoch.",
}
"""What each TensorBoard tag of `trainers/bc.py` means; shown with its chart."""
FINAL_DESCRIPTION = (
    "The final comparison: TEMP (best.pt) against RRT* on train_eval.tasks held-out tasks, "
    "each up to its first solution (a failure counts as the budget in the node figures)."
)
LAYOUT = {
    "training: train vs. validation": {
        "loss (validation rises with its reconstruction term: see the chart below)": [
            "Multiline",
            ["train/loss", "val/loss"],
        ],
        "EISE reconstruction (does not generalize to unseen workspaces; not divergence)": [
            "Multiline",
            ["train/recons", "val/recons"],
        ],
        "MPT next node (what planning needs; the main job picks best.pt on val)": [
            "Multiline",
            ["train/semantic", "val/semantic"],
        ],
    },
    "planning during training (held-out tasks)": {
        name: ["Multiline", [f"eval/{name}"]] for name in ("success", "nodes", "cost")
    },
}
"""The custom-scalars dashboard: each loss term's training and validation curves on one
chart, titled with how to read them."""
HPARAM_METRICS = ("val/loss", "val/semantic", "val/recons", "eval/success", "eval/nodes")
"""Tags the HParams dashboard shows beside each run's configuration."""


def describe_tag(tag: str) -> str | None:
    """The dashboard description of a trainer tag (`TAG_DESCRIPTIONS`), or None."""
    if tag.startswith("eval/final/"):
        return FINAL_DESCRIPTION
    return TAG_DESCRIPTIONS.get(tag)


LOGGER_BACKENDS = CHOICES["logger.backend"]
"""``logger.backend``: TensorBoard, or none ("")."""


def check_logger_backend(backend: str) -> None:
    """Refuse a ``logger.backend`` other than `LOGGER_BACKENDS`, naming the key."""
    if backend not in LOGGER_BACKENDS:
        raise ValueError(f"logger.backend: expected 'tensorboard' or '', got {backend!r}")


class Logger:
    """TensorBoard writer behind a small interface; ``backend=""`` makes every call a no-op.

    Each tag's first scalar carries its description (`describe_tag`), so the dashboard
    explains its charts.
    """

    def __init__(self, backend: str, log_dir: Path, purge_step: int | None = None) -> None:
        check_logger_backend(backend)
        self.writer = None
        if backend == "tensorboard":
            from torch.utils.tensorboard import SummaryWriter

            # TensorBoard drops the folder's earlier events at steps >= purge_step.
            self.writer = SummaryWriter(log_dir=str(log_dir), purge_step=purge_step)
        self.log_dir = log_dir
        self._described: set[str] = set()

    def scalars(self, values: dict[str, float], step: int) -> None:
        """Write each ``tag: value`` (non-finite values are skipped: they do not plot)."""
        if self.writer is not None:
            for tag, value in values.items():
                if math.isfinite(float(value)):
                    new = tag not in self._described
                    add_scalar(self.writer, tag, value, step, describe_tag(tag) if new else None)
                    self._described.add(tag)

    def figure(self, tag: str, figure: Any, step: int) -> None:
        """Write a matplotlib figure."""
        if self.writer is not None:
            self.writer.add_figure(tag, figure, step)

    def image(self, tag: str, image: np.ndarray, step: int) -> None:
        """Write an ``(H, W, 3)`` uint8 image."""
        if self.writer is not None:
            self.writer.add_image(tag, image, step, dataformats="HWC")

    def hparams(self, config: Config) -> None:
        """The config in the HParams dashboard and the custom-scalars layout (`LAYOUT`)."""
        if self.writer is not None:
            add_hparams(self.writer, config.to_dict(), HPARAM_METRICS)
            self.writer.add_custom_scalars(LAYOUT)

    def close(self) -> None:
        """Flush and close."""
        if self.writer is not None:
            self.writer.close()


def make_logger(config: Config, run_dir: Path, purge_step: int | None = None) -> Logger:
    """`Logger` for ``logger.backend`` writing into the run directory.

    ``purge_step``: TensorBoard hides the events written there before at this step and later
    (a resumed run passes the first step it writes again; a new run 0). TensorBoard reads the
    first such mark in a folder as a start, later ones as restarts: only a run that began
    with one is purged on a rerun.
    """
    return Logger(config.logger.backend, run_dir, purge_step)
