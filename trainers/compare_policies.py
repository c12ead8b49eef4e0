r"""Pair policies task by task: a capped mean of nodes with its paired bootstrap interval.

    python trainers/tune_planner.py --config configs/7d.yaml --checkpoint A.pt ... \\
        --no-baseline --per-task a.json
    python trainers/tune_planner.py --config configs/7d.yaml --checkpoint B.pt ... \\
        --no-baseline --per-task b.json
    python trainers/compare_policies.py a.json b.json [c.json ...] [--cap 1000] [--margin 0.05]

The first file is the reference (the shipped policy, say); every other file is a candidate
that planned the same tasks with the same seeds and budget (the files name their tasks; other
tasks are refused). Node counts to the first solution, a failure counted as the whole
budget, are capped at ``--cap`` per task (`temp_gym.evaluation.statistics.
paired_capped_difference`): a mean of heavy-tailed counts can be decided by one task of
thousands, and the cap counts such a task as a failure to solve fast instead. Per candidate
it prints the plain and capped means, the capped mean difference to the reference with its
95% paired bootstrap interval, and whether the interval's upper end is within ``--margin``
of the reference's capped mean (a non-inferiority test), beside the median, the attention
phase's share solved both ways, the tasks over the cap, the share solved and the mean
first-path cost on the tasks both solved.
"""

from __future__ import annotations

import json
import math
import sys

from temp_gym.config import count, number, parse_args, script_parser
from temp_gym.jobs import JobError, run_script
from temp_gym.limits import MAX_PROBLEM_BYTES

KEYS = ("max_nodes", "seeds", "problems", "settings")
RUN_KEYS = ("nodes", "success", "cost", "attention_solved_both_ways")
"""What each setting of a per-task file lists, one entry per task."""


def _load(path: str, setting: int) -> dict:
    """One setting's per-task figures from a ``tune_planner.py --per-task`` file.

    Raises:
        JobError: a file that cannot be read, or is not such a file (naming what is wrong).
    """
    import numpy as np

    from temp_gym.files import StoredFileError, read_capped

    try:
        raw = read_capped(path, MAX_PROBLEM_BYTES, "a per-task file", "give a --per-task file")
        data = json.loads(raw.decode("utf-8"))
    except StoredFileError as error:
        raise JobError(str(error)) from None
    except (OSError, ValueError, RecursionError) as error:
        raise JobError(f"{path}: not a readable per-task file ({error})") from None
    missing = [key for key in KEYS if not isinstance(data, dict) or key not in data]
    if missing:
        raise JobError(f"{path}: not a tune_planner.py --per-task file (no {missing[0]!r})")
    settings, budget = data["settings"], data["max_nodes"]
    if not isinstance(settings, list) or not isinstance(budget, int) or budget < 1:
        raise JobError(f"{path}: not a tune_planner.py --per-task file (its settings or budget)")
    if not 0 <= setting < len(settings):
        raise JobError(
            f"{path}: --setting {setting}, but the file holds settings 0 to {len(settings) - 1}"
        )
    runs = settings[setting]
    tasks = len(data["seeds"]) if isinstance(data["seeds"], list) else -1
    if not isinstance(runs, dict) or any(
        not isinstance(runs.get(key), list) or len(runs[key]) != tasks for key in RUN_KEYS
    ):
        raise JobError(f"{path}: setting {setting} does not list {RUN_KEYS} for its {tasks} tasks")
    if not all(isinstance(value, bool) for value in runs["success"]) or not all(
        isinstance(value, (int, float)) and not isinstance(value, bool) for value in runs["nodes"]
    ):  # "12" or "false" would be read as a count or as True
        raise JobError(
            f"{path}: setting {setting} holds a success that is not true or false, or a node "
            "count that is not a number"
        )
    try:
        success = np.array(runs["success"], dtype=bool)
        nodes = np.where(success, np.array(runs["nodes"], dtype=np.float64), budget)
    except (TypeError, ValueError) as error:
        raise JobError(
            f"{path}: setting {setting} holds a value that is not a number ({error})"
        ) from None
    if not np.all(np.isfinite(nodes)) or np.any(nodes < 0):
        raise JobError(f"{path}: setting {setting} holds node counts that are not counts")
    return {"path": path, "data": data, "runs": runs, "nodes": nodes}


