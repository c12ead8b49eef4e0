"""What a plan on a new arm workspace pays before its first node: the checkers and the tree.

    python benchmarks/checker_setup.py [--robots kuka_iiwa14 franka_panda] [--problems 50]
        [--mbm ARCHIVE]

Per arm, generated problems (a fresh workspace each; with ``--mbm``, also the first
``--problems`` of MotionBenchMaker's archive, Panda only): the median time to build the fast
checker (`make_checker`), the exact one (``exact=True``, which certifies every returned path)
and a `Tree` (the fast checker and the workspace's free-volume floor, its workspace forgotten
before each, as the paper's protocol does). Every plan pays the tree; a planner that grows a
second tree from the goal shares the first one's checker. Rounds alternate over the same
problems, so all three see the same machine load.
"""

from __future__ import annotations

import time

import numpy as np

from temp_gym.config import parse_args, script_parser
from temp_gym.planning.tree import Tree, forget_workspace
from temp_gym.worlds.checkers import make_checker
from temp_gym.worlds.generators import generate_problem

ROUNDS = 5


def build_times(problems: list) -> dict[str, float]:
    """Median seconds of each build over `ROUNDS` rounds of ``problems``."""

    def tree(problem) -> None:
        forget_workspace(problem.workspace)
        Tree(problem)

    builds = {
        "fast checker": lambda problem: make_checker(problem.workspace),
        "exact checker": lambda problem: make_checker(problem.workspace, exact=True),
        "tree": tree,
    }
    for build in builds.values():  # untimed: caches of the arm filled
        build(problems[0])
    times: dict[str, list[float]] = {name: [] for name in builds}
    for _ in range(ROUNDS):
        for name, build in builds.items():
            for problem in problems:
                began = time.perf_counter()
                build(problem)
                times[name].append(time.perf_counter() - began)
    return {name: float(np.median(t)) for name, t in times.items()}


def main(argv: list[str] | None = None) -> dict[str, dict[str, float]]:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=["kuka_iiwa14", "franka_panda"],
                        help="registered arms")  # fmt: skip
    parser.add_argument("--problems", type=int, default=50, help="problems per set")
    parser.add_argument(
        "--mbm", default=None, help="a MotionBenchMaker archive or folder: also its Panda problems"
    )
    args = parse_args(parser, argv)
    if args.problems < 1:
        parser.error("--problems must be at least 1")
    sets = {}
    for robot in args.robots:
        rng = np.random.default_rng(0)
        sets[f"{robot}, generated"] = [generate_problem(robot, rng) for _ in range(args.problems)]
    if args.mbm is not None:
        from temp_gym.benchmarks.motionbenchmaker import load

        problems = load(args.mbm)
        step = max(len(problems) // args.problems, 1)  # spread over the scenes
        sets["franka_panda, MotionBenchMaker"] = [p for _, p in problems[::step]][: args.problems]
    print("| problems | fast checker (us) | exact checker (us) | tree (us) |")
    print("|---|---:|---:|---:|")
    out = {}
    for name, problems in sets.items():
        out[name] = build_times(problems)
        row = " | ".join(f"{out[name][key] * 1e6:.0f}" for key in out[name])
        print(f"| {name} ({len(problems)}) | {row} |", flush=True)
    return out


if __name__ == "__main__":
    main()
