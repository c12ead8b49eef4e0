"""``temp-plan``: solve one problem file from the command line.

Example:
    $ temp-plan problem.json                  # TEMP with the shipped policy for the robot
    $ temp-plan problem.json --planner informed_rrt_star --seed 3 --max-nodes 2000 --out r.json
    informed_rrt_star seed=3: cost 26.8120, 2000 nodes, ...
    $ temp-plan problem.json --checkpoint runs/TEMP-2D-v0__bc__0/best.pt   # your own policy

Exit status: 0 when a path was found, 1 when none was, 2 for bad input (a one-line error on
stderr, no traceback).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path


def _parser() -> argparse.ArgumentParser:
    from temp_gym.planning import PLANNERS

    parser = argparse.ArgumentParser(
        prog="temp-plan", description="Solve a temp-gym problem JSON file with one planner."
    )
    parser.add_argument("problem", help="problem JSON file (see temp_gym.problem)")
    parser.add_argument(
        "--planner", default="temp", choices=sorted(PLANNERS), help="default: temp (TEMP)"
    )
    parser.add_argument(
        "--checkpoint", default=None, help="temp: a trained policy (default: the shipped one)"
    )
    parser.add_argument(
        "--attention-nodes",
        type=int,
        default=None,
        help="temp: attention-phase budget n (default: the policy's)",
    )
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--time-limit", type=float, default=None, help="seconds (default none)")
    parser.add_argument("--max-nodes", type=int, default=5000, help="tree-size budget")
    parser.add_argument("--step-size", type=float, default=None, help="steering step")
    parser.add_argument("--stop-at-first", action="store_true", help="stop at the first solution")
    parser.add_argument("--out", default=None, help="write the result (path included) as JSON")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    from temp_gym.planning import plan
    from temp_gym.problem import Problem

    args = _parser().parse_args(argv)
    try:
        problem = Problem.load(args.problem)
        extra = {}
        if args.planner == "temp":
            extra["attention_nodes"] = args.attention_nodes
            if args.checkpoint is not None:
                from temp_gym.models.policy import TEMPPolicy

                extra["policy"] = TEMPPolicy.from_checkpoint(args.checkpoint, robot=problem.robot)
        elif args.checkpoint is not None or args.attention_nodes is not None:
            raise ValueError("--checkpoint and --attention-nodes apply to --planner temp only")
        result = plan(
            problem,
            planner=args.planner,
            seed=args.seed,
            max_nodes=args.max_nodes,
            time_limit=args.time_limit,
            stop_at_first=args.stop_at_first,
            step_size=args.step_size,
            **extra,
        )
        if args.out is not None:
            Path(args.out).write_text(json.dumps(result.to_dict()) + "\n")
    except (OSError, ValueError, ImportError) as error:
        print(f"temp-plan: error: {error}", file=sys.stderr)
        return 2
    print(result.summary())
    return 0 if result.success else 1


if __name__ == "__main__":
    sys.exit(main())
