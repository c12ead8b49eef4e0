r"""Choose a policy's planner settings on validation workspaces: budget n, noise, horizon, ...

    python trainers/tune_planner.py --config configs/2d.yaml --checkpoint runs/.../best.pt \\
        --attention-nodes 50 100 200 400 --noise-std 0 0.03 --horizon 1 2 4 --tasks 60 \\
        [--max-nodes 10000]
    python trainers/tune_planner.py --config configs/2d.yaml --split test --tasks 1000 \\
        --max-nodes 10000            # the shipped policy, as it ships

Every setting flag (`SWEEPS`: the attention-phase budget n, output noise, horizon, path window,
stall patience, ...) takes the values to try; a flag not given takes the checkpoint's own
setting (what `temp_gym.load_policy` applies: a shipped policy's are those it was tuned with,
its model card says how), else the planner's default, and so do the keys of the config's
``train_eval.temp`` section, which a flag replaces. So with no setting flag the table measures
the policy as it ships. ``--checkpoint`` defaults to the policy shipped for the config's robot.

For every combination it plans ``--tasks`` tasks drawn from the ``val`` workspaces, or from the
100 of the planner-tuning pool (``--split tune``, which estimates a failure rate of half a
percent better than val's 20 workspaces; both seen in no test; the test workspaces stay
untouched until the final measurement, ``--split test`` with the chosen setting) with the
``temp`` planner up to the first solution, and prints nodes to the first solution (mean and
median, a failure counted as the whole budget), the share solved by attention-based planning
within n (from the start alone, and both ways: from the start, or from the goal after a stall,
or in a later round), cost and time; and, against a classical planner on the same tasks and
seeds (``--baseline``, RRT* by default), the share of tasks where TEMP needed fewer nodes and
the mean difference with its 95% paired bootstrap interval.
Each row prints the settings it ran with, the checkpoint's included. The recommendation
minimizes the mean nodes among the settings whose attention phase solves at least
``--min-attention-success`` of the tasks (both ways); ``trainers/ship.py --attention-nodes ...
--noise-std ...`` then ships it.

Every run, the baseline's included, has the node budget ``--max-nodes`` (default: the config's
``train_eval.max_nodes``), printed with the table; an n above it is refused rather than
quietly cut to it. ``--no-baseline`` (or its older name ``--no-rrt``) leaves the baseline out
(its columns print ``-``), for comparing policies with each other: ``--per-task FILE`` writes
every run's figures task by task, which ``trainers/compare_policies.py`` pairs across policies.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import sys
from pathlib import Path
from typing import Any

from temp_gym.config import (
    ConfigError,
    TEMPConfig,
    count,
    load_config,
    number,
    parse_args,
    script_parser,
)
from temp_gym.jobs import run_script
from temp_gym.limits import MAX_TASKS

# PyTorch, numba and the planners are imported where they are used, after the command line is
# read: ``--help`` and a bad value are answered without loading them.

PER_TASK_KEYS = ("max_nodes", "seeds", "problems", "settings")
"""Keys of a ``--per-task`` file: an existing file is replaced only if it has them."""

RULE = -1
"""``--patience`` and ``--rounds``: the planner's default, not the checkpoint's."""

SWEEPS = (
    ("--attention-nodes", "attention_nodes", count(1), "attention-phase budgets n, in tree nodes"),
    ("--noise-std", "noise_std", number(0.0),
     "output noise levels (standard deviations, normalized units)"),
    ("--horizon", "horizon", count(0),
     "proposals used per MPT call (0: the model's whole chunk)"),
    ("--path-window", "path_window", count(0),
     "newest path-so-far nodes read per MPT call (0: all the model was trained on)"),
    ("--patience", "attention_patience", count(RULE), "attention-phase stall patiences (-1: the "
     "default rule, temp_gym.planning.attention.default_patience; 0: never)"),
    ("--near-goal-factor", "attention_near_goal_factor", number(1.0),
     "stall-patience factors near the goal (1: the same patience everywhere)"),
    ("--uniform", "attention_uniform", number(0.0, 1.0),
     "shares of uniform samples in the attention phase"),
    ("--follow-fallback", "attention_follow_fallback", number(0.0, 1.0), "probabilities of "
     "going on from a fallback node that got no closer to the goal (1: always, Algorithm 1)"),
    ("--local-fallback", "attention_local_fallback", count(0), "replacements of a colliding "
     "proposal drawn near it before uniform ones (0: none, Algorithm 1)"),
    ("--keep-chunk", "attention_keep_chunk", int, "after a chunk's proposal collided and a "
     "fallback node replaced it: go on with the chunk (1) or call the policy again (0)"),
    ("--resume", "attention_resume", number(0.0),
     "classical nodes, in stall patiences, before the attention phase resumes (0: never)"),
    ("--resume-growth", "attention_resume_growth", number(1.0), "how many times longer each "
     "classical turn between resumed attention phases is than the one before (1: equal)"),
    ("--goal-tree", "goal_tree", int,
     "grow a tree from the goal after an unsolved attention phase (1) or not (0)"),
    ("--from-goal", "attention_from_goal", int, "after a stall, the policy grows the goal tree "
     "first (1) or Informed RRT*'s samples alone (0); needs --goal-tree 1"),
    ("--rounds", "attention_rounds", count(RULE), "after stalls from the start and from the "
     "goal, more rounds of the two (-1: the planner's default; 0: none); with --from-goal 1"),
)  # fmt: skip
"""(flag, setting, argparse type, what it sweeps): each flag takes the values to try."""

POLICY_KEYS = ("noise_std", "horizon", "path_window")
"""Settings of the policy itself; the others are `TEMPSettings` fields."""

COLUMNS = ("n", "noise", "horizon", "window", "patience", "near goal", "uniform", "follow",
           "local", "keep chunk", "resume", "growth", "goal tree", "from goal",
           "rounds")  # fmt: skip
"""The table's settings columns, one per sweep, in `SWEEPS`' order."""


def _parser():
    parser = script_parser(
        __doc__.splitlines()[0],
        epilog="Output: the table on stdout; with --per-task, that JSON file too.",
    )
    parser.add_argument("--config", required=True, help="the config the policy was trained with")
    parser.add_argument(
        "--checkpoint",
        default=None,
        help="the policy (a bc.py best.pt; None: the one shipped for the robot)",
    )
    for flag, key, kind, what in SWEEPS:
        choices = [0, 1] if flag in ("--keep-chunk", "--goal-tree", "--from-goal") else None
        parser.add_argument(
            flag,
            dest=key,
            type=kind,
            nargs="+",
            default=None,
            choices=choices,
            help=f"{what}, to try (None: the checkpoint's)",
        )
    parser.add_argument(
        "--max-nodes",
        type=count(1),
        default=None,
        help="node budget of every run, the baseline's included (None: "
        "train_eval.max_nodes of the config); each n must fit in it",
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
        "--baseline",
        default="rrt_star",
        help="the classical planner TEMP is paired with on the same tasks and seeds (any "
        "registered planner but temp; rrt_star, informed_rrt_star, rrt_connect, ompl_...)",
    )
    parser.add_argument(
        "--no-baseline",
        "--no-rrt",
        dest="no_baseline",
        action="store_true",
        help="leave the baseline out (its columns print -): for comparing policies with each "
        "other (--no-rrt: the same flag's older name)",
    )
    parser.add_argument(
        "--per-task",
        default=None,
        help="write every run's figures task by task to this JSON file "
        "(trainers/compare_policies.py pairs two such files)",
    )
    parser.add_argument("overrides", nargs="*", help="key.sub=value config overrides")
    return parser  # fmt: skip


def _check_values(args, budget: int, budget_from: str) -> None:
    """Refuse, naming the flag, a value the planner or the policy would refuse."""
    from temp_gym.planning.settings import noise_level
    from temp_gym.planning.temp_settings import check

    too_large = [n for n in args.attention_nodes or () if n > budget]
    if too_large:  # n beyond the budget would silently mean n = budget
        raise ValueError(
            f"--attention-nodes {too_large[0]} exceeds the node budget {budget} "
            f"({budget_from}); pass a larger --max-nodes"
        )
    for flag, key, _, _ in SWEEPS:
        for value in getattr(args, key) or ():
            if key in ("attention_patience", "attention_rounds") and value == RULE:
                continue
            if key == "noise_std":
                noise_level(value, flag)
            elif key not in POLICY_KEYS and key not in ("goal_tree", "attention_from_goal",
                                                        "attention_keep_chunk"):  # fmt: skip
                check(key, value, flag)


def _check_baseline(name: str) -> None:
    """Refuse, naming ``--baseline``, a planner that is not registered or is TEMP itself."""
    from temp_gym.planning import PLANNERS  # the built-in planners are registered with it

    if name == "temp" or name not in PLANNERS:
        known = sorted(set(PLANNERS) - {"temp"})
        raise ValueError(f"--baseline: unknown classical planner {name!r}; expected one of {known}")


def _rows(args) -> list[dict[str, Any]]:
    """Every combination of the values given, one dict per row (None: not given)."""
    lists = [getattr(args, key) or [None] for _, key, _, _ in SWEEPS]
    first = {key: values[0] for (_, key, _, _), values in zip(SWEEPS, lists)}
    rows = []
    for values in itertools.product(*lists):
        row = dict(zip([key for _, key, _, _ in SWEEPS], values))
        # Rows a setting makes no difference to are run once: the first value of the other.
        if row["attention_resume"] == 0 and row["attention_resume_growth"] != first[
                "attention_resume_growth"]:  # fmt: skip
            continue
        if row["goal_tree"] == 0 and row["attention_from_goal"] != first["attention_from_goal"]:
            continue
        from_goal = row["goal_tree"] != 0 and row["attention_from_goal"] != 0
        if not from_goal and row["attention_rounds"] != first["attention_rounds"]:
            continue
        rows.append(row)
    return rows


def _row_setup(row: dict[str, Any], base, config_temp: TEMPConfig):
    """The row's policy and its ``train_eval.temp`` section (what `plan_episode` reads)."""
    changes = {key: row[key] or None for key in ("horizon", "path_window") if row[key] is not None}
    if row["noise_std"] is not None:
        changes["noise_std"] = row["noise_std"]
    for key in ("attention_patience", "attention_rounds"):
        if row[key] == RULE:  # the planner's default: the policy carries none
            changes[key] = None
    policy = base.fresh(**changes)
    temp = {key: value for key, value in dataclasses.asdict(config_temp).items()}
    for _, key, _, _ in SWEEPS:
        value = row[key]
        if key in POLICY_KEYS or value is None or value == RULE and key in changes:
            continue
        temp[key] = bool(value) if key in ("goal_tree", "attention_from_goal",
                                           "attention_keep_chunk") else value  # fmt: skip
    if temp["goal_tree"] is False:  # no goal tree: no phase from the goal, no rounds
        temp["attention_from_goal"], temp["attention_rounds"] = False, 0
    elif temp["attention_from_goal"] is False:
        temp["attention_rounds"] = 0
    return policy, TEMPConfig(**temp)


