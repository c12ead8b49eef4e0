"""`TEMPModel`: EISE and MPT trained together, its config, and its checkpoint format.

Model sizes come from the config's ``model`` section (`temp_gym.config.ModelConfig`: every key,
its default and meaning); the robot, the occupancy resolution and L come from the ``env``
section.

A checkpoint is a plain dict that ``torch.load(path, weights_only=True)`` reads:

| key | value |
|---|---|
| ``version`` | `CHECKPOINT_VERSION` |
| ``state_dict`` | the `TEMPModel`'s tensors |
| ``model_config`` | the ``model`` section (plain python: a `ModelConfig` as a dict) |
| ``robot``, ``dim`` | the robot it was trained for and its configuration-space dimension |
| ``encoding_resolution`` | cells per workspace axis of the occupancy grid |
| ``max_path_length`` | L, the most HPD tokens |

Trainer checkpoints (``last.pt``) add ``optimizer``, ``scheduler``, ``epoch`` and the RNG
state; `load_checkpoint` reads both kinds.

Examples:
    >>> model = TEMPModel.from_config({"num_layers": 2}, robot="point2d",
    ...                               encoding_resolution=32, max_path_length=64)
    >>> out = model(batch)            # batch: a dict of tensors named like the observation
    >>> out["samples"].shape, out["recons_logits"].shape
    (torch.Size([B, 1, 2]), torch.Size([B, 32, 32]))
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import math
import pickle
import warnings
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch
from torch import nn

from temp_gym.config import ModelConfig
from temp_gym.config.checks import check_section
from temp_gym.config.typed import build
from temp_gym.files import atomic_write
from temp_gym.jobs import brief
from temp_gym.limits import (
    MAX_MODEL_PARAMETERS,
    MAX_PATH_LENGTH,
    MAX_WEIGHT_MAGNITUDE,
)
from temp_gym.models.checkpoint_file import (  # noqa: F401  (CheckpointError re-exported)
    NOT_A_CHECKPOINT,
    CheckpointError,
    read_checkpoint_bytes,
)
from temp_gym.models.checkpoint_settings import check_carried
from temp_gym.models.eise import EISE
from temp_gym.models.mpt import MPT
from temp_gym.planning.policy import check_compatible  # noqa: F401  (re-exported)
from temp_gym.problem import robot_names
from temp_gym.worlds.encoding import check_resolution
from temp_gym.worlds.robots import robot_spec

CHECKPOINT_VERSION = 1


def model_config_of(model_config: ModelConfig | Mapping[str, Any] | None) -> ModelConfig:
    """A `ModelConfig` from a ``model`` section or a checkpoint's ``model_config`` dict.

    A checkpoint written before a key existed lacks it, and gets its default (the value the
    model was built with then).

    Raises:
        ValueError: an unknown key or a wrong type (a `temp_gym.config.ConfigError`).
    """
    if isinstance(model_config, ModelConfig):
        return model_config
    return build(ModelConfig, model_config, "model")


class TEMPModel(nn.Module):
    """EISE + MPT: occupancy, task and path so far -> the next sample and Ô's logits.

    Args:
        robot: a registered robot's name (`temp_gym.worlds.robots`).
        encoding_resolution: cells per workspace axis of the occupancy grid.
        max_path_length: L.
        **model_config: the ``model`` section's keys; missing ones take the defaults of
            `temp_gym.config.ModelConfig`.
    """

    def __init__(
        self, robot: str, encoding_resolution: int, max_path_length: int, **model_config: Any
    ) -> None:
        super().__init__()
        spec = robot_spec(robot)
        sizes = model_config_of(model_config)
        config = dataclasses.asdict(sizes)
        self.robot = robot
        self.dim, workspace_dim = spec.dim, spec.workspace_dim
        self.encoding_resolution = int(encoding_resolution)
        self.max_path_length = int(max_path_length)
        self.config = config
        self.eise = EISE(
            (self.encoding_resolution,) * workspace_dim,
            sizes.eise_hidden,
            sizes.num_sei_tokens,
            sizes.token_dim,
        )
        self.mpt = MPT(
            self.dim,
            sizes.token_dim,
            sizes.num_heads,
            sizes.num_layers,
            sizes.ffn_dim,
            sizes.num_sei_tokens,
            self.max_path_length,
            sizes.dropout,
            sizes.prediction,
            sizes.offset_scale,
            sizes.chunk,
        )

    @classmethod
    def from_config(
        cls,
        model_config: ModelConfig | Mapping[str, Any] | None,
        robot: str,
        encoding_resolution: int,
        max_path_length: int,
    ) -> TEMPModel:
        """Build from a ``model`` section (or checkpoint dict), the robot, resolution and L.

        The sizes are checked first (`weight_shapes`), so a config that asks for more than
        `temp_gym.limits` supports is refused before anything is allocated.

        Raises:
            ValueError: a size out of bounds, or too many weights in all (naming which).
        """
        sizes = dataclasses.asdict(model_config_of(model_config))
        weight_shapes(sizes, robot, encoding_resolution, max_path_length)
        return cls(robot, encoding_resolution, max_path_length, **sizes)

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
        with atomic_write(path) as handle:  # fsynced before the rename
            torch.save(self.checkpoint(**extra), handle)

    def num_parameters(self, part: str | None = None) -> int:
        """Parameters of the whole model, or of ``part`` (``eise`` or ``mpt``)."""
        module = self if part is None else getattr(self, part)
        return sum(parameter.numel() for parameter in module.parameters())


def weight_shapes(
    model_config: ModelConfig | Mapping[str, Any] | None,
    robot: str,
    encoding_resolution: int,
    max_path_length: int,
) -> dict[str, tuple[int, ...]]:
    """The shape of every weight of the model these sizes make, without allocating it.

    Each size is checked against `temp_gym.limits` (the ``model`` section's bounds, the
    occupancy grid's cells, L), then the model is built on PyTorch's ``meta`` device, which
    holds shapes and no data, and its weights are counted.

    Raises:
        ValueError: a size out of bounds, or more than `MAX_MODEL_PARAMETERS` weights.
    """
    sizes = model_config_of(model_config)
    check_section(sizes, "model")
    spec = robot_spec(robot)
    check_resolution(encoding_resolution, spec.workspace_dim, "encoding_resolution")
    if isinstance(max_path_length, bool) or not 1 <= int(max_path_length) <= MAX_PATH_LENGTH:
        raise ValueError(f"max_path_length: expected 1..{MAX_PATH_LENGTH}, got {max_path_length}")
    if sizes.token_dim % sizes.num_heads:
        raise ValueError(
            f"model.token_dim: {sizes.token_dim} is not a multiple of model.num_heads "
            f"({sizes.num_heads})"
        )
    with torch.device("meta"):
        model = TEMPModel(
            robot, int(encoding_resolution), int(max_path_length), **dataclasses.asdict(sizes)
        )
    shapes = {name: tuple(tensor.shape) for name, tensor in model.state_dict().items()}
    count = sum(math.prod(shape) for shape in shapes.values())
    if count > MAX_MODEL_PARAMETERS:
        raise ValueError(
            f"model: {count:,} weights, at most {MAX_MODEL_PARAMETERS:,} are supported "
            "(temp_gym.limits); make token_dim, ffn_dim, eise_hidden, num_layers or "
            "encoding_resolution smaller"
        )
    return shapes


def weights_digest(state_dict: dict[str, torch.Tensor]) -> str:
    """SHA-256 of a state dict (names, shapes, bytes): ties reported figures to their weights."""
    digest = hashlib.sha256()
    for name in sorted(state_dict):
        tensor = state_dict[name].detach().cpu().contiguous()
        digest.update(name.encode())
        digest.update(str(tuple(tensor.shape)).encode())
        digest.update(tensor.numpy().tobytes())
    return digest.hexdigest()


def _failed_member(source: io.BytesIO) -> str | None:
    """The first member of a zip checkpoint whose bytes fail their CRC-32, else None.

    PyTorch's reader does not check the CRCs its zip files store, so a flipped bit in a
    weight would load as another policy. A file that is no zip is left to `torch.load`.
    """
    try:
        with zipfile.ZipFile(source) as archive:
            return archive.testzip()
    except (zipfile.BadZipFile, OSError, EOFError, ValueError):
        return None
    finally:
        source.seek(0)


def _read_checkpoint(path: str | Path, map_location, data: bytes | None = None) -> dict[str, Any]:
    """``torch.load(..., weights_only=True)``; every failure becomes a `CheckpointError`."""
    source = io.BytesIO(read_checkpoint_bytes(path) if data is None else data)
    damaged = _failed_member(source)
    if damaged is not None:
        raise CheckpointError(path, f"damaged ({damaged} fails its CRC-32 check)", NOT_A_CHECKPOINT)
    try:
        with warnings.catch_warnings():  # torch warns about foreign pickle protocols
            warnings.simplefilter("ignore")
            checkpoint = torch.load(source, map_location=map_location, weights_only=True)
    except (FileNotFoundError, IsADirectoryError, PermissionError):
        raise
    except pickle.UnpicklingError:
        raise CheckpointError(
            path,
            "torch.load(weights_only=True) refused it: not a plain tensor checkpoint (a "
            "foreign, damaged or malicious file; nothing in it was run)",
            NOT_A_CHECKPOINT,
        ) from None
    except EOFError:
        raise CheckpointError(path, "empty or truncated", NOT_A_CHECKPOINT) from None
    except (RuntimeError, ValueError, TypeError, KeyError, IndexError, OSError) as error:
        first = (str(error).splitlines() or [type(error).__name__])[0][:160]
        raise CheckpointError(
            path, f"not a readable torch file ({first})", NOT_A_CHECKPOINT
        ) from None
    if not isinstance(checkpoint, dict) or not isinstance(checkpoint.get("state_dict"), dict):
        raise CheckpointError(path, "not a TEMP checkpoint (no state_dict)", NOT_A_CHECKPOINT)
    if type(checkpoint.get("version")) is not int or checkpoint["version"] != CHECKPOINT_VERSION:
        raise CheckpointError(
            path,
            f"checkpoint version {checkpoint.get('version')!r}, expected {CHECKPOINT_VERSION}",
            NOT_A_CHECKPOINT,
        )
    for key, kind in (("robot", str), ("dim", int), ("encoding_resolution", int)):
        if not isinstance(checkpoint.get(key), kind) or isinstance(checkpoint.get(key), bool):
            raise CheckpointError(path, f"no valid {key!r} entry", NOT_A_CHECKPOINT)
    for key in ("max_path_length",):
        if not isinstance(checkpoint.get(key), int) or checkpoint[key] < 1:
            raise CheckpointError(path, f"no valid {key!r} entry", NOT_A_CHECKPOINT)
    robot = checkpoint["robot"]
    if robot not in robot_names() or robot_spec(robot).dim != checkpoint["dim"]:
        raise CheckpointError(
            path, f"unknown robot {checkpoint['robot']!r} (d={checkpoint['dim']})", NOT_A_CHECKPOINT
        )
    if not isinstance(checkpoint.get("model_config"), dict):
        raise CheckpointError(path, "no valid 'model_config' entry", NOT_A_CHECKPOINT)
    if "planner" in checkpoint:
        try:
            check_carried(checkpoint["planner"])
        except ValueError as error:
            raise CheckpointError(path, str(error), NOT_A_CHECKPOINT) from None
    for name, tensor in checkpoint["state_dict"].items():
        if not isinstance(tensor, torch.Tensor):
            raise CheckpointError(path, f"state_dict[{name!r}] is not a tensor", NOT_A_CHECKPOINT)
        if tensor.is_floating_point() and not bool(torch.isfinite(tensor).all()):
            raise CheckpointError(
                path,
                f"weight {name!r} holds NaN or inf (training diverged, or the file is damaged)",
                "use an earlier checkpoint, or retrain",
            )
        if tensor.is_floating_point() and tensor.numel():
            largest = float(tensor.detach().abs().max())
            if largest > MAX_WEIGHT_MAGNITUDE:
                raise CheckpointError(
                    path,
                    f"weight {name!r} holds {largest:.3g}, beyond {MAX_WEIGHT_MAGNITUDE:g} "
                    "(training diverged, or the file is damaged)",
                    "use an earlier checkpoint, or retrain",
                )
    return checkpoint


def load_checkpoint(
    path: str | Path,
    robot: str | None = None,
    dim: int | None = None,
    map_location: str | torch.device = "cpu",
    data: bytes | None = None,
) -> tuple[TEMPModel, dict[str, Any]]:
    """Load a checkpoint with ``weights_only=True``; return the model and the raw dict.

    Every defect is a `CheckpointError` naming the file: a file torch cannot read (empty,
    truncated, random bytes), one with objects that ``weights_only`` refuses to build, missing
    or ill-typed entries, weights that do not fit the stored model sizes, NaN or inf weights.
    ``data``, when given, is the file's bytes already read (``path`` then names it in errors).

    Raises:
        CheckpointError: the file is not a usable TEMP checkpoint (a `ValueError`).
        ValueError: it was trained for another ``robot`` or dimension ``dim``.
        OSError: the file cannot be opened.
    """
    checkpoint = _read_checkpoint(path, map_location, data)
    check_compatible(checkpoint["robot"], checkpoint["dim"], robot, dim, source=str(path))
    sizes = (checkpoint["robot"], checkpoint["encoding_resolution"], checkpoint["max_path_length"])
    try:  # the stored sizes against the limits and the stored weights, before allocating
        expected = weight_shapes(checkpoint["model_config"], *sizes)
    except ValueError as error:
        first = (str(error).splitlines() or [type(error).__name__])[0][:200]
        raise CheckpointError(
            path, f"unsupported model sizes ({first})", NOT_A_CHECKPOINT
        ) from None
    stored = {name: tuple(tensor.shape) for name, tensor in checkpoint["state_dict"].items()}
    if stored != expected:
        raise CheckpointError(
            path, f"its weights do not fit its model_config ({_shape_mismatch(expected, stored)})",
            NOT_A_CHECKPOINT,
        )  # fmt: skip
    try:
        model = TEMPModel.from_config(checkpoint["model_config"], *sizes)
        model.load_state_dict(checkpoint["state_dict"])
    except (ValueError, TypeError, RuntimeError, KeyError) as error:
        first = (str(error).splitlines() or [type(error).__name__])[0][:200]
        raise CheckpointError(
            path, f"its weights do not fit its model_config ({first})", NOT_A_CHECKPOINT
        ) from None
    return model, checkpoint


def _shape_mismatch(expected: dict[str, tuple], stored: dict[str, tuple]) -> str:
    """The first difference between the weights a config makes and those a file holds."""
    missing = sorted(set(expected) - set(stored))
    if missing:
        return f"no weight {missing[0]!r}"
    extra = sorted(set(stored) - set(expected))
    if extra:
        return f"an unexpected weight {brief(extra[0], 60)}"
    name = next(name for name in expected if expected[name] != stored[name])
    return f"{name!r} has shape {stored[name]}, the config makes {expected[name]}"
