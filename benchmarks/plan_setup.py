"""A plan's fixed cost: TEMP against RRT* and Informed RRT* on problems of one motion.

    python benchmarks/plan_setup.py [--worlds 2d 3d 7d] [--problems 50] [--repeats 5]

Per world, the first ``--problems`` easy test tasks of the protocol's draw (evaluation seed
0), each with its goal moved onto the second node of its RRT* path (one tree edge from the
start: a straight free motion), so that what is timed is what every plan pays before and
around its first nodes: the tree, the generator, and for TEMP the policy's reset to the
problem (the workspace's encoding and the task's MPT prefix) and the attention phase's set-up.
Before each plan the workspace is forgotten (the tree's per-workspace caches and the policy's
encoding), as the paper's protocol does
(`temp_gym.evaluation.runner.EvaluationSettings.fresh_workspaces`), and the time read is the
planner's own time to its first solution, the protocol's figure. The planners alternate round
by round, so they see the same machine load.

Prints, per world and planner, the median plan over all rounds and the best round's mean, in
microseconds, TEMP's ratio to each baseline, and TEMP's policy reset alone on a new workspace.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

import temp_gym
from temp_gym import plan
from temp_gym.config import parse_args, script_parser
from temp_gym.evaluation.runner import evaluation_problem
from temp_gym.planning.tree import forget_workspace

ROBOTS = {"2d": "point2d", "3d": "point3d", "7d": "kuka_iiwa14"}
PLANNERS = ("temp", "rrt_star", "informed_rrt_star")


def one_motion_problems(robot: str, count: int) -> list:
    """Easy test tasks with the goal moved to the node after the start on their RRT* path."""
    problems = []
    index = 0
    while len(problems) < count and index < 10 * count:
        problem = evaluation_problem(robot, "easy", index)
        index += 1
        path = plan(problem, planner="rrt_star", seed=0, max_nodes=2000, stop_at_first=True).path
        if path is None or len(path) < 2:
            continue
        problems.append(dataclasses.replace(problem, goal=np.array(path[1], dtype=np.float64)))
    return problems


def plan_times(problems: list, planner: str, policy) -> np.ndarray:
    """Seconds to the first solution of each problem, on a workspace forgotten just before."""
    times = np.empty(len(problems))
    options = {"policy": policy} if planner == "temp" else {}
    for i, problem in enumerate(problems):
        forget_workspace(problem.workspace)
        if planner == "temp":
            policy.forget_workspace(problem.workspace)
        result = plan(problem, planner=planner, seed=0, stop_at_first=True, **options)
        times[i] = result.time_to_first_solution
    return times


def reset_times(problems: list, policy) -> np.ndarray:
    """Seconds of the policy's reset to each problem, on a workspace forgotten just before."""
    times = np.empty(len(problems))
    for i, problem in enumerate(problems):
        policy.forget_workspace(problem.workspace)
        began = time.perf_counter()
        policy.reset(problem, seed=0)
        times[i] = time.perf_counter() - began
    return times


def main(argv: list[str] | None = None) -> dict[str, dict[str, float]]:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--worlds", nargs="+", choices=sorted(ROBOTS), default=["2d", "3d"],
                        help="worlds to measure (7d needs pybullet)")  # fmt: skip
    parser.add_argument("--problems", type=int, default=50, help="one-motion problems per world")
    parser.add_argument("--repeats", type=int, default=5, help="timed rounds per planner")
    args = parse_args(parser, argv)
    if args.problems < 1 or args.repeats < 1:
        parser.error("--problems and --repeats must be at least 1")
    print("| world | problems | planner | median us | best round's mean us | TEMP / planner |")
    print("|---|---:|---|---:|---:|---:|")
    medians: dict[str, dict[str, float]] = {}
    for world in args.worlds:
        robot = ROBOTS[world]
        policy = temp_gym.load_policy(robot)
        problems = one_motion_problems(robot, args.problems)
        for planner in PLANNERS:  # untimed: kernels loaded, the policy warm
            plan_times(problems[:2], planner, policy)
        times: dict[str, list[np.ndarray]] = {planner: [] for planner in PLANNERS}
        resets = []
        for _ in range(args.repeats):
            for planner in PLANNERS:
                times[planner].append(plan_times(problems, planner, policy))
            resets.append(reset_times(problems, policy))
        medians[world] = {name: float(np.median(np.concatenate(t))) for name, t in times.items()}
        for name in PLANNERS:
            median = medians[world][name]
            best = min(float(np.mean(t)) for t in times[name])
            ratio = medians[world]["temp"] / median
            print(f"| {world} | {len(problems)} | {name} | {median * 1e6:.0f} | "
                  f"{best * 1e6:.0f} | {ratio:.2f} |", flush=True)  # fmt: skip
        medians[world]["reset"] = float(np.median(np.concatenate(resets)))
        print(f"| {world} | {len(problems)} | TEMP's policy reset alone | "
              f"{medians[world]['reset'] * 1e6:.0f} | | |", flush=True)  # fmt: skip
    return medians


if __name__ == "__main__":
    main()
