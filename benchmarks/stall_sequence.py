"""TEMP after a stall: the phases from the goal and the rounds as one compiled call, or from Python.

    python benchmarks/stall_sequence.py [--worlds 2d 3d] [--tasks 100] [--repeats 5]

Per point world, the challenging test tasks of the protocol's draw (evaluation seed 0) on which
the shipped policy's attention phase stalls, so that the phases after a stall run (from the
goal, then the rounds). Each is planned as a user calls ``plan(problem)``, to its first
solution, once with those phases as one compiled sequence
(`temp_gym.planning.goal_tree.GoalTree.grow_from_goal_and_in_rounds`) and once driven from
Python phase by phase (``goal_tree.SEQUENCE_COMPILED = False``), alternating, so both see the
same load; both grow the same trees (tests/planning/test_goal_tree.py). Prints the best summed
time of each over the tasks, per plan, and the ratio.
"""

from __future__ import annotations

import time

from temp_gym import plan
from temp_gym.config import parse_args, script_parser
from temp_gym.evaluation.runner import evaluation_problem
from temp_gym.planning import goal_tree

ROBOTS = {"2d": "point2d", "3d": "point3d"}


def stalling_tasks(robot: str, tasks: int) -> list:
    """The first ``tasks`` challenging test tasks' problems on which the policy stalls."""
    problems = []
    for index in range(tasks):
        problem = evaluation_problem(robot, "challenging", index)
        if "from_goal_stop" in plan(problem, seed=0, stop_at_first=True).attention:
            problems.append(problem)
    return problems


def summed_time(problems: list, compiled: bool) -> float:
    """Seconds of one plan per problem, the phases after the stall compiled or not."""
    saved = goal_tree.SEQUENCE_COMPILED
    goal_tree.SEQUENCE_COMPILED = compiled
    try:
        began = time.perf_counter()
        for problem in problems:
            plan(problem, seed=0, max_nodes=10_000, stop_at_first=True)
        return time.perf_counter() - began
    finally:
        goal_tree.SEQUENCE_COMPILED = saved


def main(argv: list[str] | None = None) -> dict[str, tuple[float, float]]:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--worlds", nargs="+", choices=sorted(ROBOTS), default=["2d", "3d"],
                        help="point worlds to measure")  # fmt: skip
    parser.add_argument("--tasks", type=int, default=100, help="challenging test tasks looked at")
    parser.add_argument("--repeats", type=int, default=5, help="timed rounds per side")
    args = parse_args(parser, argv)
    if args.tasks < 1 or args.repeats < 1:
        parser.error("--tasks and --repeats must be at least 1")
    print("| world | stalled tasks | sequence ms | phases ms | sequence us/plan | "
          "phases us/plan | sequence/phases |")  # fmt: skip
    print("|---|---:|---:|---:|---:|---:|---:|")
    best = {}
    for world in args.worlds:
        problems = stalling_tasks(ROBOTS[world], args.tasks)
        if not problems:
            print(f"| {world} | 0 | | | | | |")
            continue
        sequence, phases = [], []
        for _ in range(args.repeats):
            sequence.append(summed_time(problems, True))
            phases.append(summed_time(problems, False))
        s, p = min(sequence), min(phases)
        best[world] = (s, p)
        count = len(problems)
        print(f"| {world} | {count} | {s * 1e3:.1f} | {p * 1e3:.1f} | {s / count * 1e6:.0f} | "
              f"{p / count * 1e6:.0f} | {s / p:.2f} |", flush=True)  # fmt: skip
    return best


if __name__ == "__main__":
    main()
