"""The paper's protocol on validation tasks, for several policies side by side.

    python benchmarks/cost_matched.py --world 2d [--checkpoints runs/.../best.pt@horizon=4 ...]
        [--tasks 500] [--seed-offset 30000]

Choosing a policy or a planner setting by its time to a first solution rewards short cuts
to long paths: the paper's protocol runs each baseline until its cost is within 1.05 of
TEMP's, so a policy whose first paths are longer gives the baselines an easier target. This
runs that protocol on ``--tasks`` validation tasks (the `boxes` workspaces `trainers/
tune_planner.py` draws from, with its seed plus ``--seed-offset``, so by default other tasks
than the ones tuned on; no test task), for the shipped policy and each ``--checkpoints``
entry (``PATH[@key=value,...]``, `temp_gym.models.checkpoint_settings.CHECKPOINT_SETTINGS`), as
`trainers/evaluate.py` times a task: each TEMP run after an untimed warm run and on a
workspace the planners have forgotten (`temp_gym.evaluation.runner.start_timed_run`), the
policies in alternating order. Our RRT* and Informed RRT* then run once per task, after
their warm runs, to the lowest of the policies' targets, and each policy's target is read off
the same history (`temp_gym.evaluation.protocol.reach_tolerance`), so every policy meets the
same baseline runs. Per policy: TEMP's summed and median time, its nodes and mean cost, and
the paired time ratio against each baseline (sums over the tasks every policy solved and the
baseline reached), the figure `docs/results.md` holds to 0.7. One process: the ratios are comparable
within a run, not across machines.
"""

from __future__ import annotations

import numpy as np

from temp_gym import plan, training
from temp_gym.config import load_config, parse_args, script_parser
from temp_gym.evaluation.protocol import reach_tolerance, tolerance_target
from temp_gym.evaluation.runner import EvaluationSettings, start_timed_run, warm_up_problem
from temp_gym.models.checkpoint_settings import checkpoint_entry
from temp_gym.models.registry import load_policy, policy_from_checkpoint
from temp_gym.worlds.robots import robot_specs

ROBOTS = {spec.short_name: spec.name for spec in robot_specs()}
BASELINES = ("rrt_star", "informed_rrt_star")


def compare(robot: str, problems: list, policies: dict, budget: int) -> dict[str, dict]:
    """Per policy: its TEMP runs ``(seconds, nodes, cost)`` and each baseline's seconds to
    the policy's target (NaN where not reached), over the tasks every policy solved."""
    settings = EvaluationSettings(robot=robot, groups={}, fresh_workspaces=True)
    warm = warm_up_problem(robot)
    for policy in policies.values():  # compile and load before any clock
        plan(warm, policy=policy, max_nodes=200)
    for name in BASELINES:
        plan(warm, planner=name, max_nodes=200)
    figures = {name: {"temp": [], **{b: [] for b in BASELINES}} for name in policies}
    names = list(policies)
    for index, problem in enumerate(problems):
        results = {}
        for name in names if index % 2 == 0 else names[::-1]:
            start_timed_run("temp", problem, policies[name], settings)
            results[name] = plan(problem, policy=policies[name], seed=index, max_nodes=budget,
                                 stop_at_first=True)  # fmt: skip
        if not all(result.success for result in results.values()):
            continue
        targets = {name: tolerance_target(result.cost) for name, result in results.items()}
        for name, result in results.items():
            figures[name]["temp"].append(
                (result.time_to_first_solution, result.nodes_to_first_solution, result.cost)
            )
        for baseline in BASELINES:
            start_timed_run(baseline, problem, None, settings)
            history = plan(problem, planner=baseline, seed=index, max_nodes=budget,
                           target_cost=min(targets.values())).history  # fmt: skip
            for name, target in targets.items():
                seconds = reach_tolerance(history, target)["time"]
                figures[name][baseline].append(np.nan if seconds is None else seconds)
    return figures


def main(argv: list[str] | None = None) -> None:
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--world", choices=list(ROBOTS), default="2d", help="the world")
    parser.add_argument("--checkpoints", nargs="*", default=[],
                        help="bc.py checkpoints to compare with the shipped policy, each "
                        "PATH[@noise_std=X,horizon=K,...]: any planner setting of "
                        "temp_gym.models.checkpoint_settings.CHECKPOINT_SETTINGS")  # fmt: skip
    parser.add_argument("--tasks", type=int, default=500, help="validation tasks")
    parser.add_argument(
        "--seed-offset",
        type=int,
        default=30_000,
        help="added to train_eval.seed to draw the tasks (tune_planner: 20000)",
    )
    parser.add_argument("--budget", type=int, default=10_000, help="node budget per run")
    args = parse_args(parser, argv)
    if args.tasks < 1 or args.budget < 1:
        parser.error("--tasks and --budget must be at least 1")
    robot = ROBOTS[args.world]
    config = load_config(f"configs/{args.world}.yaml", [])
    problems = training.draw_problems(
        config, "val", args.tasks, config.train_eval.seed + args.seed_offset
    )
    policies = {"shipped": load_policy(robot)}
    for entry in args.checkpoints:
        try:
            path, settings = checkpoint_entry(entry)
        except ValueError as error:
            raise SystemExit(str(error)) from None
        policies[str(path)] = policy_from_checkpoint(path, robot, **settings)
    figures = compare(robot, problems, policies, args.budget)
    solved = len(next(iter(figures.values()))["temp"])
    print(f"{args.tasks} {args.world} validation tasks, {solved} solved by every policy; "
          f"budget {args.budget} nodes\n")  # fmt: skip
    print("| policy | TEMP time sum (ms) | median (us) | nodes mean / median | cost | "
          + " | ".join(f"paired vs {b} (tasks)" for b in BASELINES) + " |")  # fmt: skip
    print("|---|---:|---:|---:|---:|" + "---:|" * len(BASELINES))
    for name, runs in figures.items():
        temp = np.array(runs["temp"], dtype=float).reshape(-1, 3)
        cells = []
        for baseline in BASELINES:
            times = np.array(runs[baseline], dtype=float)
            reached = ~np.isnan(times)
            ratio = temp[reached, 0].sum() / times[reached].sum() if reached.any() else np.nan
            cells.append(f"{ratio:.3f} ({int(reached.sum())})")
        print(f"| {name} | {temp[:, 0].sum() * 1e3:.1f} | {np.median(temp[:, 0]) * 1e6:.0f} | "
              f"{temp[:, 1].mean():.1f} / {np.median(temp[:, 1]):.0f} | {temp[:, 2].mean():.3f} | "
              + " | ".join(cells) + " |")  # fmt: skip


if __name__ == "__main__":
    main()
