"""Batches for behaviour cloning.

A split's samples and workspace table (`SplitData`), chunk targets, symmetry augmentation,
path noise, and the (sharded) batch order.

`ensure_dataset` finds the config's dataset, generating it when it is incomplete.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tensordict import TensorDict

from temp_gym.config import Config
from temp_gym.config.errors import ConfigError

BATCH_KEYS = ("start", "goal", "goal_radius", "path", "path_length", "target")


def ensure_dataset(config: Config, progress: bool = True, quiet: bool = False) -> Path:
    """The dataset directory ``data.dir``, generated (or repaired) if incomplete.

    Waits while another process holds the directory's lock (another rank, or a
    ``generate.py`` run), then finds the dataset it made.
    """
    from temp_gym.data import dataset_exists, generate_dataset

    if dataset_exists(config):
        return Path(config.data.dir)
    if not quiet:
        print(f"no complete dataset in {config.data.dir}: generating it (RRT* demonstrations)")
    return Path(generate_dataset(config, workers=config.data.workers, progress=progress, wait=True))


def chunk_rows(task_id: torch.Tensor, step: torch.Tensor, chunk: int):
    """Rows of the next ``chunk`` nodes of each sample's expert path, and which exist.

    A task's samples are stored in path order (prefix ``x0..xk`` at step k, target
    ``x(k+1)``), so sample ``i + j`` holds node ``x(k+1+j)`` when it belongs to the same
    task at step ``k + j``. Returns ``rows`` ``(N, chunk)`` (int64; a row whose node does not
    exist, past the end of the path, points at the sample itself) and ``mask`` ``(N, chunk)``.

    Raises:
        ValueError: ``chunk > 1`` and no sample has a next node stored after it (the samples
            are not in path order, so chunk targets cannot be read off them).
    """
    count = len(task_id)
    index = torch.arange(count)
    offsets = torch.arange(chunk)
    rows = (index[:, None] + offsets[None, :]).clamp(max=max(count - 1, 0))
    mask = (task_id[rows] == task_id[:, None]) & (step[rows] == step[:, None] + offsets)
    if chunk > 1 and count > 1 and not bool(mask[:, 1].any()):
        raise ValueError("chunk targets: the samples are not stored in path order")
    return torch.where(mask, rows, index[:, None]), mask


class SplitData:
    """One split's samples and workspace table, ready for batching.

    The samples stay where the replay buffer keeps them (a memory map); each batch is gathered
    by index. The occupancy grids are looked up by ``workspace_id`` once per batch, and only
    the batch's distinct workspaces are sent through the EISE. A batch also holds the expert's
    next ``chunk`` nodes (``targets``, ``target_mask``: `chunk_rows`) for a chunked MPT.
    """

    def __init__(
        self,
        buffer: Any,
        workspaces: TensorDict,
        chunk: int = 1,
        corrections: list[dict[str, np.ndarray]] = (),
    ) -> None:
        samples = buffer.storage[: len(buffer)]
        rows, mask = chunk_rows(
            torch.as_tensor(samples["task_id"]).reshape(-1).long(),
            torch.as_tensor(samples["step"]).reshape(-1).long(),
            chunk,
        )
        targets = torch.as_tensor(samples["target"]).to(torch.float32)
        self.chunk_targets = targets[rows]  # (N, chunk, d): the expert's next nodes
        self.chunk_mask = mask
        if corrections:  # on-policy samples (temp_gym.data.correction) carry their targets
            keys = [key for key in BATCH_KEYS if key != "target"] + ["workspace_id"]
            parts = [samples.select(*keys).to_dict()]
            targets, masks = [self.chunk_targets], [mask]
            for columns in corrections:
                if columns["targets"].shape[1] < chunk:
                    raise ValueError(
                        f"corrections: labelled with {columns['targets'].shape[1]} targets, "
                        f"the model predicts {chunk}"
                    )
                parts.append({key: torch.from_numpy(np.asarray(columns[key])) for key in keys})
                targets.append(torch.from_numpy(np.asarray(columns["targets"][:, :chunk])))
                masks.append(torch.from_numpy(np.asarray(columns["target_mask"][:, :chunk])))
            merged = {key: torch.cat([part[key] for part in parts]) for key in keys}
            samples = TensorDict(merged, batch_size=[len(merged["path"])])
            self.chunk_targets = torch.cat(targets).to(torch.float32)
            self.chunk_mask = torch.cat(masks)
        self.samples = samples
        self.lengths = torch.as_tensor(self.samples["path_length"]).reshape(-1).clone()
        ids = workspaces["workspace_id"].long()
        self.occupancy = workspaces["occupancy"].to(torch.float32).clone()
        self.row_of_id = torch.full((int(ids.max()) + 1,), -1, dtype=torch.long)
        self.row_of_id[ids] = torch.arange(len(ids))

    def __len__(self) -> int:
        return int(self.samples.batch_size[0])

    def batch(self, index: torch.Tensor, device: torch.device) -> dict[str, torch.Tensor]:
        """Samples ``index`` as a model batch: unique grids plus ``occupancy_index``."""
        part = self.samples[index]
        rows = self.row_of_id[part["workspace_id"].long().reshape(-1)]
        if bool((rows < 0).any()):
            raise ValueError("a sample refers to a workspace_id missing from the table")
        unique, inverse = torch.unique(rows, return_inverse=True)
        batch = {
            key: torch.as_tensor(part[key]).to(device) for key in BATCH_KEYS if key != "target"
        }
        batch["occupancy"] = self.occupancy[unique].to(device)
        batch["occupancy_index"] = inverse.to(device)
        batch["targets"] = self.chunk_targets[index].to(device)
        batch["target_mask"] = self.chunk_mask[index].to(device)
        batch["target"] = batch["targets"][:, 0]
        return batch


COORDINATE_KEYS = ("start", "goal", "path", "target", "targets")


def draw_symmetry(dim: int, generator: torch.Generator) -> tuple[torch.Tensor, torch.Tensor]:
    """One of the ``2^d d!`` symmetries of the cube: per-axis flips and an axis order."""
    flips = torch.rand(dim, generator=generator) < 0.5
    order = torch.randperm(dim, generator=generator)
    return flips, order


def augment_symmetry(
    batch: dict[str, torch.Tensor],
    generator: torch.Generator | None = None,
    symmetry: tuple[torch.Tensor, torch.Tensor] | None = None,
) -> dict[str, torch.Tensor]:
    """Apply one random symmetry of the cube to a point-robot batch (grids and coordinates).

    Point worlds are cubes ([0, 20]^d) whose occupancy grid covers the configuration bounds,
    so flipping grid axis i is negating normalized coordinate i, and swapping two grid axes
    is swapping the two coordinates: the same planning problem, mirrored. One of the
    ``2^d d!`` symmetries is drawn per batch (`draw_symmetry`), or given. Padding rows stay
    zero.
    """
    dim = batch["start"].shape[-1]
    flips, order = symmetry if symmetry is not None else draw_symmetry(dim, generator)
    out = dict(batch)
    sign = torch.where(flips, -1.0, 1.0).to(batch["start"].device)
    for key in COORDINATE_KEYS:
        if key in batch:
            out[key] = (batch[key] * sign)[..., order.to(batch[key].device)]
    grid = batch["occupancy"]
    flipped_axes = [1 + axis for axis in range(dim) if flips[axis]]
    if flipped_axes:
        grid = torch.flip(grid, flipped_axes)
    out["occupancy"] = grid.permute(0, *(1 + order).tolist())
    return out


def perturb_path(
    batch: dict[str, torch.Tensor],
    std: float,
    generator: torch.Generator | None = None,
    noise: torch.Tensor | None = None,
) -> dict[str, torch.Tensor]:
    """Add Gaussian noise of ``std`` (normalized units) to the valid path rows; keep the target.

    The policy's own tree never follows the expert exactly; training from perturbed paths
    toward the expert's next node teaches it to steer back (noise injection, as in DART).
    ``noise`` (standard normal, at least as many path rows) may be given instead of drawn.
    """
    path = batch["path"]
    valid = torch.arange(path.shape[1], device=path.device) < batch["path_length"].reshape(-1, 1)
    if noise is None:
        noise = torch.randn(path.shape, generator=generator)
    noise = noise[:, : path.shape[1]].to(path.device) * std
    out = dict(batch)
    out["path"] = torch.clamp(path + noise * valid.unsqueeze(-1), -1.0, 1.0)
    return out


def make_replay_buffer(config: Config, split: str) -> SplitData:
    """Load ``split`` (``train`` or ``val``) as `SplitData`, with targets for the model's chunk.

    The training split gets the correction rounds of ``data.corrections`` too.
    """
    from temp_gym.data import load_split
    from temp_gym.data.correction import load_corrections

    buffer, workspaces = load_split(config.data.dir, split)
    if len(buffer) == 0 or len(workspaces) == 0:
        plans = _plans_stored(config.data.dir, split)
        if plans is None or plans[1] == 0:
            raise ConfigError(
                f"data.workspaces.{split}: the {split} split of {config.data.dir} holds no "
                "samples; training needs at least one workspace in each split"
            )
        if plans[2] == plans[1]:  # no plan ran: more nodes cannot help
            raise ConfigError(
                f"data.workspaces.{split}: the {split} split of {config.data.dir} holds no "
                f"samples: none of its {plans[1]} tasks could be drawn (no free start and goal "
                f"of difficulty {config.data.difficulty!r} in its workspaces); is the robot "
                "in collision with its workspaces or itself in nearly every configuration? "
                "(temp-view a workspace, or count free states with its checker)"
            )
        raise ConfigError(
            f"data.workspaces.{split}: the {split} split of {config.data.dir} holds no samples: "
            f"{plans[0]} of its {plans[1]} expert plans succeeded (within data.max_nodes = "
            f"{config.data.max_nodes}); draw more tasks (data.tasks_per_workspace, "
            f"data.workspaces.{split}), give the expert more nodes (data.max_nodes) or easier "
            "tasks (data.difficulty=easy)"
        )
    chunk = config.model.chunk
    rounds = config.data.corrections if split == "train" else []
    return SplitData(buffer, workspaces, chunk, [load_corrections(path) for path in rounds])


def _plans_stored(directory: str, split: str) -> tuple[int, int, int] | None:
    """``(stored, attempted, not drawn)`` expert plans of ``split`` from its dataset card.

    None without a card. A task not drawn (no free start and goal found) counts as attempted.
    """
    import json
    from pathlib import Path

    try:
        card = json.loads((Path(directory) / "dataset_card.json").read_text())
        counts = card["splits"][split]
        not_drawn = int(counts.get("tasks_not_drawn", 0))
        return int(counts["plans_stored"]), int(counts["plans_attempted"]), not_drawn
    except (OSError, ValueError, KeyError, TypeError):
        return None


def iterate_batches(
    data: SplitData,
    batch_size: int,
    device: torch.device,
    generator: torch.Generator | None = None,
    bucket: int = 32,
) -> Iterator[dict[str, torch.Tensor]]:
    """`iterate_batch_indices`, gathered into model batches."""
    for index in iterate_batch_indices(data, batch_size, generator, bucket):
        yield data.batch(index, device)


def iterate_batch_indices(
    data: SplitData,
    batch_size: int,
    generator: torch.Generator | None = None,
    bucket: int = 32,
) -> Iterator[torch.Tensor]:
    """Batches over the whole split; shuffled by ``generator``, in order without one.

    Shuffled batches are bucketed by path length: each run of ``bucket * batch_size``
    shuffled samples is sorted by ``path_length`` and cut into batches, and the batches are
    shuffled again. Padding is cut to the longest path of a batch (`MPT.forward`), so similar
    lengths make an epoch several times cheaper, and batches still mix workspaces and tasks.
    """
    count = len(data)
    if generator is None:
        for first in range(0, count, batch_size):
            yield torch.arange(first, min(first + batch_size, count))
        return
    order = torch.randperm(count, generator=generator)
    batches = []
    for first in range(0, count, bucket * batch_size):
        chunk = order[first : first + bucket * batch_size]
        chunk = chunk[torch.argsort(data.lengths[chunk], stable=True)]
        batches.extend(chunk.split(batch_size))
    for index in torch.randperm(len(batches), generator=generator).tolist():
        yield batches[index]
