"""The anytime loop per node: its compiled extensions against the Python loop, side by side.

    python benchmarks/anytime_loop.py                      # 2D, 3D and 7D, 10 problems each
    python benchmarks/anytime_loop.py --worlds 2d --problems 20 --nodes 5000

RRT* and Informed RRT* (`temp_gym.planning.anytime.grow_anytime`) grow the same tree with
``compiled_loop=True`` and ``compiled_loop=False``; this grows both on the same test problems
and seeds, in alternating order, checks that the trees are identical, and prints microseconds
per node of each (the loop only: tree, sampler and checker are built outside the clock) and
their ratio. One thread (``NUMBA_NUM_THREADS=1``).
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")  # before numba loads

import time  # noqa: E402

import numpy as np  # noqa: E402

from temp_gym.config import parse_args, script_parser  # noqa: E402
from temp_gym.evaluation.runner import evaluation_problem  # noqa: E402
from temp_gym.planning.anytime import grow_anytime  # noqa: E402
from temp_gym.planning.result import AnytimeLog  # noqa: E402
from temp_gym.planning.settings import PlanSettings  # noqa: E402
from temp_gym.planning.tree import Tree  # noqa: E402

WORLDS = {"2d": ("point2d", "challenging"), "3d": ("point3d", "challenging"),
          "7d": ("kuka_iiwa14", "any")}  # fmt: skip


def _grow(problem, seed: int, informed: bool, compiled_loop: bool, nodes: int):
    tree = Tree(problem)
    settings = PlanSettings(seed=seed, max_nodes=nodes)
    rng = np.random.default_rng(seed)
    began = time.perf_counter()
    grow_anytime(tree, settings, rng, AnytimeLog(), informed, compiled_loop=compiled_loop)
    return tree, time.perf_counter() - began


def _same(a: Tree, b: Tree) -> bool:
    n = a.num_nodes
    return (
        n == b.num_nodes
        and np.array_equal(a.positions[:n], b.positions[:n])
        and np.array_equal(a.links[:n], b.links[:n])
        and a.samples == b.samples
    )


def main(argv: list[str] | None = None) -> None:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--worlds", nargs="+", choices=sorted(WORLDS), default=sorted(WORLDS),
                        help="worlds to run")  # fmt: skip
    parser.add_argument("--problems", type=int, default=10, help="test problems per world")
    parser.add_argument("--nodes", type=int, default=2000, help="tree nodes per run")
    args = parse_args(parser, argv)
    print("| world | planner | compiled us/node | Python us/node | Python/compiled | same trees |")
    print("|---|---|---:|---:|---:|---|")
    for world in args.worlds:
        robot, difficulty = WORLDS[world]
        warm = evaluation_problem(robot, difficulty, 10_000, 0)
        for informed in (False, True):
            for compiled_loop in (True, False):  # compile (or load) before timing
                _grow(warm, 0, informed, compiled_loop, 200)
            seconds = {True: 0.0, False: 0.0}
            nodes = {True: 0, False: 0}
            same = True
            for index in range(args.problems):
                problem = evaluation_problem(robot, difficulty, index, 0)
                trees = {}
                order = (True, False) if index % 2 else (False, True)
                for compiled_loop in order:
                    tree, elapsed = _grow(problem, index, informed, compiled_loop, args.nodes)
                    trees[compiled_loop] = tree
                    seconds[compiled_loop] += elapsed
                    nodes[compiled_loop] += tree.num_nodes
                same &= _same(trees[True], trees[False])
            per_node = {key: seconds[key] / nodes[key] * 1e6 for key in seconds}
            name = "informed_rrt_star" if informed else "rrt_star"
            print(
                f"| {world} | {name} | {per_node[True]:.1f} | {per_node[False]:.1f} | "
                f"{per_node[False] / per_node[True]:.2f}x | {'yes' if same else '**no**'} |"
            )


if __name__ == "__main__":
    main()
