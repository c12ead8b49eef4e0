r"""What each training ingredient bought: policies side by side on validation tasks, in nodes.

    python benchmarks/ingredients.py --config configs/2d.yaml \\
        --policy "80 x 200, width 32=old_2d.pt" --policy "shipped=temp_gym/checkpoints/2d.pt" \\
        [--tasks 200] [--families boxes mixed] [--ood-seeds 10] [--budget 10000]

Every policy plans the same tasks with the same seeds: ``--tasks`` tasks drawn from the
``val`` workspaces of each workspace family in ``--families`` (`data.workspace_family`: the
boxes of the paper's generator, and the structured families), and each problem of the world's
out-of-distribution family (`examples/ood`) with ``--ood-seeds`` seeds. It reports the nodes to
the first solution at a ``--budget`` node budget (a failure counts as the whole budget): mean
and median per policy and column, with RRT* on the same tasks and seeds as the
reference (Informed RRT* is RRT* until its first solution, so it is the same row). Every
policy runs with the same planner settings (``--noise-std``, its whole
chunk, the attention phase's budget the whole ``--budget`` and the default stall rule), so
the rows differ in their training alone. Node counts do not depend on the machine's speed, so
the table can be measured beside other jobs; the validation columns choose, the OOD column
only reports (it is a test family).
"""

from __future__ import annotations

import dataclasses
import statistics

import numpy as np

from temp_gym import training
from temp_gym.config import labelled_entry, load_config, parse_args, script_parser
from temp_gym.evaluation.ood import load_ood_family
from temp_gym.models.policy import TEMPPolicy
from temp_gym.training import plan_episode


def _tasks(config, families: list[str], count: int, ood_seeds: int) -> dict[str, list]:
    """Column name -> [(problem, seed)]: validation tasks per family, then the OOD family."""
    seed = config.train_eval.seed + 20_000  # the tuning script's validation tasks
    columns = {}
    for family in families:
        problems = training.draw_problems(config, "val", count, seed, workspace_family=family)
        columns[f"val {family}"] = [(p, seed + i) for i, p in enumerate(problems)]
    if ood_seeds > 0:
        family = load_ood_family(config.env.robot).values()
        columns["OOD"] = [(p, s) for p in family for s in range(ood_seeds)]
    return columns


def _nodes(runs: list[dict], budget: int) -> tuple[float, float]:
    nodes = training.nodes_or_budget(runs, budget)
    return float(np.mean(nodes)), float(statistics.median(nodes))


def main(argv: list[str] | None = None) -> dict:
    """Print the table; return ``{row: {column: (mean, median)}}``."""
    parser = script_parser(__doc__.splitlines()[0])
    parser.add_argument("--config", required=True, help="the world's config (configs/2d.yaml)")
    parser.add_argument(
        "--policy",
        action="append",
        required=True,
        help="LABEL=CHECKPOINT, once per policy (the label says what it was trained on)",
    )
    parser.add_argument("--tasks", type=int, default=200, help="validation tasks per family")
    parser.add_argument(
        "--families", nargs="+", default=["boxes", "mixed"], help="workspace families of val"
    )
    parser.add_argument("--ood-seeds", type=int, default=10, help="seeds per OOD problem (0: none)")
    parser.add_argument("--budget", type=int, default=10_000, help="node budget per run")
    parser.add_argument("--noise-std", type=float, default=0.03, help="every policy's noise")
    parser.add_argument("overrides", nargs="*", help="key.sub=value config overrides")
    args = parse_args(parser, argv)
    try:
        policies = [labelled_entry(entry) for entry in args.policy]
    except ValueError as error:
        parser.error(str(error))
    if args.tasks < 1 or args.budget < 1 or args.ood_seeds < 0:
        parser.error("--tasks and --budget must be >= 1, --ood-seeds >= 0")
    config = load_config(args.config, args.overrides)
    settings = dataclasses.replace(
        config.train_eval, max_nodes=args.budget, attention_nodes=args.budget,
        attention_patience=None, attention_uniform=0.0,
    )  # fmt: skip
    columns = _tasks(config, args.families, args.tasks, args.ood_seeds)
    rows: dict[str, dict[str, tuple[float, float]]] = {}
    # Informed RRT* is RRT* until its first solution: one reference row stands for both.
    rows["RRT* (= Informed RRT* to a first solution)"] = {
        column: _nodes([plan_episode(p, "rrt_star", s, settings) for p, s in tasks], args.budget)
        for column, tasks in columns.items()
    }
    for label, path in policies:
        policy = TEMPPolicy.from_checkpoint(path, robot=config.env.robot, noise_std=args.noise_std)
        rows[label] = {
            column: _nodes(
                [plan_episode(p, "temp", s, settings, policy) for p, s in tasks], args.budget
            )
            for column, tasks in columns.items()
        }
        print(f"measured {label}", flush=True)
    counts = ", ".join(f"{column}: {len(tasks)} runs" for column, tasks in columns.items())
    print(f"\nnodes to a first solution, mean / median ({counts}; budget {args.budget})\n")
    print("| policy | " + " | ".join(columns) + " |")
    print("|---|" + "---:|" * len(columns))
    for label, row in rows.items():
        cells = " | ".join(f"{mean:.1f} / {median:.0f}" for mean, median in row.values())
        print(f"| {label} | {cells} |")
    return rows


if __name__ == "__main__":
    main()
