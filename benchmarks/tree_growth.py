"""RRT* per node as its tree grows: nearest and near queries through the grid against scans.

    python benchmarks/tree_growth.py [--sizes 1000 4000 16000] [--repeats 3]

Per point world, on one challenging test task, RRT* (the compiled anytime loop) runs to each
tree size, once with the tree's grid (`temp_gym.planning._grid`, made once a tree outgrows
`GRID_MIN_NODES`) and once scanning every node for every query; the two alternate, so both
see the same machine load, and the trees are the same node for node (tests/planning/test_tree.py).
Prints the best time per run, per node, and the ratio.

Then the same on a tree crowded into a trap (``benchmarks/data/trap_2d.json``: task 832 of the
2D planner-tuning pool, where RRT* needs 5491 nodes and 87,554 samples to a first solution):
there nearly every sample lies far from the tree, and a nearest query reads thousands of nodes.
"""

from __future__ import annotations

import time
from pathlib import Path

from temp_gym import Problem, plan
from temp_gym.config import parse_args, script_parser
from temp_gym.evaluation.runner import evaluation_problem
from temp_gym.planning import _grid


def timed(problem, nodes: int, seed: int, min_nodes: int) -> float:
    """Seconds of one RRT* run to ``nodes`` nodes with the grid from ``min_nodes`` nodes."""
    saved = _grid.GRID_MIN_NODES
    _grid.GRID_MIN_NODES = min_nodes
    try:
        began = time.perf_counter()
        plan(problem, planner="rrt_star", max_nodes=nodes, seed=seed)
        return time.perf_counter() - began
    finally:
        _grid.GRID_MIN_NODES = saved


def main(argv: list[str] | None = None) -> None:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 2000, 4000, 8000, 16000],
                        help="tree sizes (nodes)")  # fmt: skip
    parser.add_argument("--repeats", type=int, default=3, help="runs per size and side")
    args = parse_args(parser, argv)
    print("| world | nodes | grid ms | scan ms | grid us/node | scan us/node | grid/scan |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for robot in ("point2d", "point3d"):
        problem = evaluation_problem(robot, "challenging", 3)
        plan(problem, planner="rrt_star", max_nodes=50)  # compile first
        for nodes in args.sizes:
            grid, scan = [], []
            for seed in range(args.repeats):
                grid.append(timed(problem, nodes, seed, _grid.GRID_MIN_NODES))
                scan.append(timed(problem, nodes, seed, 2**62))
            g, s = min(grid), min(scan)
            print(f"| {robot} | {nodes} | {g * 1e3:.1f} | {s * 1e3:.1f} | {g / nodes * 1e6:.2f} | "
                  f"{s / nodes * 1e6:.2f} | {g / s:.2f} |", flush=True)  # fmt: skip
    trap = Problem.load(TRAP)
    grid, scan = [], []
    for seed in range(args.repeats):
        grid.append(timed_first(trap, seed, _grid.GRID_MIN_NODES))
        scan.append(timed_first(trap, seed, 2**62))
    g, s = min(grid), min(scan)
    print(
        f"\ntrap ({TRAP.name}), RRT* to its first solution: grid {g * 1e3:.0f} ms, scan "
        f"{s * 1e3:.0f} ms, grid/scan {g / s:.2f}"
    )


TRAP = Path(__file__).resolve().parent / "data" / "trap_2d.json"


def timed_first(problem, seed: int, min_nodes: int) -> float:
    """Seconds of one RRT* run to its first solution with the grid from ``min_nodes`` nodes."""
    saved = _grid.GRID_MIN_NODES
    _grid.GRID_MIN_NODES = min_nodes
    try:
        began = time.perf_counter()
        plan(problem, planner="rrt_star", max_nodes=10_000, seed=seed, stop_at_first=True)
        return time.perf_counter() - began
    finally:
        _grid.GRID_MIN_NODES = saved


if __name__ == "__main__":
    main()
