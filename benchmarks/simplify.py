"""How much shorter path simplification makes arm paths, and what it costs, per planner.

    python benchmarks/simplify.py [--tasks 60] [--planners temp rrt_connect]
    python benchmarks/simplify.py --mbm problems.tar.bz2 [--per-scene 10]

Plans ``--tasks`` 7D validation tasks of ``configs/7d.yaml`` (or, with ``--mbm``, the first
``--per-scene`` valid problems of each MotionBenchMaker scene; `benchmarks/certification.py`
picks them the same way) with each planner up to its first solution, with
``plan(..., simplify=True)`` (`temp_gym.planning.simplify`), and reports per planner the median
path cost before and after, the median ratio of the two, the waypoints before and after, and
the median seconds simplification took (its certification by the exact checker included) beside
the median whole call.
"""

from __future__ import annotations

import statistics

from certification import chosen_problems  # benchmarks/certification.py

from temp_gym import plan
from temp_gym.config import parse_args, script_parser

PLANNERS = ("temp", "rrt_connect")


def main(argv: list[str] | None = None) -> dict[str, dict[str, float]]:
    """Run the benchmark; returns per planner its paths and median costs, ratio and times."""
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--tasks", type=int, default=60, help="7D validation tasks")
    parser.add_argument("--max-nodes", type=int, default=10_000, help="node budget per plan")
    parser.add_argument("--mbm", default=None, help="MotionBenchMaker's archive, instead")
    parser.add_argument("--per-scene", type=int, default=10, help="--mbm: problems per scene")
    parser.add_argument("--planners", nargs="+", default=list(PLANNERS), help="planners")
    args = parse_args(parser, argv)
    problems = chosen_problems(args.mbm, args.per_scene, args.tasks)
    for planner in args.planners:  # load kernels and the policy
        plan(problems[0], planner=planner, seed=0, max_nodes=50, simplify=True)
    rows: dict[str, list[dict[str, float]]] = {planner: [] for planner in args.planners}
    for seed, problem in enumerate(problems):
        for planner in args.planners:
            result = plan(problem, planner=planner, seed=seed, max_nodes=args.max_nodes,
                          stop_at_first=True, simplify=True)  # fmt: skip
            if result.success:
                before = result.simplification
                rows[planner].append({
                    "before": before["cost"], "after": result.cost,
                    "ratio": result.cost / before["cost"] if before["cost"] > 0 else 1.0,
                    "waypoints_before": before["waypoints"], "waypoints": len(result.path),
                    "time": before["time"], "call": result.wall_time,
                })  # fmt: skip
    print(f"{len(problems)} problems, first solutions, plan(..., simplify=True)\n")
    print(
        "| planner | paths | cost before / after (median) | after / before (median) | "
        "waypoints before / after (median) | simplification / whole call (median s) |"
    )
    print("|---|---:|---:|---:|---:|---:|")  # fmt: skip
    table = {}
    for planner, runs in rows.items():
        if not runs:
            continue
        median = {key: statistics.median(run[key] for run in runs) for key in runs[0]}
        m = median
        print(f"| {planner} | {len(runs)} | {m['before']:.2f} / {m['after']:.2f} | "
              f"{m['ratio']:.3f} | {m['waypoints_before']:g} / {m['waypoints']:g} | "
              f"{m['time']:.3f} / {m['call']:.3f} |")  # fmt: skip
        table[planner] = {"paths": len(runs), **median}
    return table


if __name__ == "__main__":
    main()
