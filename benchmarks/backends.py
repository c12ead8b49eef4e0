"""Demonstration throughput: the ray backend against the local one, side by side.

    python benchmarks/backends.py [--config configs/2d.yaml] [--workers 2] [--workspaces 8]

Generates the same small dataset twice into temporary directories, first with local worker
processes, then as Ray tasks on a local Ray instance with the same number of CPUs, and prints
plans/s for each and the ratio ray/local (target: >= 0.8). Ray's start-up is timed apart:
a cluster is normally running already.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from temp_gym.config import load_config, parse_args, script_parser
from temp_gym.data import generate_dataset
from temp_gym.distributed import init_ray


def timed_generation(config_path, overrides, directory, backend, workers) -> float:
    config = load_config(config_path, [*overrides, f"data.dir={directory}"])
    started = time.perf_counter()
    generate_dataset(config, workers=workers, progress=False, backend=backend)
    return time.perf_counter() - started


def main(argv: list[str] | None = None) -> None:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--config", default="configs/2d.yaml", help="YAML config")
    parser.add_argument("--workers", type=int, default=2, help="processes (local) or CPUs (ray)")
    parser.add_argument("--workspaces", type=int, default=8, help="train workspaces (val: 1/4)")
    parser.add_argument("--tasks", type=int, default=50, help="tasks per workspace")
    args = parse_args(parser, argv)
    overrides = [
        f"data.workspaces.train={args.workspaces}",
        f"data.workspaces.val={max(1, args.workspaces // 4)}",
        f"data.tasks_per_workspace={args.tasks}",
    ]
    plans = (args.workspaces + max(1, args.workspaces // 4)) * args.tasks
    with tempfile.TemporaryDirectory() as scratch:
        # Warm the numba cache first, so neither backend pays for compilation.
        timed_generation(args.config, [*overrides[:2], "data.tasks_per_workspace=1",
                         "data.workspaces.train=1", "data.workspaces.val=1"],
                         Path(scratch) / "warm", "local", 1)  # fmt: skip
        local = timed_generation(args.config, overrides, Path(scratch) / "local", "local",
                                 args.workers)  # fmt: skip
        started = time.perf_counter()
        init_ray(None, args.workers)
        startup = time.perf_counter() - started
        ray = timed_generation(args.config, overrides, Path(scratch) / "ray", "ray", args.workers)
    print(f"{plans} plans, {args.workers} workers ({args.config})")
    print("| backend | wall (s) | plans/s |")
    print("|---|---:|---:|")
    print(f"| local | {local:.1f} | {plans / local:.1f} |")
    print(f"| ray | {ray:.1f} | {plans / ray:.1f} |")
    print(
        f"ray / local throughput: {local / ray:.2f} (Ray start-up {startup:.1f} s not included;"
        f" with it: {local / (ray + startup):.2f})"
    )


if __name__ == "__main__":
    main()
