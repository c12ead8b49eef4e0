"""Collision-checking throughput: fast vs exact checker, per world, in one run.

    python benchmarks/collision.py [--states 100000] [--edges 5000] [--exact-states 2000]

For each world (2D, 3D, 7D) it draws generated workspaces, times ``states_free`` on random
configurations and ``edges_free`` on random edges (edge length ~ the planners' step size), for
the fast checker and the exact one, and prints states/s, edges/s and the fast/exact ratio.
Point robots have one checker that is both fast and exact (analytic), so their ratio is 1.
Single-threaded: numba kernels run on one core; set NUMBA_NUM_THREADS=1 to be sure.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from temp_gym.config import parse_args, script_parser
from temp_gym.worlds.collision import make_checker
from temp_gym.worlds.generators import generate_workspace

STEP = {"point2d": 1.0, "point3d": 1.0, "kuka_iiwa14": 0.5}


def _rate(function, *args, repeats: int = 3) -> float:
    """Calls per second of ``function(*args)``, counted in rows of the first argument."""
    count = len(args[0])
    function(*args)  # warm-up: numba compilation, caches
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        function(*args)
        best = min(best, time.perf_counter() - start)
    return count / best


def _random_edges(rng, bounds, step, count):
    starts = rng.uniform(bounds[0], bounds[1], size=(count, bounds.shape[1]))
    direction = rng.normal(size=starts.shape)
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    ends = np.clip(starts + step * direction, bounds[0], bounds[1])
    return starts, ends


def bench_world(robot: str, args: argparse.Namespace) -> dict[str, float]:
    rng = np.random.default_rng(args.seed)
    rows = {
        "fast_states": [],
        "fast_edges": [],
        "exact_states": [],
        "exact_edges": [],
        "free_fraction": [],
    }
    for _ in range(args.workspaces):
        workspace = generate_workspace(robot, rng)
        bounds = workspace.bounds
        states = rng.uniform(bounds[0], bounds[1], size=(args.states, workspace.dim))
        starts, ends = _random_edges(rng, bounds, STEP[robot], args.edges)
        fast = make_checker(workspace)
        exact = make_checker(workspace, exact=True)
        rows["free_fraction"].append(fast.states_free(states).mean())
        rows["fast_states"].append(_rate(fast.states_free, states))
        rows["fast_edges"].append(_rate(fast.edges_free, starts, ends))
        few_starts, few_ends = starts[: args.exact_edges], ends[: args.exact_edges]
        rows["exact_states"].append(
            _rate(exact.states_free, states[: args.exact_states], repeats=1)
        )
        rows["exact_edges"].append(_rate(exact.edges_free, few_starts, few_ends, repeats=1))
    return {key: float(np.mean(value)) for key, value in rows.items()}


def main(argv: list[str] | None = None) -> None:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--states", type=int, default=100_000, help="random states per workspace")
    parser.add_argument("--edges", type=int, default=5_000, help="random edges per workspace")
    parser.add_argument(
        "--exact-states", type=int, default=2_000, help="of those, for the exact checker"
    )
    parser.add_argument(
        "--exact-edges", type=int, default=200, help="of those, for the exact checker"
    )
    parser.add_argument("--workspaces", type=int, default=3, help="generated workspaces per robot")
    parser.add_argument("--seed", type=int, default=0, help="seed of workspaces, states, edges")
    parser.add_argument(
        "--robots",
        nargs="+",
        default=["point2d", "point3d", "kuka_iiwa14"],
        help="robots to measure",
    )
    args = parse_args(parser, argv)
    for robot in args.robots:
        result = bench_world(robot, args)
        print(
            f"\n## {robot}  ({args.workspaces} generated workspaces, "
            f"{100 * result['free_fraction']:.0f}% of random states free)"
        )
        print("| check | fast (/s) | exact (/s) | fast / exact |")
        print("|---|---:|---:|---:|")
        for kind in ("states", "edges"):
            fast, exact = result[f"fast_{kind}"], result[f"exact_{kind}"]
            print(f"| {kind} | {fast:,.0f} | {exact:,.0f} | {fast / exact:,.1f}x |")


if __name__ == "__main__":
    main()
