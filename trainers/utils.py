"""Factories and helpers for `trainers/bc.py` (torchrl sota-implementations style).

``make_env``, ``make_replay_buffer``, ``make_model``, ``make_loss``, ``make_optimizer``,
``make_logger`` each read the config section they are named after; ``iterate_batches`` and
``evaluate_planner`` are the data and evaluation loops the trainer shares with its tests.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from tensordict import TensorDict

from temp_gym.evaluation.statistics import bootstrap_interval
from temp_gym.models.loss import TEMPLoss
from temp_gym.models.temp import TEMPModel
from temp_gym.problem import Problem
from temp_gym.tensorboard_summaries import add_hparams, add_scalar
from temp_gym.wrappers.metrics import INFO_KEY, PlanningMetrics

BATCH_KEYS = ("start", "goal", "goal_radius", "path", "path_length", "target")


# ---------------------------------------------------------------------- env and data
def make_env(config: dict[str, Any], fallback: str = "random", split: str = "test") -> gym.Env:
    """The planning env of ``config["env"]``, wrapped in `PlanningMetrics`."""
    env_config, eval_config = config["env"], config.get("eval", {})
    env = gym.make(
        env_config["id"],
        difficulty=eval_config.get("difficulty", "any"),
        max_nodes=eval_config.get("max_nodes"),
        step_size=env_config.get("step_size"),
        fallback=fallback,
        encoding_resolution=env_config["encoding_resolution"],
        split=split,
        max_path_length=env_config["max_path_length"],
        disable_env_checker=True,
    )
    return PlanningMetrics(env)


def ensure_dataset(config: dict[str, Any], progress: bool = True, quiet: bool = False) -> Path:
    """The dataset directory of ``config["data"]``, generated (or repaired) if incomplete.

    Waits while another process holds the directory's lock (another rank, or a
    ``generate.py`` run), then finds the dataset it made.
    """
    from temp_gym.data import dataset_exists, generate_dataset

    if dataset_exists(config):
        return Path(config["data"]["dir"])
    if not quiet:
        print(
            f"no complete dataset in {config['data']['dir']}: generating it (RRT* demonstrations)"
        )
    return Path(
        generate_dataset(
            config, workers=config["data"].get("workers"), progress=progress, wait=True
        )
    )


def launch_rank() -> int:
    """This process's rank in a ``torchrun`` launch (0 without one), before any process group."""
    import os

    return int(os.environ.get("RANK", "0"))


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


def make_replay_buffer(config: dict[str, Any], split: str) -> SplitData:
    """Load ``split`` (``train`` or ``val``) as `SplitData`, with targets for the model's chunk."""
    from temp_gym.data import load_split
    from temp_gym.data.correction import load_corrections

    buffer, workspaces = load_split(config["data"]["dir"], split)
    chunk = int((config.get("model") or {}).get("chunk", 1))
    rounds = (config["data"].get("corrections") or []) if split == "train" else []
    return SplitData(buffer, workspaces, chunk, [load_corrections(path) for path in rounds])


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


# ---------------------------------------------------------------------- data parallelism
class Distributed:
    """This process's place in a ``torchrun`` job (rank 0 of 1 without one).

    Under ``torchrun --nproc_per_node=N`` the process group is initialised with gloo on CPU
    or nccl on CUDA (one GPU per local rank). Every rank holds the model; each global batch
    is cut into ``world`` equal slices (`shard`) and each rank reads only its slice; DDP
    averages the gradients. Rank 0 alone logs, checkpoints, evaluates and builds the dataset.
    """

    def __init__(self, device_name: str = "auto") -> None:
        import os

        import torch.distributed as dist

        self.world = int(os.environ.get("WORLD_SIZE", "1"))
        self.rank = launch_rank()
        local_rank = int(os.environ.get("LOCAL_RANK", "0"))
        cuda = torch.cuda.is_available() and device_name in ("auto", "cuda")
        if device_name == "auto":
            device_name = "cuda" if cuda else "cpu"
        if device_name == "cuda" and self.world > 1:
            device_name = f"cuda:{local_rank}"
        self.device = torch.device(device_name)
        if self.world > 1 and not dist.is_initialized():
            dist.init_process_group(backend="nccl" if self.device.type == "cuda" else "gloo")
        self.is_main = self.rank == 0

    def shard(self, size: int) -> tuple[torch.Tensor, float]:
        """Positions of this rank's slice of a global batch of ``size``, and its loss weight.

        The weight ``n_rank * world / size`` makes the mean over ranks of the weighted slice
        losses equal the global batch's loss (both loss terms are per-sample means). A rank
        whose slice is empty runs one sample with weight 0, so DDP's collective still happens.
        """
        positions = torch.arange(size).tensor_split(self.world)[self.rank]
        if len(positions) == 0:
            return torch.zeros(1, dtype=torch.long), 0.0
        return positions, len(positions) * self.world / size

    def sum(self, values: torch.Tensor) -> torch.Tensor:
        """Sum ``values`` over ranks (identity without torchrun)."""
        if self.world > 1:
            import torch.distributed as dist

            values = values.clone()
            dist.all_reduce(values)
        return values

    def barrier(self) -> None:
        """Wait for every rank."""
        if self.world > 1:
            import torch.distributed as dist

            dist.barrier()

    def close(self) -> None:
        """Leave the process group."""
        if self.world > 1:
            import torch.distributed as dist

            if dist.is_initialized():
                dist.destroy_process_group()


# ---------------------------------------------------------------------- model and optimization
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