def _effective(policy, temp: TEMPConfig, budget: int) -> dict[str, Any]:
    """The settings a row ran with: given, else the policy's, else the planner's defaults."""
    from temp_gym import training
    from temp_gym.planning.temp_planner import DEFAULTS
    from temp_gym.planning.temp_settings import DECLARED, resolve

    settings = training.temp_settings(temp, policy)
    value = {name: resolve(settings, policy, name, DEFAULTS.get(name)) for name in DECLARED}
    rounds = resolve(settings, policy, "attention_rounds", None)  # None: shown as "default"
    goal = temp.goal_tree is not False
    from_goal = goal and temp.attention_from_goal is not False
    return {
        "attention_nodes": resolve(settings, policy, "attention_nodes", budget),
        "noise_std": policy.noise_std, "horizon": policy.chunk, "path_window": policy.path_window,
        "attention_patience": value["attention_patience"],
        "attention_near_goal_factor": value["attention_near_goal_factor"],
        "attention_uniform": value["attention_uniform"],
        "attention_follow_fallback": value["attention_follow_fallback"],
        "attention_local_fallback": value["attention_local_fallback"],
        "attention_keep_chunk": bool(temp.attention_keep_chunk),
        "attention_resume": value["attention_resume"],
        "attention_resume_growth": value["attention_resume_growth"],
        "goal_tree": goal, "attention_from_goal": from_goal,
        "attention_rounds": rounds if from_goal else 0,
    }  # fmt: skip


