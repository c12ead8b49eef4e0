"""Benchmark: our RRT* / Informed RRT* / RRT-Connect against OMPL's, on generated problems.

One run per (problem, planner), all planners on the same problems and the same fast checker.
Reports, per world and planner: success, time and nodes to the first solution, mean cost at
fixed node budgets (over the problems every planner had solved by that budget; RRT-Connect's is
its one solution, which it does not improve), wall time per node, and our/OMPL ratios.

    python benchmarks/planners.py --worlds 2d 3d --problems 20 --budgets 500 1000 2000
"""

from __future__ import annotations

import math
import time

import numpy as np

from temp_gym.config import parse_args, script_parser
from temp_gym.planning import plan
from temp_gym.worlds.robots import robot_specs

ROBOTS = {spec.short_name: spec.name for spec in robot_specs()}
PAIRS = [("rrt_star", "ompl_rrt_star"), ("informed_rrt_star", "ompl_informed_rrt_star"),
         ("rrt_connect", "ompl_rrt_connect")]  # fmt: skip


def make_problems(world: str, count: int, seed: int):
    from temp_gym.worlds.generators import generate_problem

    rng = np.random.default_rng(seed)
    return [generate_problem(ROBOTS[world], rng) for _ in range(count)]


def run_world(world, problems, planners, budgets, step_size):
    runs = {name: [] for name in planners}
    for i, problem in enumerate(problems):
        for name in planners:
            runs[name].append(
                plan(problem, planner=name, seed=i, max_nodes=max(budgets), step_size=step_size)
            )
    return runs


def mean(values):
    values = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.mean(values)) if values else math.nan


def report(world, runs, budgets):
    names = list(runs)
    count = len(next(iter(runs.values())))
    print(f"\n## {world}: {count} problems, budgets {budgets}")
    header = ["planner", "solved", "t_first ms", "n_first"]
    header += [f"cost@{b}" for b in budgets] + ["us/node"]
    rows = []
    common = {}
    for b in budgets:
        solved_by_all = [
            i for i in range(count) if all(math.isfinite(runs[n][i].cost_at(b)) for n in names)
        ]
        common[b] = solved_by_all
    stats = {}
    for name in names:
        results = runs[name]
        # total time over total nodes: a walled-in start (1 node, many samples) cannot dominate
        per_node = 1e6 * sum(r.wall_time for r in results) / sum(r.nodes for r in results)
        costs = [mean([results[i].cost_at(b) for i in common[b]]) for b in budgets]
        stats[name] = (costs, per_node)
        rows.append(
            [
                name,
                f"{sum(r.success for r in results)}/{count}",
                f"{1e3 * mean([r.time_to_first_solution for r in results]):.1f}",
                f"{mean([r.nodes_to_first_solution for r in results]):.0f}",
            ]
            + [f"{c:.3f}" for c in costs]
            + [f"{per_node:.1f}"]
        )
    rows.append(["(common solved)", "", "", ""] + [str(len(common[b])) for b in budgets] + [""])
    for ours, ompl in PAIRS:
        if ours in stats and ompl in stats:
            (c1, t1), (c2, t2) = stats[ours], stats[ompl]
            rows.append(
                [f"ratio {ours}/{ompl}", "", "", ""]
                + [f"{a / b:.3f}" for a, b in zip(c1, c2)]
                + [f"{t1 / t2:.2f}"]
            )
    widths = [max(len(str(x)) for x in col) for col in zip(header, *rows)]
    print("| " + " | ".join(h.ljust(w) for h, w in zip(header, widths)) + " |")
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for row in rows:
        print("| " + " | ".join(str(x).ljust(w) for x, w in zip(row, widths)) + " |")


def main(argv: list[str] | None = None) -> None:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument(
        "--worlds",
        nargs="+",
        default=["2d", "3d", "7d"],
        choices=list(ROBOTS),
        help="worlds to measure",
    )
    parser.add_argument("--problems", type=int, default=20, help="generated problems per world")
    parser.add_argument(
        "--budgets",
        type=int,
        nargs="+",
        default=[500, 1000, 2000],
        help="node budgets at which costs are compared",
    )
    parser.add_argument(
        "--planners",
        nargs="+",
        default=[p for pair in PAIRS for p in pair],
        help="planners to run",
    )
    parser.add_argument(
        "--step-size", type=float, default=None, help="steering step (None: the default)"
    )
    parser.add_argument("--seed", type=int, default=2024, help="problem-generation seed")
    args = parse_args(parser, argv)
    budgets = sorted(args.budgets)
    for world in args.worlds:
        problems = make_problems(world, args.problems, args.seed)
        plan(problems[0], "rrt_star", max_nodes=50)  # compile and warm up outside the timings
        started = time.perf_counter()
        runs = run_world(world, problems, args.planners, budgets, args.step_size)
        report(world, runs, budgets)
        print(f"({time.perf_counter() - started:.1f} s)")


if __name__ == "__main__":
    main()