# ---------------------------------------------------------------------- logging
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
    "eval/success": "TEMP planning during training: share of eval.periodic_tasks held-out test "
    "tasks solved within eval.max_nodes, every eval.every epochs.",
    "eval/nodes": "TEMP planning during training: mean nodes to the first solution on the "
    "held-out tasks (a failure counts as the whole budget).",
    "eval/cost": "TEMP planning during training: mean path cost over the solved held-out tasks.",
    "time/epoch": "Wall seconds of the epoch's training batches (validation excluded).",
    "time/samples_per_s": "Training samples per wall second in the epoch.",
}
"""What each TensorBoard tag of `trainers/bc.py` means; shown with its chart."""
FINAL_DESCRIPTION = (
    "The final comparison: TEMP (best.pt) against RRT* on eval.tasks held-out tasks, each up "
    "to its first solution (a failure counts as the budget in the node figures)."
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


class Logger:
    """TensorBoard writer behind a small interface; ``backend=""`` makes every call a no-op.

    Each tag's first scalar carries its description (`describe_tag`), so the dashboard
    explains its charts.
    """

    def __init__(self, backend: str, log_dir: Path) -> None:
        self.writer = None
        if backend == "tensorboard":
            from torch.utils.tensorboard import SummaryWriter

            self.writer = SummaryWriter(log_dir=str(log_dir))
        elif backend:
            raise ValueError(f"logger.backend: expected 'tensorboard' or '', got {backend!r}")
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

    def hparams(self, config: dict[str, Any]) -> None:
        """The config in the HParams dashboard and the custom-scalars layout (`LAYOUT`)."""
        if self.writer is not None:
            add_hparams(self.writer, config, HPARAM_METRICS)
            self.writer.add_custom_scalars(LAYOUT)

    def close(self) -> None:
        """Flush and close."""
        if self.writer is not None:
            self.writer.close()


def make_logger(config: dict[str, Any], run_dir: Path) -> Logger:
    """`Logger` for ``logger.backend`` writing into the run directory."""
    return Logger(config.get("logger", {}).get("backend", "tensorboard"), run_dir)


# ---------------------------------------------------------------------- evaluation
def draw_problems(config: dict[str, Any], split: str, count: int, seed: int) -> list[Problem]:
    """``count`` tasks drawn by the env from ``split``'s workspaces, task i with seed+i."""
    env = make_env(config, fallback="none", split=split)
    problems = []
    for index in range(count):
        env.reset(seed=seed + index)
        problems.append(env.unwrapped.problem)
    env.close()
    return problems


def run_episode(
    env: gym.Env, policy: Any, problem: Problem, seed: int
) -> tuple[dict[str, float], dict[str, Any]]:
    """Plan ``problem`` in ``env`` with ``policy`` until the first solution or the budget.

    Returns ``info["planning"]`` (`PlanningMetrics`) plus ``time`` (wall seconds, policy
    included), and the final info (with the tree still in ``env.unwrapped``).
    """
    began = time.perf_counter()
    observation, info = env.reset(seed=seed, options={"problem": problem})
    policy.reset(problem)
    while True:
        observation, _, terminated, truncated, info = env.step(policy(observation))
        if terminated or truncated:
            break
    episode = {key: float(value) for key, value in info[INFO_KEY].items()}
    episode["time"] = time.perf_counter() - began
    return episode, info


def evaluate_planner(
    env: gym.Env, policy: Any, problems: list[Problem], seed: int
) -> list[dict[str, float]]:
    """`run_episode` over ``problems`` (episode i seeded ``seed + i``)."""
    return [run_episode(env, policy, problem, seed + i)[0] for i, problem in enumerate(problems)]


def nodes_or_budget(episodes: list[dict[str, float]], max_nodes: int) -> np.ndarray:
    """Nodes to the first solution per episode, ``max_nodes`` for a failed one."""
    return np.array([run["nodes"] if run["success"] > 0 else max_nodes for run in episodes])


def paired_nodes(
    episodes: list[dict[str, float]],
    baseline: list[dict[str, float]],
    max_nodes: int,
    resamples: int = 2000,
    seed: int = 0,
) -> dict[str, float]:
    """Nodes to the first solution of two planners on the same tasks, compared task by task.

    A failure counts as the whole budget, as in `summarize`. Returns the share of tasks where
    ``episodes`` needed fewer nodes than ``baseline``, the mean difference (``episodes`` minus
    ``baseline``) and its 95% paired bootstrap interval (``resamples`` resamplings of the
    tasks, seeded): the means of heavy-tailed node counts move a lot between task sets, and
    the interval says whether a difference is more than that.
    """
    if len(episodes) != len(baseline) or not episodes:
        raise ValueError(
            f"expected the same non-empty task list, got {len(episodes)} and {len(baseline)}"
        )
    difference = nodes_or_budget(episodes, max_nodes) - nodes_or_budget(baseline, max_nodes)
    low, high = bootstrap_interval(difference, np.mean, resamples=resamples, seed=seed)
    return {
        "fewer": float(np.mean(difference < 0)),
        "difference": float(difference.mean()),
        "low": float(low),
        "high": float(high),
    }


def summarize(episodes: list[dict[str, float]], max_nodes: int) -> dict[str, float]:
    """Success rate, nodes to the first solution, cost, samples and time of a planner.

    Nodes: mean over all episodes (a failure counts as the whole budget) and median; cost:
    mean over successful episodes; samples and time: means over all episodes.
    """
    success = np.array([episode["success"] for episode in episodes]) > 0
    nodes = nodes_or_budget(episodes, max_nodes)
    costs = np.array([episode["cost"] for episode, ok in zip(episodes, success) if ok])
    return {
        "success": float(success.mean()),
        "nodes_mean": float(nodes.mean()),
        "nodes_median": float(np.median(nodes)),
        "cost": float(costs.mean()) if len(costs) else math.inf,
        "samples": float(np.mean([episode["samples"] for episode in episodes])),
        "time": float(np.mean([episode["time"] for episode in episodes])),
    }
