"""Data parallelism: this process's place in a ``torchrun`` job (`Distributed`)."""

from __future__ import annotations

import torch

from temp_gym.config.errors import ConfigError


def launch_rank() -> int:
    """This process's rank in a ``torchrun`` launch (0 without one), before any process group."""
    import os

    return int(os.environ.get("RANK", "0"))


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
        if self.device.type == "cuda" and not torch.cuda.is_available():
            raise ConfigError(f"train.device: {device_name!r}, but this PyTorch sees no CUDA "
                              "device; use cpu or auto")  # fmt: skip
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
