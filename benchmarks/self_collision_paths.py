"""Returned 7D paths in self-collision, by pybullet: every planner on the evaluation's test tasks.

    python benchmarks/self_collision_paths.py [--tasks 200] [--max-nodes 5000] [--workers 2]

Draws the 7D test tasks the evaluation uses (`temp_gym.evaluation.runner.evaluation_problem`,
difficulty ``any``, seed 0), plans each with every planner up to its first solution (or the
node budget / time limit), and hands every returned path, interpolated so that no joint moves
more than ``--max-step`` radians between checked states, to pybullet in its own DIRECT client
(`temp_gym.worlds.collision.pybullet_reference`), which checks every pair of links two or more
apart on its own shapes, independently of our checkers. Prints per planner the paths returned,
the states pybullet checked and the paths it found in self-collision (the figure
docs/research/collision.md quotes: it should be 0).
"""

from __future__ import annotations

import argparse
import functools
import importlib.util
import time

from temp_gym.config import parse_args, script_parser
from temp_gym.distributed import map_units
from temp_gym.evaluation.runner import evaluation_problem
from temp_gym.planning import plan
from temp_gym.worlds.arm.model import load_arm
from temp_gym.worlds.collision.pybullet_reference import PybulletArm, densify
from temp_gym.worlds.robots import KUKA_IIWA14

PLANNERS = ["temp", "rrt_star", "informed_rrt_star", "ompl_rrt_star", "ompl_informed_rrt_star"]


def referee_task(index: int, planners: list[str], args: argparse.Namespace) -> dict[str, tuple]:
    """Plan task ``index`` with each planner; per planner ``(solved, states, colliding, pairs)``."""
    problem = evaluation_problem(KUKA_IIWA14.name, "any", index)
    out = {}
    with PybulletArm(load_arm(KUKA_IIWA14.description)) as bullet:
        for name in planners:
            result = plan(problem, planner=name, seed=index, max_nodes=args.max_nodes,
                          time_limit=args.time_limit, stop_at_first=True)  # fmt: skip
            if not result.success:
                out[name] = (False, 0, False, [])
                continue
            states = densify(result.path, args.max_step)
            free = bullet.self_collision_free(states)
            pairs = sorted({p for s in states[~free] for p in bullet.self_collisions(s)})
            out[name] = (True, len(states), not free.all(), pairs)
    return out


def main(argv: list[str] | None = None) -> None:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--tasks", type=int, default=200, help="7D test tasks")
    parser.add_argument("--max-nodes", type=int, default=5000, help="node budget per plan")
    parser.add_argument("--time-limit", type=float, default=20.0, help="seconds per plan")
    parser.add_argument("--max-step", type=float, default=0.01, help="radians between checks")
    parser.add_argument("--workers", type=int, default=2, help="processes")
    parser.add_argument("--planners", nargs="+", default=PLANNERS, help="planners to check")
    args = parse_args(parser, argv)
    planners = [
        name
        for name in args.planners
        if not name.startswith("ompl") or importlib.util.find_spec("ompl") is not None
    ]
    started = time.perf_counter()
    unit = functools.partial(referee_task, planners=planners, args=args)
    records = dict(map_units(unit, list(range(args.tasks)), workers=args.workers))
    print(
        f"\n## {args.tasks} 7D test tasks, up to the first solution ({args.max_nodes} nodes, "
        f"{args.time_limit} s), pybullet every {args.max_step} rad "
        f"({time.perf_counter() - started:.0f} s)"
    )
    print("| planner | paths returned | states checked | paths in self-collision | pairs |")
    print("|---|---:|---:|---:|---|")
    for name in planners:
        rows = [records[i][name] for i in range(args.tasks)]
        pairs = sorted({p for row in rows for p in row[3]})
        print(
            f"| {name} | {sum(r[0] for r in rows)} | {sum(r[1] for r in rows):,} | "
            f"{sum(r[2] for r in rows)} | {', '.join('-'.join(p) for p in pairs) or '-'} |"
        )


if __name__ == "__main__":
    main()