def _cells(setting: dict[str, Any], window: int) -> list[str]:
    """The settings columns of a row (`COLUMNS`)."""
    patience, rounds = setting["attention_patience"], setting["attention_rounds"]
    return [
        str(setting["attention_nodes"]), f"{setting['noise_std']:g}", str(setting["horizon"]),
        str(window), "rule" if patience is None else str(patience),
        f"{setting['attention_near_goal_factor']:g}", f"{setting['attention_uniform']:g}",
        f"{setting['attention_follow_fallback']:g}", str(setting["attention_local_fallback"]),
        str(int(setting["attention_keep_chunk"])), f"{setting['attention_resume']:g}",
        f"{setting['attention_resume_growth']:g}", str(int(setting["goal_tree"])),
        str(int(setting["attention_from_goal"])) if setting["goal_tree"] else "-",
        "-" if not setting["attention_from_goal"]
        else "default" if rounds is None else str(rounds),
    ]  # fmt: skip


def main(argv: list[str] | None = None) -> dict:
    """Print the table; return the recommended setting (every key, as the row ran)."""
    parser = _parser()
    args = parse_args(parser, argv)
    config = load_config(args.config, args.overrides)
    eval_config = config.train_eval
    budget_from = "train_eval.max_nodes"
    if args.max_nodes is not None:
        eval_config = dataclasses.replace(eval_config, max_nodes=args.max_nodes)
        budget_from = "--max-nodes"
    if eval_config.max_nodes < 1:
        parser.error(f"{budget_from}: must be at least 1, got {eval_config.max_nodes}")
    if args.per_task is not None:
        inputs = [Path(args.config), *([Path(args.checkpoint)] if args.checkpoint else [])]
        check_per_task_file(Path(args.per_task), inputs)
    import numpy as np

    from temp_gym import training
    from temp_gym.evaluation.ood import load_ood_family
    from temp_gym.files import write_json_atomic
    from temp_gym.models.registry import policy_from_checkpoint, shipped_checkpoint
    from temp_gym.training import plan_episode
    from temp_gym.worlds.structured import check_family

    try:
        _check_values(args, eval_config.max_nodes, budget_from)
        check_family(config.env.robot, args.family)
        _check_baseline(args.baseline)
    except ValueError as error:
        parser.error(str(error))
    flag = "--checkpoint" if args.checkpoint else "the shipped policy"
    try:
        checkpoint = args.checkpoint or str(shipped_checkpoint(config.env.robot))
        base = policy_from_checkpoint(checkpoint, robot=config.env.robot)
    except (OSError, ValueError) as error:
        raise ConfigError(f"{flag}: {error}") from None
    try:  # the policy's own checks (horizon, path window), naming the flag, before any run
        rows = [(row, *_row_setup(row, base, eval_config.temp)) for row in _rows(args)]
    except ValueError as error:
        message = str(error)
        parser.error(message if message.startswith("--") else f"--{_flag_of(message)}{message}")
    if args.split == "ood":
        family = list(load_ood_family(config.env.robot).values())
        problems = [family[index % len(family)] for index in range(args.tasks)]
    else:
        problems = training.draw_problems(
            config, args.split, args.tasks, eval_config.seed + 20_000, workspace_family=args.family
        )
    seeds = [eval_config.seed + index for index in range(len(problems))]
    baseline_runs = None
    baseline_line = f"{args.baseline}: not run (--no-baseline)"
    if not args.no_baseline:
        baseline_runs = [
            plan_episode(p, args.baseline, s, eval_config) for p, s in zip(problems, seeds)
        ]
        base = training.summarize(baseline_runs, eval_config.max_nodes)
        baseline_line = (
            f"{args.baseline}: nodes mean {base['nodes_mean']:.1f} median "
            f"{base['nodes_median']:.0f}, solved {base['success']:.3f}, cost {base['cost']:.2f}, "
            f"time {base['time'] * 1e3:.1f} ms"
        )
    print(
        f"{len(problems)} {args.split} tasks ({'OOD' if args.split == 'ood' else args.family}), "
        f"budget {eval_config.max_nodes} nodes per run; {baseline_line}; settings not given: "
        f"{checkpoint}'s"
    )
    per_task = {
        "config": args.config,
        "checkpoint": checkpoint,
        "split": args.split,
        "family": "OOD" if args.split == "ood" else args.family,
        "max_nodes": eval_config.max_nodes,
        "seeds": seeds,
        "problems": [_digest(problem) for problem in problems],
        "baseline": args.baseline,
        args.baseline: None if baseline_runs is None else _task_figures(baseline_runs),
        "settings": [],
    }
    figures = ("nodes mean", "median", "AP solved", "AP both ways", "success", "cost",
               "time (ms)", f"fewer than {args.baseline}",
               "mean difference [95% CI]")  # fmt: skip
    print("| " + " | ".join((*COLUMNS, *figures)) + " |")
    print("|" + "---:|" * (len(COLUMNS) + len(figures) - 1) + "---|")
    best, best_nodes = None, np.inf
    for _, policy, temp in rows:
        row_config = dataclasses.replace(eval_config, temp=temp)
        runs = [plan_episode(p, "temp", s, row_config, policy) for p, s in zip(problems, seeds)]
        summary = training.summarize(runs, eval_config.max_nodes)
        solved = float(np.mean([run["attention_solved"] for run in runs]))
        both_ways = float(np.mean([run["attention_solved_both_ways"] for run in runs]))
        if baseline_runs is None:
            versus_baseline = "- | -"
        else:
            paired = training.paired_nodes(runs, baseline_runs, eval_config.max_nodes)
            versus_baseline = (
                f"{paired['fewer']:.2f} | {paired['difference']:+.1f} "
                f"[{paired['low']:+.1f}, {paired['high']:+.1f}]"
            )
        setting = _effective(policy, temp, eval_config.max_nodes)
        per_task["settings"].append({"setting": setting, **_task_figures(runs)})
        print(
            "| " + " | ".join(_cells(setting, policy.window)) + " | "
            f"{summary['nodes_mean']:.1f} | {summary['nodes_median']:.0f} | "
            f"{solved:.3f} | {both_ways:.3f} | {summary['success']:.3f} | "
            f"{summary['cost']:.2f} | {summary['time'] * 1e3:.2f} | {versus_baseline} |",
            flush=True,
        )
        if both_ways >= args.min_attention_success and summary["nodes_mean"] < best_nodes:
            best, best_nodes = setting, summary["nodes_mean"]
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
    blocking = next((folder for folder in out.absolute().parents if folder.exists()), None)
    if blocking is not None and not blocking.is_dir():  # checked now, not after the sweep
        raise ConfigError(f"--per-task: {blocking} is a file, so {out} cannot be written")
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


def _flag_of(message: str) -> str:
    """``path-window: `` for a message about ``path_window``; the flag of a policy's check."""
    name = message.split(":", 1)[0]
    return f"{name.replace('_', '-')}: " if name in POLICY_KEYS else ""


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
