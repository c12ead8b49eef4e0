r"""Choose a policy's planner settings on validation workspaces: budget n, noise, horizon.

    python trainers/tune_planner.py --config configs/2d.yaml --checkpoint runs/.../best.pt \\
        --attention-nodes 50 100 200 400 --noise-std 0 0.03 --horizon 1 2 4 --tasks 60 \\
        [--max-nodes 10000]

For every combination of n, noise, horizon (proposals used per MPT call, up to the model's chunk;
0: all), path window (``--path-window``: the newest nodes of the path so far each MPT call reads;
0: all the model was trained on), stall patience (``--patience``; -1: the default rule), its factor
near the goal (``--near-goal-factor``), share of uniform samples (``--uniform``) and probability of
going on from a fallback node (``--follow-fallback``), replacements of a colliding proposal drawn
near it (``--local-fallback``), whether a chunk goes on past a proposal that
collided (``--keep-chunk``), the resume factor (``--resume``) and the growth of the classical turns
between resumed phases (``--resume-growth``), whether a tree grows from the goal after an unsolved
attention phase (``--goal-tree``), whether the policy grows that tree first after a stall
(``--from-goal``: the attention phase from the goal) and how many more rounds of the two it takes
when both stall (``--rounds``) it plans ``--tasks`` tasks drawn from the ``val`` workspaces, or
from the 100 of the planner-tuning pool (``--split tune``, which estimates a failure rate of half a
percent better than val's 20 workspaces; both seen in no test; the test workspaces stay untouched
until the final measurement, ``--split test`` with the chosen setting) with the ``temp`` planner up
to the first solution, and prints nodes to the first solution (mean and median, a failure counted
as the whole budget), the share solved by attention-based planning within n (from the start alone,
and both ways: from the start, or from the goal after a stall, or in a later round), cost and time;
and, against RRT* on the same tasks, the share of tasks where TEMP needed fewer nodes and the mean
difference with its 95% paired bootstrap interval. The recommendation minimizes the mean nodes
among the settings whose attention phase solves at least ``--min-attention-success`` of the tasks
(both ways); ``trainers/ship.py --attention-nodes ... --noise-std ...`` then ships it.

Every run, RRT*'s included, has the node budget ``--max-nodes`` (default: the config's
``train_eval.max_nodes``), printed with the table; an n above it is refused rather than
quietly cut to it. ``--no-rrt`` leaves RRT* out (its columns print ``-``), for comparing
policies with each other: ``--per-task FILE`` writes every run's figures task by task, which
``trainers/compare_policies.py`` pairs across policies.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import sys
from pathlib import Path

from temp_gym.config import (
    ConfigError,
    count,
    load_config,
    number,
    parse_args,
    script_parser,
)
from temp_gym.jobs import run_script
from temp_gym.limits import MAX_TASKS

PER_TASK_KEYS = ("max_nodes", "seeds", "problems", "settings")
"""Keys of a ``--per-task`` file: an existing file is replaced only if it has them."""

RESUME_AFTER_DEFAULT = 1.0
"""`temp_gym.planning.attention.RESUME_AFTER`, for the help text alone (reading it would load
numba on every ``--help``; a test keeps both equal)."""


def main(argv: list[str] | None = None) -> dict:
    """Print the table; return the recommended ``{"attention_nodes", "noise_std"}``."""
    parser = script_parser(
        __doc__.splitlines()[0],
        epilog="Output: the table on stdout; with --per-task, that JSON file too.",
    )
    parser.add_argument("--config", required=True, help="the config the policy was trained with")
    parser.add_argument("--checkpoint", required=True, help="the policy (a bc.py best.pt)")
    parser.add_argument(
        "--attention-nodes",
        type=count(1),
        nargs="+",
        default=[50, 100, 200, 400],
        help="attention-phase budgets n to try, in tree nodes",
    )
    parser.add_argument(
        "--noise-std",
        type=number(0.0),
        nargs="+",
        default=[0.0, 0.03],
        help="output noise levels to try (standard deviations, normalized units)",
    )
    parser.add_argument(
        "--max-nodes",
        type=count(1),
        default=None,
        help="node budget of every run, RRT*'s included (None: train_eval.max_nodes of the "
        "config); each n must fit in it",
    )
    parser.add_argument("--tasks", type=count(1, MAX_TASKS), default=60, help="tasks per setting")
    parser.add_argument(
        "--split",
        default="val",
        choices=["val", "tune", "test", "ood"],
        help="tune: the planner-tuning pool (100 workspaces; temp_gym.worlds.splits); test: the "
        "final measurement; ood: the out-of-distribution family, --tasks runs spread over its "
        "problems and seeds",
    )
    parser.add_argument(
        "--horizon",
        type=count(0),
        nargs="+",
        default=[0],
        help="proposals used per MPT call to try (0: the model's whole chunk)",
    )
    parser.add_argument(
        "--path-window",
        type=count(0),
        nargs="+",
        default=[0],
        help="newest path-so-far nodes read per MPT call to try (0: all the model was trained on)",
    )
    parser.add_argument(
        "--patience",
        type=count(-1),
        nargs="+",
        default=[-1],
        help="attention-phase stall patience to try (-1: the default rule)",
    )
    parser.add_argument(
        "--uniform",
        type=number(0.0, 1.0),
        nargs="+",
        default=[0.0],
        help="shares of uniform samples in the attention phase to try",
    )
    parser.add_argument(
        "--near-goal-factor",
        type=number(1.0),
        nargs="+",
        default=[1.0],
        help="stall-patience factors near the goal to try (1: the same patience everywhere)",
    )
    parser.add_argument(
        "--follow-fallback",
        type=number(0.0, 1.0),
        nargs="+",
        default=[1.0],
        help="probabilities of going on from a fallback node that got no closer to the goal to "
        "try (1: always, Algorithm 1)",
    )
    parser.add_argument(
        "--local-fallback",
        type=count(0),
        nargs="+",
        default=[0],
        help="replacements of a colliding proposal drawn near it before uniform ones, to try "
        "(0: none, Algorithm 1)",
    )
    parser.add_argument(
        "--keep-chunk",
        type=int,
        nargs="+",
        choices=[0, 1],
        default=[0],
        help="after a chunk's proposal collided and a fallback node replaced it: go on with "
        "the chunk (1) or call the policy again (0), to try",
    )
    parser.add_argument(
        "--resume",
        type=number(0.0),
        nargs="+",
        default=[RESUME_AFTER_DEFAULT],
        help="classical nodes, in stall patiences, before the attention phase resumes after a "
        "stall, to try (0: never)",
    )
    parser.add_argument(
        "--resume-growth",
        type=number(1.0),
        nargs="+",
        default=[1.0],
        help="how many times longer each classical turn between resumed attention phases is "
        "than the one before, to try (1: equal turns)",
    )
    parser.add_argument(
        "--goal-tree",
        type=int,
        nargs="+",
        choices=[0, 1],
        default=[1],
        help="grow a tree from the goal after an unsolved attention phase (1, the planner's "
        "default) or not (0), to try",
    )
    parser.add_argument(
        "--from-goal",
        type=int,
        nargs="+",
        choices=[0, 1],
        default=[1],
        help="after a stall, the policy grows the goal tree first (1, the planner's default) or "
        "Informed RRT*'s samples alone (0), to try; needs --goal-tree 1",
    )
    parser.add_argument(
        "--rounds",
        type=count(-1),
        nargs="+",
        default=[-1],
        help="after stalls from the start and from the goal, more rounds of the two (-1: the "
        "planner's default; 0: none), to try; with --from-goal 1",
    )
    parser.add_argument(
        "--family",
        default="boxes",
        help="workspace family of the val and test tasks (temp_gym.worlds.structured; the "
        "paper's protocol: boxes); data.workspace_family, the training data's, does not set it",
    )
    parser.add_argument(
        "--min-attention-success",
        type=number(0.0, 1.0),
        default=0.9,
        help="least share of tasks the attention phase must solve (both ways) to be recommended",
    )
    parser.add_argument(
        "--no-rrt",
        action="store_true",
        help="leave RRT* out (its columns print -): for comparing policies with each other",
    )
    parser.add_argument(
        "--per-task",
        default=None,
        help="write every run's figures task by task to this JSON file "
        "(trainers/compare_policies.py pairs two such files)",
    )
    parser.add_argument("overrides", nargs="*", help="key.sub=value config overrides")
    args = parse_args(parser, argv)
    config = load_config(args.config, args.overrides)
    eval_config = config.train_eval
    budget_from = "train_eval.max_nodes"
    if args.max_nodes is not None:
        eval_config = dataclasses.replace(eval_config, max_nodes=args.max_nodes)
        budget_from = "--max-nodes"
    if eval_config.max_nodes < 1:
        parser.error(f"{budget_from}: must be at least 1, got {eval_config.max_nodes}")
    too_large = [n for n in args.attention_nodes if n > eval_config.max_nodes]
    if too_large:  # n beyond the budget would silently mean n = budget
        parser.error(
            f"--attention-nodes {too_large[0]} exceeds the node budget {eval_config.max_nodes} "
            f"({budget_from}); pass a larger --max-nodes"
        )
    if args.per_task is not None:
        check_per_task_file(Path(args.per_task), [Path(args.config), Path(args.checkpoint)])
    import numpy as np
    import torch

    from temp_gym import training
    from temp_gym.evaluation.ood import load_ood_family
    from temp_gym.files import write_json_atomic
    from temp_gym.models.policy import TEMPPolicy
    from temp_gym.models.temp import load_checkpoint
    from temp_gym.planning.result import (
        local_fallback_count,
        near_goal_factor,
        resume_factor,
        resume_growth,
        share,
    )
    from temp_gym.training import plan_episode
    from temp_gym.worlds.structured import check_family

    try:  # the planner's own check, naming the flag
        for factor in args.near_goal_factor:
            near_goal_factor(factor, "--near-goal-factor")
        for follow in args.follow_fallback:
            share(follow, "--follow-fallback")
        for tries in args.local_fallback:
            local_fallback_count(tries, "--local-fallback")
        for resume in args.resume:
            resume_factor(resume, "--resume")
        for growth in args.resume_growth:
            resume_growth(growth, "--resume-growth")
        check_family(config.env.robot, args.family)
    except ValueError as error:
        parser.error(str(error))
    torch.set_num_threads(1)
    try:
        model, _ = load_checkpoint(args.checkpoint, robot=config.env.robot)
    except (OSError, ValueError) as error:
        raise ConfigError(f"--checkpoint: {error}") from None
    windows = [window or None for window in args.path_window]  # 0: the whole path
    for window in windows:  # the policy's own check, naming the flag, before any run
        try:
            TEMPPolicy(model, path_window=window)
        except ValueError as error:
            parser.error(f"--path-window: {error}")
    if args.split == "ood":
        family = list(load_ood_family(config.env.robot).values())
        problems = [family[index % len(family)] for index in range(args.tasks)]
    else:
        problems = training.draw_problems(
            config, args.split, args.tasks, eval_config.seed + 20_000, workspace_family=args.family
        )
    seeds = [eval_config.seed + index for index in range(len(problems))]
    rrt_runs = None
    baseline = "RRT*: not run (--no-rrt)"
    if not args.no_rrt:
        rrt_runs = [plan_episode(p, "rrt_star", s, eval_config) for p, s in zip(problems, seeds)]
        rrt = training.summarize(rrt_runs, eval_config.max_nodes)
        baseline = (
            f"RRT*: nodes mean {rrt['nodes_mean']:.1f} median {rrt['nodes_median']:.0f}, "
            f"cost {rrt['cost']:.2f}, time {rrt['time'] * 1e3:.1f} ms"
        )
    print(
        f"{len(problems)} {args.split} tasks ({'OOD' if args.split == 'ood' else args.family}), "
        f"budget {eval_config.max_nodes} nodes per run; {baseline}"
    )
    per_task = {
        "config": args.config,
        "checkpoint": args.checkpoint,
        "split": args.split,
        "family": "OOD" if args.split == "ood" else args.family,
        "max_nodes": eval_config.max_nodes,
        "seeds": seeds,
        "problems": [_digest(problem) for problem in problems],
        "rrt_star": None if rrt_runs is None else _task_figures(rrt_runs),
        "settings": [],
    }
    print(
        "| n | noise | horizon | window | patience | near goal | uniform | follow | local "
        "| keep chunk | resume | growth | goal tree | from goal | rounds "
        "| nodes mean "
        "| median "
        "| AP solved | AP both ways | success | cost | time (ms) | fewer than RRT* "
        "| mean difference [95% CI] |"
    )
    print(
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:"
        "|---:|---:|---:|---:|---|"
    )
    best, best_nodes = None, np.inf
    settings = itertools.product(
        args.attention_nodes, args.noise_std, args.horizon, windows, args.patience,
        args.near_goal_factor, args.uniform, args.follow_fallback, args.local_fallback,
        args.keep_chunk, args.resume, args.resume_growth, args.goal_tree, args.from_goal,
        args.rounds,
    )  # fmt: skip
    for (
        budget, noise, horizon, window, patience, factor, uniform, follow, local, keep, resume,
        growth, goal, from_goal, rounds,
    ) in settings:  # fmt: skip
        if resume == 0 and growth != args.resume_growth[0]:
            continue  # without resumed phases --resume-growth changes nothing: one row
        if not goal and from_goal != args.from_goal[0]:
            continue  # without the goal tree --from-goal changes nothing: one row
        from_goal = bool(goal and from_goal)
        if not from_goal and rounds != args.rounds[0]:
            continue  # without the phase from the goal --rounds changes nothing: one row
        rounds = (None if rounds < 0 else rounds) if from_goal else 0
        eval_config = dataclasses.replace(
            eval_config,
            attention_nodes=budget,
            attention_patience=None if patience < 0 else patience,
            attention_uniform=uniform,
            attention_near_goal_factor=factor,
            attention_follow_fallback=follow,
            attention_local_fallback=local,
            attention_keep_chunk=bool(keep),
            attention_resume=resume,
            attention_resume_growth=growth,
            goal_tree=bool(goal),
            attention_from_goal=from_goal,
            attention_rounds=rounds,
        )
        policy = TEMPPolicy(
            model,
            noise_std=noise,
            horizon=horizon or None,
            path_window=window,
        )
        runs = [plan_episode(p, "temp", s, eval_config, policy) for p, s in zip(problems, seeds)]
        row = training.summarize(runs, eval_config.max_nodes)
        solved = float(np.mean([run["attention_solved"] for run in runs]))
        both_ways = float(np.mean([run["attention_solved_both_ways"] for run in runs]))
        if rrt_runs is None:
            versus_rrt = "- | -"
        else:
            paired = training.paired_nodes(runs, rrt_runs, eval_config.max_nodes)
            versus_rrt = (
                f"{paired['fewer']:.2f} | {paired['difference']:+.1f} "
                f"[{paired['low']:+.1f}, {paired['high']:+.1f}]"
            )
        setting = {"attention_nodes": budget, "noise_std": noise, "horizon": policy.chunk,
                   "path_window": policy.path_window,
                   "attention_patience": eval_config.attention_patience,
                   "attention_uniform": uniform, "attention_near_goal_factor": factor,
                   "attention_follow_fallback": follow, "attention_local_fallback": local,
                   "attention_keep_chunk": bool(keep),
                   "attention_resume": resume, "attention_resume_growth": growth,
                   "goal_tree": bool(goal),
                   "attention_from_goal": from_goal, "attention_rounds": rounds}  # fmt: skip
        per_task["settings"].append({"setting": setting, **_task_figures(runs)})
        print(
            f"| {budget} | {noise} | {policy.chunk} | {policy.window} | {patience} | {factor:g} | "
            f"{uniform} | {follow:g} | {local} | {keep} | {resume:g} | {growth:g} | {goal} | "
            f"{int(from_goal) if goal else '-'} | "
            f"{'-' if not from_goal else 'default' if rounds is None else rounds} | "
            f"{row['nodes_mean']:.1f} | "
            f"{row['nodes_median']:.0f} | "
            f"{solved:.3f} | {both_ways:.3f} | {row['success']:.3f} | {row['cost']:.2f} | "
            f"{row['time'] * 1e3:.2f} | {versus_rrt} |",
            flush=True,
        )
        if both_ways >= args.min_attention_success and row["nodes_mean"] < best_nodes:
            best, best_nodes = setting, row["nodes_mean"]
    print(f"recommended: {best}")
    if args.per_task is not None:
        write_json_atomic(args.per_task, per_task)
        print(f"per-task figures: {args.per_task}")
    return best or {}


def check_per_task_file(out: Path, inputs: list[Path]) -> None:
    """Refuse a ``--per-task`` file that is an input, or an existing file not of this kind.

    Raises:
        ConfigError: naming the flag and the file.
    """
    for given in inputs:
        if out.absolute() == given.absolute() or (
            out.exists() and given.exists() and out.samefile(given)
        ):
            raise ConfigError(f"--per-task: {out} is an input; choose another file")
    if out.is_dir():
        raise ConfigError(f"--per-task: {out} is a directory")
    if out.exists():
        try:
            data = json.loads(out.read_text())
        except (OSError, ValueError, RecursionError):
            data = None
        if not (isinstance(data, dict) and all(key in data for key in PER_TASK_KEYS)):
            raise ConfigError(
                f"--per-task: {out} exists and is not a per-task file of this script; move it "
                "or choose another file"
            )


def _digest(problem) -> str:
    """A short SHA-256 of the problem's JSON: two per-task files name the same tasks or not."""
    text = json.dumps(problem.to_dict(), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _task_figures(runs: list[dict]) -> dict[str, list]:
    """Per task: nodes to the first solution, success, cost and the attention phase's share."""
    return {
        "nodes": [int(run["nodes"]) for run in runs],
        "success": [bool(run["success"] > 0) for run in runs],
        "cost": [float(run["cost"]) if run["success"] > 0 else None for run in runs],
        "attention_solved": [bool(run.get("attention_solved", False)) for run in runs],
        "attention_solved_both_ways": [
            bool(run.get("attention_solved_both_ways", False)) for run in runs
        ],
    }


if __name__ == "__main__":
    sys.exit(run_script("tune_planner.py", main))
