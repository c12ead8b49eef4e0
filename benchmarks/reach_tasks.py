r"""Reach-into tasks for the arm: the goal has the hand enclosed by boxes, in nodes.

    python benchmarks/reach_tasks.py --config configs/7d.yaml \\
        --policy "shipped=temp_gym/checkpoints/7d.pt" [--family mixed] [--tasks 100] \\
        [--sides 3] [--budget 10000]

The arm's task generator (`temp_gym.worlds.arm_world.generate_arm_task`) draws start and
goal as uniform random free configurations, which rarely put the hand inside a compartment, a
bin or a window; the hand-made OOD scenes do (`examples/ood/7d`). This benchmark asks whether
such tasks are a regime of their own: in the ``val`` workspaces of ``--family``, it draws
tasks whose goal has the hand (link_7's origin) enclosed, a box (other than the floor) within
30 cm along at least ``--sides`` of the six axis directions, and whose start is a uniform
free configuration from which the straight motion to the goal is blocked. Start and goal keep
half the edge resolution of clearance. RRT* and every policy plan each task with the same seed
to a first
solution at ``--budget`` nodes (a failure counts as the budget); the table gives mean / median
nodes and the unsolved runs, over all tasks and over the tasks some run solved. A task no
run solves is rarely unreachable: planned from the goal, Informed RRT* solves most of them in a
few hundred nodes (`benchmarks/directions.py`, docs/research/7d.md).
"""

from __future__ import annotations

import dataclasses
import statistics

import numpy as np

from temp_gym import training
from temp_gym.config import labelled_entry, load_config, parse_args, script_parser
from temp_gym.models.policy import TEMPPolicy
from temp_gym.problem import Problem, Workspace
from temp_gym.training import plan_episode
from temp_gym.worlds.arm.model import load_arm
from temp_gym.worlds.collision.arm_fast import ArmSphereChecker
from temp_gym.worlds.robots import robot_spec
from temp_gym.worlds.splits import split_workspace

AXES = np.concatenate([np.eye(3), -np.eye(3)])
"""The six axis directions the enclosure is probed along."""
PROBE = np.linspace(0.02, 0.3, 15)
"""Distances (m) probed along each direction."""
VAL_WORKSPACES = 20
"""Validation workspaces the tasks cycle through."""


def enclosed_sides(point: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> int:
    """How many of the six axis directions meet a box within `PROBE`'s reach of ``point``."""
    probes = point + PROBE[None, :, None] * AXES[:, None, :]  # (6, k, 3)
    inside = np.all((probes[..., None, :] >= lower) & (probes[..., None, :] <= upper), axis=-1)
    return int(inside.any(axis=(1, 2)).sum())


def reach_task(
    workspace: Workspace, rng: np.random.Generator, sides: int, goal_radius: float, tries: int = 200
) -> Problem | None:
    """A task whose goal has the hand enclosed on ``sides`` sides (None: none in ``tries``)."""
    arm = load_arm(robot_spec(workspace.robot).description)
    limits = arm.joint_limits()
    lower, upper = workspace.obstacle_lower[1:], workspace.obstacle_upper[1:]  # not the floor
    checker = ArmSphereChecker(
        arm, workspace.bounds, workspace.obstacle_lower, workspace.obstacle_upper
    )
    for _ in range(tries):
        states = rng.uniform(limits[0], limits[1], size=(256, arm.dim))
        free = np.flatnonzero(checker.states_free(states, checker.resolution / 2))
        hands = arm.forward_kinematics(states[free])[:, -1, :3, 3]
        goals = [states[i] for i, hand in zip(free, hands)
                 if enclosed_sides(hand, lower, upper) >= sides]  # fmt: skip
        for goal in goals:
            for start in states[free]:
                far = np.linalg.norm(goal - start) > 2 * goal_radius
                if far and not checker.edge_free(start, goal):
                    return Problem(workspace, start, goal, goal_radius)
    return None


def main(argv: list[str] | None = None) -> dict:
    """Print the table; return ``{row: (mean, median, unsolved)}`` over the solved tasks."""
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--config", required=True, help="the arm's config (configs/7d.yaml)")
    parser.add_argument(
        "--policy", action="append", required=True, help="LABEL=CHECKPOINT, once per policy"
    )
    parser.add_argument("--family", default="mixed", help="workspace family of the val pool")
    parser.add_argument("--tasks", type=int, default=100, help="tasks drawn (some may fail)")
    parser.add_argument("--sides", type=int, default=3, help="enclosed sides of the goal's hand")
    parser.add_argument("--budget", type=int, default=10_000, help="node budget per run")
    parser.add_argument("--seed", type=int, default=77, help="seeds the task draws")
    parser.add_argument("overrides", nargs="*", help="key.sub=value config overrides")
    args = parse_args(parser, argv)
    if args.tasks < 1 or args.budget < 1 or not 1 <= args.sides <= 6:
        parser.error("--tasks and --budget must be >= 1, --sides in 1..6")
    try:
        policies = [labelled_entry(entry) for entry in args.policy]
    except ValueError as error:
        parser.error(str(error))
    config = load_config(args.config, args.overrides)
    robot = config.env.robot
    if robot != "kuka_iiwa14":
        parser.error(f"--config: reach tasks are the arm's; this config plans for {robot}")
    settings = dataclasses.replace(
        config.train_eval, max_nodes=args.budget, attention_nodes=args.budget,
        attention_patience=None, attention_uniform=0.0, noise_std=0.0,
    )  # fmt: skip
    goal_radius = robot_spec(robot).goal_radius  # the generator's
    problems = []
    for i in range(args.tasks):
        workspace = split_workspace(robot, "val", i % VAL_WORKSPACES, args.family)
        found = reach_task(workspace, np.random.default_rng([args.seed, i]), args.sides,
                           goal_radius)  # fmt: skip
        if found is not None:
            problems.append(found)
    print(f"{len(problems)} of {args.tasks} reach tasks drawn ({args.family} val, "
          f"{args.sides}+ enclosed sides)", flush=True)  # fmt: skip
    nodes = {"RRT*": training.nodes_or_budget(
        [plan_episode(p, "rrt_star", s, settings) for s, p in enumerate(problems)], args.budget
    )}  # fmt: skip
    for label, path in policies:
        policy = TEMPPolicy.from_checkpoint(path, robot=robot, noise_std=0.0)
        runs = [plan_episode(p, "temp", s, settings, policy) for s, p in enumerate(problems)]
        nodes[label] = training.nodes_or_budget(runs, args.budget)
        print(f"measured {label}", flush=True)
    table = {label: np.asarray(values, dtype=float) for label, values in nodes.items()}
    solved = np.any(np.stack(list(table.values())) < args.budget, axis=0)
    print(f"\nnodes to a first solution, mean / median, unsolved runs (budget {args.budget}); "
          f"{int(solved.sum())} tasks solved by some run\n")  # fmt: skip
    print("| planner | all tasks | tasks some run solved |")
    print("|---|---:|---:|")
    result = {}
    for label, values in table.items():
        cells = []
        for subset in (values, values[solved]):
            unsolved = int(np.sum(subset >= args.budget))
            median = statistics.median(subset) if len(subset) else float("nan")
            cells.append(f"{np.mean(subset):.1f} / {median:.0f}, {unsolved} unsolved")
        print(f"| {label} | {cells[0]} | {cells[1]} |")
        result[label] = (float(np.mean(values[solved])), float(np.median(values[solved])))
    return result


if __name__ == "__main__":
    main()