def _same_tasks(reference: dict, candidate: dict) -> None:
    for key in ("max_nodes", "seeds", "problems"):
        if reference["data"][key] != candidate["data"][key]:
            raise JobError(
                f"{candidate['path']}: its {key} differ from {reference['path']}'s: "
                "plan the same tasks with the same seeds and budget"
            )


def _cost(reference: dict, candidate: dict) -> tuple[float, float]:
    """Mean first-path cost of each on the tasks both solved."""
    import numpy as np

    both = np.logical_and(reference["runs"]["success"], candidate["runs"]["success"])
    if not both.any():
        return float("nan"), float("nan")
    costs = [np.array(item["runs"]["cost"], dtype=object)[both].astype(np.float64)
             for item in (reference, candidate)]  # fmt: skip
    return float(costs[0].mean()), float(costs[1].mean())


def main(argv: list[str] | None = None) -> dict:
    """Print the table; return ``{candidate path: its figures}``."""
    parser = script_parser(__doc__.splitlines()[0], epilog="Output: the table on stdout.")
    parser.add_argument("reference", help="the reference's per-task file (tune_planner.py)")
    parser.add_argument("candidates", nargs="+", help="the candidates' per-task files")
    parser.add_argument(
        "--cap",
        type=number(0.0),
        default=1000.0,
        help="nodes a task counts at most, in every mean (positive)",
    )
    parser.add_argument(
        "--margin",
        type=number(0.0),
        default=0.05,
        help="non-inferiority margin, a share of the reference's capped mean",
    )
    parser.add_argument(
        "--setting", type=int, default=0, help="which setting of each file (its row, from 0)"
    )
    parser.add_argument("--seed", type=count(0), default=0, help="seed of the bootstrap resampling")
    args = parse_args(parser, argv)
    if not (math.isfinite(args.cap) and args.cap > 0):
        parser.error(f"--cap: expected a finite positive number, got {args.cap}")
    import numpy as np

    from temp_gym.evaluation.statistics import paired_capped_difference

    reference = _load(args.reference, args.setting)
    candidates = [_load(path, args.setting) for path in args.candidates]
    for candidate in candidates:
        _same_tasks(reference, candidate)
    print(
        f"{len(reference['nodes'])} tasks, budget {reference['data']['max_nodes']} nodes, "
        f"each counted at most {args.cap:g}; reference {args.reference}"
    )
    print(
        "| policy | mean | median | capped mean | difference [95% CI] | within margin "
        "| both ways | over cap | solved | cost (both solved) |"
    )
    print("|---|---:|---:|---:|---|---|---:|---:|---:|---:|")
    reference_both_ways = float(np.mean(reference["runs"]["attention_solved_both_ways"]))
    rows = {}
    for item in [reference, *candidates]:
        summary = paired_capped_difference(
            reference["nodes"], item["nodes"], args.cap, seed=args.seed
        )
        limit = args.margin * summary["reference_capped"]
        within = summary["high"] <= limit
        both_ways = float(np.mean(item["runs"]["attention_solved_both_ways"]))
        solved = float(np.mean(item["runs"]["success"]))
        reference_cost, cost = _cost(reference, item)
        is_reference = item is reference
        difference = (
            "-"
            if is_reference
            else f"{summary['difference']:+.2f} [{summary['low']:+.2f}, {summary['high']:+.2f}]"
        )
        verdict = "-" if is_reference else f"{'yes' if within else 'no'} (<= {limit:+.2f})"
        print(
            f"| {item['path']} | {summary['candidate_mean']:.1f} | "
            f"{np.median(item['nodes']):.0f} | {summary['candidate_capped']:.2f} | {difference} | "
            f"{verdict} | {both_ways:.3f} | {summary['candidate_over_cap']} | {solved:.3f} | "
            f"{cost:.3f} |"
        )
        if not is_reference:
            rows[item["path"]] = {
                **summary,
                "limit": limit,
                "within_margin": within,
                "median": float(np.median(item["nodes"])),
                "both_ways": both_ways,
                "reference_both_ways": reference_both_ways,
                "solved": solved,
                "cost": cost,
                "reference_cost": reference_cost,
            }
    return rows


if __name__ == "__main__":
    sys.exit(run_script("compare_policies.py", main))
