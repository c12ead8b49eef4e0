"""MPT inference time per sample on one CPU core, for the default model of each world.

    python benchmarks/inference.py                       # 2D, 3D and 7D defaults
    python benchmarks/inference.py --config configs/7d.yaml --threads 1

Measures what `TEMPPolicy.__call__` costs in a planning step: one MPT forward pass (the
SEI is cached per workspace), batch 1, for short and full-length paths; plus the batched
throughput and the one-off EISE cost per workspace. Also prints parameter counts and the
checkpoint size.
"""

from __future__ import annotations

import argparse
import io
import time

import numpy as np
import torch

from temp_gym.config import load_config
from temp_gym.models.temp import TEMPModel


def _time(function, repeats: int) -> float:
    for _ in range(max(repeats // 10, 5)):
        function()
    best = np.inf
    for _ in range(5):  # best of 5 rounds: robust to a noisy machine
        began = time.perf_counter()
        for _ in range(repeats):
            function()
        best = min(best, (time.perf_counter() - began) / repeats)
    return best


def benchmark(config_path: str, repeats: int) -> None:
    config = load_config(config_path)
    env = config["env"]
    model = TEMPModel.from_config(
        config.get("model"), env["robot"], env["encoding_resolution"], env["max_path_length"]
    ).eval()
    dim, length = model.dim, model.max_path_length
    grid = torch.zeros(1, *model.eise.grid_shape)
    buffer = io.BytesIO()
    torch.save(model.checkpoint(), buffer)
    print(
        f"{env['id']}: parameters {model.num_parameters():,} (EISE "
        f"{model.num_parameters('eise'):,}, MPT {model.num_parameters('mpt'):,}), "
        f"checkpoint {buffer.tell() / 1e6:.2f} MB"
    )
    with torch.inference_mode():
        sei = model.eise(grid)
        goal, start = torch.zeros(1, dim), torch.zeros(1, dim)
        radius = torch.full((1, 1), 0.05)
        for rows in (8, 32, length):
            path = torch.rand(1, rows, dim) * 2 - 1
            rows_tensor = torch.tensor([rows])
            seconds = _time(
                lambda p=path, n=rows_tensor: model.mpt(sei, goal, radius, start, p, n), repeats
            )
            print(f"  MPT batch 1, path {rows:3d} nodes: {seconds * 1e3:.3f} ms/sample")
        batch = 256
        sei_b = sei.expand(batch, -1, -1)
        path = torch.rand(batch, length, dim) * 2 - 1
        lengths = torch.randint(1, length + 1, (batch,))
        goal_b, start_b, radius_b = (
            goal.expand(batch, -1),
            start.expand(batch, -1),
            radius.expand(batch, -1),
        )
        seconds = _time(
            lambda: model.mpt(sei_b, goal_b, radius_b, start_b, path, lengths),
            max(repeats // 50, 3),
        )
        print(f"  MPT batch {batch}, mixed lengths: {seconds / batch * 1e3:.3f} ms/sample")
        seconds = _time(lambda: model.eise(grid), repeats)
        print(f"  EISE once per workspace: {seconds * 1e3:.3f} ms")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--config", action="append", help="config file(s); default: all worlds")
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    parser.add_argument("--repeats", type=int, default=500)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    print(f"torch {torch.__version__}, {args.threads} thread(s)")
    for path in args.config or ["configs/2d.yaml", "configs/3d.yaml", "configs/7d.yaml"]:
        benchmark(path, args.repeats)


if __name__ == "__main__":
    main()
