"""TEMP's attention phase per node: the policy fast path against whole observations, and RRT*.

    python benchmarks/temp_planner.py [--worlds 2d 3d 7d] [--problems 30] [--repeats 3]

The ``temp`` planner hands a `TEMPPolicy` only the path so far (`TEMPPolicy.propose` on
`TreeObserver.path_so_far`); any other policy gets a whole observation per step. Both give the
same trees (tested in ``tests/planning/test_temp_planner.py``), so the difference is the
per-step glue: building the observation dict, checking it, and the action round trip. Per
world, on the same generated problems with the shipped policy and the same seeds: attention-
phase time per node for each path and their ratio (fast / observations), how much of a fast
node is the policy call (the MPT), and RRT*'s time per node up to its first solution on the
same problems, which is what a TEMP node competes with. Best of ``--repeats`` per problem, the
runs interleaved, so all see the same machine load.
"""

from __future__ import annotations

import time

import numpy as np
import torch

from temp_gym import plan
from temp_gym.config import parse_args, script_parser
from temp_gym.models.registry import load_policy
from temp_gym.worlds.generators import generate_problem
from temp_gym.worlds.robots import robot_specs

ROBOTS = {spec.short_name: spec.name for spec in robot_specs()}


class ObservationOnly:
    """A policy seen through ``__call__`` alone (the planner's generic path); calls are timed.

    ``seconds`` and ``calls`` add up the policy's calls; ``model`` is passed through, since the
    planner reads the encoding resolution and L off it.
    """

    def __init__(self, policy) -> None:
        self.policy = policy
        self.model = policy.model
        self.seconds = 0.0
        self.calls = 0

    def reset(self, problem, seed=None) -> None:
        self.policy.reset(problem, seed=seed)

    def _timed(self, function, *args):
        began = time.perf_counter()
        result = function(*args)
        self.seconds += time.perf_counter() - began
        self.calls += 1
        return result

    def __call__(self, observation):
        return self._timed(self.policy, observation)


class TimedPolicy(ObservationOnly):
    """`ObservationOnly` plus ``propose``: the planner's fast path, timed the same way."""

    def propose(self, path, length):
        return self._timed(self.policy.propose, path, length)


def attention_time(problem, policy, seed: int, max_nodes: int) -> tuple[float, int]:
    """Seconds and nodes of the attention phase, up to the first solution."""
    result = plan(
        problem, planner="temp", policy=policy, seed=seed, max_nodes=max_nodes, stop_at_first=True
    )
    return result.attention["time"], result.attention["nodes"]


def rrt_star_time(problem, seed: int, max_nodes: int) -> tuple[float, int]:
    """Seconds and nodes of RRT* up to its first solution (or the budget)."""
    result = plan(problem, planner="rrt_star", seed=seed, max_nodes=max_nodes, stop_at_first=True)
    return result.time_to_first_solution or result.wall_time, result.nodes


def main(argv: list[str] | None = None) -> None:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument(
        "--worlds",
        nargs="+",
        default=list(ROBOTS),
        choices=list(ROBOTS),
        help="robots to measure",
    )
    parser.add_argument("--problems", type=int, default=30, help="generated problems per world")
    parser.add_argument("--repeats", type=int, default=3, help="timing rounds per problem")
    parser.add_argument("--max-nodes", type=int, default=3000, help="node budget per plan")
    args = parse_args(parser, argv)
    torch.set_num_threads(1)  # the per-sample latency a planner sees
    print(
        "| world | problems | nodes | fast path (us/node) | of which the MPT call "
        "| observations (us/node) | ratio | RRT* (us/node) |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for world in args.worlds:
        robot = ROBOTS[world]
        rng = np.random.default_rng(0)
        problems = [generate_problem(robot, rng) for _ in range(args.problems)]
        fast = TimedPolicy(load_policy(robot))
        slow = ObservationOnly(load_policy(robot))
        attention_time(problems[0], fast, 0, 20)  # compile and warm up, untimed
        attention_time(problems[0], slow, 0, 20)
        rrt_star_time(problems[0], 0, 20)
        totals = {"fast": 0.0, "slow": 0.0, "mpt": 0.0, "rrt": 0.0}
        nodes = rrt_nodes = 0
        for seed, problem in enumerate(problems):
            best = {name: np.inf for name in totals}
            for _ in range(args.repeats):
                for name, policy in (("fast", fast), ("slow", slow)):
                    fast.seconds = 0.0
                    seconds, count = attention_time(problem, policy, seed, args.max_nodes)
                    if name == "fast" and seconds < best["fast"]:
                        best["mpt"] = fast.seconds
                    best[name] = min(best[name], seconds)
                seconds, rrt_count = rrt_star_time(problem, seed, args.max_nodes)
                best["rrt"] = min(best["rrt"], seconds)
            nodes += count
            rrt_nodes += rrt_count
            for name in totals:
                totals[name] += best[name]
        fast_us, slow_us, mpt_us = (totals[name] / nodes * 1e6 for name in ("fast", "slow", "mpt"))
        print(
            f"| {world} | {len(problems)} | {nodes} | {fast_us:.1f} | {mpt_us:.1f} | "
            f"{slow_us:.1f} | {fast_us / slow_us:.2f} | {totals['rrt'] / rrt_nodes * 1e6:.1f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
