"""`TEMPModel`: EISE and MPT trained together, its config, and its checkpoint format.

Model sizes come from the config's ``model`` section (`MODEL_DEFAULTS` lists every key); the
robot, the occupancy resolution and L come from the ``env`` section.

A checkpoint is a plain dict that ``torch.load(path, weights_only=True)`` reads:

| key | value |
|---|---|
| ``version`` | `CHECKPOINT_VERSION` |
| ``state_dict`` | the `TEMPModel`'s tensors |
| ``model_config`` | the ``model`` section (plain python) |
| ``robot``, ``dim`` | the robot it was trained for and its configuration-space dimension |
| ``encoding_resolution`` | cells per workspace axis of the occupancy grid |
| ``max_path_length`` | L, the most HPD tokens |

Trainer checkpoints (``last.pt``) add ``optimizer``, ``scheduler``, ``epoch`` and the RNG
state; `load_checkpoint` reads both kinds.

Example:
    >>> model = TEMPModel.from_config({"num_layers": 2}, robot="point2d",
    ...                               encoding_resolution=32, max_path_length=64)
    >>> out = model(batch)            # batch: a dict of tensors named like the observation
    >>> out["samples"].shape, out["recons_logits"].shape
    (torch.Size([B, 1, 2]), torch.Size([B, 32, 32]))
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import torch
from torch import nn

from temp_gym.models.eise import EISE
from temp_gym.models.mpt import MPT
from temp_gym.problem import ROBOTS

CHECKPOINT_VERSION = 1

MODEL_DEFAULTS: dict[str, Any] = {
    "token_dim": 64,
    "num_heads": 4,
    "num_layers": 3,
    "ffn_dim": 128,
    "num_sei_tokens": 8,
    "eise_hidden": 256,
    "dropout": 0.0,
    "prediction": "offset",
    "offset_scale": 0.5,
    "chunk": 1,
}
"""Every ``model`` config key and its default."""


class TEMPModel(nn.Module):
    """EISE + MPT: occupancy, task and path so far -> the next sample and Ô's logits.

    Args:
        robot: ``point2d``, ``point3d`` or ``kuka_iiwa14``.
        encoding_resolution: cells per workspace axis of the occupancy grid.
        max_path_length: L.
        **model_config: the ``model`` section; missing keys take `MODEL_DEFAULTS`.
    """

    def __init__(
        self, robot: str, encoding_resolution: int, max_path_length: int, **model_config: Any
    ) -> None:
        super().__init__()
        if robot not in ROBOTS:
            raise ValueError(f"robot: unknown robot {robot!r}; expected one of {list(ROBOTS)}")
        unknown = set(model_config) - set(MODEL_DEFAULTS)
        if unknown:
            raise ValueError(f"model: unknown keys {sorted(unknown)}")
        config = {**MODEL_DEFAULTS, **model_config}
        self.robot = robot
        self.dim, workspace_dim = ROBOTS[robot]
        self.encoding_resolution = int(encoding_resolution)
        self.max_path_length = int(max_path_length)
        self.config = config
        self.eise = EISE(
            (self.encoding_resolution,) * workspace_dim,
            config["eise_hidden"],
            config["num_sei_tokens"],
            config["token_dim"],
        )
        self.mpt = MPT(
            self.dim,
            config["token_dim"],
            config["num_heads"],
            config["num_layers"],
            config["ffn_dim"],
            config["num_sei_tokens"],
            self.max_path_length,
            config["dropout"],
            config["prediction"],
            config["offset_scale"],
            config["chunk"],
        )

    @classmethod
    def from_config(
        cls,
        model_config: dict[str, Any] | None,
        robot: str,
        encoding_resolution: int,
        max_path_length: int,
    ) -> TEMPModel:
        """Build from the ``model`` section and the env's robot, resolution and L."""
        return cls(robot, encoding_resolution, max_path_length, **(model_config or {}))

    def forward(
        self, batch: dict[str, torch.Tensor], need_weights: bool = False
    ) -> dict[str, torch.Tensor]:
        """Run EISE and MPT on a batch named like the observation.

        Keys read: ``occupancy`` ``(B, *grid)``, ``start``, ``goal``, ``goal_radius``,
        ``path``, ``path_length``. Returns ``samples`` ``(B, chunk, d)`` (the MPT's chunk),
        ``sample`` ``(B, d)`` (its first row: the next node), ``recons_logits`` (shaped like
        ``occupancy``) and, with ``need_weights``, ``attention`` (see `MPT.forward`).

        With ``occupancy_index`` ``(B,)`` in the batch, ``occupancy`` holds only the distinct
        grids ``(W, *grid)`` and sample i uses grid ``occupancy_index[i]``: the EISE runs once
        per workspace of the batch, not once per sample.
        """
        sei = self.eise(batch["occupancy"])
        sample_sei = sei if "occupancy_index" not in batch else sei[batch["occupancy_index"]]
        samples, weights = self.mpt(
            sample_sei,
            batch["goal"],
            batch["goal_radius"],
            batch["start"],
            batch["path"],
            batch["path_length"],
            need_weights=need_weights,
        )
        out = {
            "sample": samples[:, 0],
            "samples": samples,
            "recons_logits": self.eise.decode(sei),
        }
        if need_weights:
            out["attention"] = weights
        return out

    def checkpoint(self, **extra: Any) -> dict[str, Any]:
        """The checkpoint dict (see the module docstring); ``extra`` entries are added."""
        return {
            "version": CHECKPOINT_VERSION,
            "state_dict": {key: value.detach().cpu() for key, value in self.state_dict().items()},
            "model_config": dict(self.config),
            "robot": self.robot,
            "dim": self.dim,
            "encoding_resolution": self.encoding_resolution,
            "max_path_length": self.max_path_length,
            **extra,
        }

    def save(self, path: str | Path, **extra: Any) -> None:
        """Write `checkpoint` to ``path`` (atomically: a killed save leaves the old file)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.with_suffix(path.suffix + ".partial")
        torch.save(self.checkpoint(**extra), partial)
        partial.replace(path)

    def num_parameters(self, part: str | None = None) -> int:
        """Parameters of the whole model, or of ``part`` (``eise`` or ``mpt``)."""
        module = self if part is None else getattr(self, part)
        return sum(parameter.numel() for parameter in module.parameters())


def weights_digest(state_dict: dict[str, torch.Tensor]) -> str:
    """SHA-256 of a state dict (names, shapes, bytes): ties reported figures to their weights."""
    digest = hashlib.sha256()
    for name in sorted(state_dict):
        tensor = state_dict[name].detach().cpu().contiguous()
        digest.update(name.encode())
        digest.update(str(tuple(tensor.shape)).encode())
        digest.update(tensor.numpy().tobytes())
    return digest.hexdigest()


def load_checkpoint(
    path: str | Path,
    robot: str | None = None,
    dim: int | None = None,
    map_location: str | torch.device = "cpu",
) -> tuple[TEMPModel, dict[str, Any]]:
    """Load a checkpoint with ``weights_only=True``; return the model and the raw dict.

    Raises:
        ValueError: the file is not a TEMP checkpoint, has an unknown version, or was trained
            for another ``robot`` or dimension ``dim`` than the ones asked for.
    """
    checkpoint = torch.load(path, map_location=map_location, weights_only=True)
    if not isinstance(checkpoint, dict) or "state_dict" not in checkpoint:
        raise ValueError(f"{path}: not a TEMP checkpoint (no state_dict)")
    if checkpoint.get("version") != CHECKPOINT_VERSION:
        raise ValueError(
            f"{path}: checkpoint version {checkpoint.get('version')!r}, expected "
            f"{CHECKPOINT_VERSION}"
        )
    check_compatible(checkpoint["robot"], checkpoint["dim"], robot, dim, source=str(path))
    model = TEMPModel.from_config(
        checkpoint["model_config"],
        checkpoint["robot"],
        checkpoint["encoding_resolution"],
        checkpoint["max_path_length"],
    )
    model.load_state_dict(checkpoint["state_dict"])
    return model, checkpoint


def check_compatible(
    trained_robot: str,
    trained_dim: int,
    robot: str | None,
    dim: int | None,
    source: str = "the model",
) -> None:
    """Raise a clear `ValueError` when a model for one robot is used for another."""
    if dim is not None and int(dim) != int(trained_dim):
        raise ValueError(
            f"{source} was trained for {trained_robot} (d={trained_dim}) and cannot plan in "
            f"d={dim}" + (f" ({robot})" if robot else "")
        )
    if robot is not None and robot != trained_robot:
        raise ValueError(
            f"{source} was trained for robot {trained_robot!r} (d={trained_dim}), not {robot!r}"
        )
