"""Informed RRT* from the start and from the goal, on each out-of-distribution scene, in nodes.

    python benchmarks/directions.py [--worlds 2d 3d 7d] [--seeds 10] [--budget 10000]

A tree rooted at the start rarely enters a goal that lies in a pocket (a cubby, a bin, a
window); a tree rooted at the goal leaves the pocket easily. Per scene of each world's OOD
family (`temp_gym.evaluation.ood`), Informed RRT* plans to a first solution with ``--budget``
nodes from the start and, with the same seeds, the swapped task from the goal (a path of the
swapped task, reversed, is a path of the task). The table gives median / mean nodes (a
failure counts as the budget) and the unsolved runs. This is why the demonstration expert
plans failed tasks backwards (``data.expert_reverse``), and why TEMP grows a tree from the
goal once its attention phase ends unsolved (`temp_gym.planning.goal_tree`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from temp_gym import plan
from temp_gym.config import parse_args, script_parser
from temp_gym.evaluation.ood import WORLD_DIRS, load_ood_family
from temp_gym.worlds.robots import robot_specs

ROBOTS = {spec.short_name: spec.name for spec in robot_specs() if spec.name in WORLD_DIRS}


def first_solution_nodes(problem, seeds: int, budget: int) -> np.ndarray:
    """Nodes to a first solution of ``seeds`` Informed RRT* runs (the budget when unsolved)."""
    nodes = []
    for seed in range(seeds):
        result = plan(problem, planner="informed_rrt_star", seed=seed, max_nodes=budget,
                      stop_at_first=True)  # fmt: skip
        nodes.append(result.nodes_to_first_solution if result.success else budget)
    return np.asarray(nodes, dtype=float)


def cell(nodes: np.ndarray, budget: int) -> str:
    unsolved = int(np.sum(nodes >= budget))
    return f"{np.median(nodes):.0f} / {np.mean(nodes):.0f}, {unsolved} unsolved"


def main(argv: list[str] | None = None) -> dict[str, dict[str, tuple[float, float]]]:
    """Print the table; return ``{world: {scene: (median forward, median backward)}}``."""
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--worlds", nargs="+", choices=sorted(ROBOTS), default=sorted(ROBOTS),
                        help="worlds whose OOD family to plan")  # fmt: skip
    parser.add_argument("--seeds", type=int, default=10, help="seeds per scene and direction")
    parser.add_argument("--budget", type=int, default=10_000, help="node budget per run")
    args = parse_args(parser, argv)
    if args.seeds < 1 or args.budget < 1:
        parser.error("--seeds and --budget must be at least 1")
    print("| world | scene | from the start: median / mean nodes | from the goal |")
    print("|---|---|---|---|")
    medians: dict[str, dict[str, tuple[float, float]]] = {}
    for world in args.worlds:
        medians[world] = {}
        for scene, problem in load_ood_family(ROBOTS[world]).items():
            forward = first_solution_nodes(problem, args.seeds, args.budget)
            swapped = replace(problem, start=problem.goal, goal=problem.start)
            backward = first_solution_nodes(swapped, args.seeds, args.budget)
            medians[world][scene] = (float(np.median(forward)), float(np.median(backward)))
            print(f"| {world} | {scene} | {cell(forward, args.budget)} | "
                  f"{cell(backward, args.budget)} |", flush=True)  # fmt: skip
    return medians


if __name__ == "__main__":
    main()
