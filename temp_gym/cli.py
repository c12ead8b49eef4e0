"""``temp-plan``: solve problem files from the command line.

Example:
    $ temp-plan problem.json                  # TEMP with the shipped policy for the robot
    $ temp-plan problem.json --planner informed_rrt_star --seed 3 --max-nodes 2000 --out r.json
    informed_rrt_star seed=3: cost 26.8120, 2000 nodes, ...
    $ temp-plan problem.json --checkpoint runs/TEMP-2D-v0__quick__0/best.pt   # your own policy
    $ temp-plan problems/*.json --out-dir results/   # batch: one process, one result each
    $ temp-plan problem.json --set attention_patience=60   # any setting of the planner's class

``--set KEY=VALUE`` (repeatable) sets any field of the planner's settings class
(`temp_gym.planning.PLANNERS`; `temp_gym.planning.TEMPSettings` for ``temp``); the epilog of
``--help`` lists them. TEMP's settings not given take the policy's own: the shipped policy's,
or those a ``--checkpoint`` carries.

Batch mode plans every file in one process, so start-up (imports, the per-process warm-up of
the compiled kernels, loading the policy) is paid once; each file gets a summary line and,
with ``--out-dir``, ``{out-dir}/{file stem}.json``. A bad file is reported and skipped.

Exit status (`EXIT_CODES`): 0 every problem was solved, 3 no path was found for some
problem, 2 bad input (a one-line error on stderr per bad file or argument, no traceback),
130 interrupted. 1 is left to Python: an unexpected error, with its traceback, is a bug.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import textwrap
from collections.abc import Sequence
from pathlib import Path

from temp_gym.jobs import BAD_INPUT, INTERRUPTED

SOLVED = 0
NO_PATH = 3
EXIT_CODES = {
    SOLVED: "every problem solved",
    BAD_INPUT: "bad input",
    NO_PATH: "no path found",
    INTERRUPTED: "interrupted",
}
"""Exit status -> meaning."""


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Every flag's default shown, the epilog's lines kept."""


def _parser() -> argparse.ArgumentParser:
    from temp_gym.planning import PLANNERS, PlanSettings
    from temp_gym.planning.settings import field_names

    common = field_names(PlanSettings)
    own = {
        name: sorted(field_names(entry.settings) - common - {"policy"})
        for name, entry in PLANNERS.items()
    }
    listed = [f"every planner takes {', '.join(sorted(common))}"] + [
        f"{name} also {', '.join(names)}" for name, names in own.items() if names
    ]
    parser = argparse.ArgumentParser(
        prog="temp-plan",
        description="Solve temp-gym problem JSON files with one planner.",
        formatter_class=_HelpFormatter,
        epilog=textwrap.fill("settings of --set: " + "; ".join(listed) + ".", 79)
        + "\n\nexit status: "
        + ", ".join(f"{code} {meaning}" for code, meaning in EXIT_CODES.items()),
    )
    parser.add_argument(
        "problems", nargs="+", metavar="problem", help="problem JSON files (temp_gym.problem)"
    )
    parser.add_argument("--planner", default="temp", choices=sorted(PLANNERS), help="planner")
    parser.add_argument(
        "--checkpoint", default=None, help="temp: a trained policy (None: the shipped one)"
    )
    parser.add_argument(
        "--attention-nodes",
        type=int,
        default=None,
        help="temp: attention-phase budget n (None: the policy's)",
    )
    parser.add_argument("--seed", type=int, default=0, help="random seed")
    parser.add_argument(
        "--time-limit",
        type=float,
        default=None,
        help="seconds of search per problem (None: no limit; see temp_gym.plan for what it covers)",
    )
    parser.add_argument(
        "--max-nodes", type=int, default=PlanSettings.max_nodes, help="tree-size budget"
    )
    parser.add_argument("--step-size", type=float, default=None, help="steering step")
    parser.add_argument("--stop-at-first", action="store_true", help="stop at the first solution")
    parser.add_argument(
        "--set",
        dest="settings",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a setting of the planner (repeatable; listed below), e.g. attention_patience=60",
    )
    parser.add_argument(
        "--out", default=None, help="one problem: write its result (path included) as JSON"
    )
    parser.add_argument(
        "--out-dir", default=None, help="write each result to {out-dir}/{problem file stem}.json"
    )
    return parser


def _error(message: object) -> None:
    print(f"temp-plan: error: {message}", file=sys.stderr)


def _outputs(args: argparse.Namespace) -> list[Path | None]:
    """Where each problem's result goes (None: nowhere), checked before any planning."""
    if args.out is not None and len(args.problems) > 1:
        raise ValueError("--out takes one problem; use --out-dir for several")
    if args.out is not None and args.out_dir is not None:
        raise ValueError("--out and --out-dir: give one of them")
    if args.out is not None and Path(args.out).is_dir():
        raise ValueError(f"--out: {args.out} is a directory")
    out_dir = None if args.out_dir is None else Path(args.out_dir)
    if out_dir is not None and out_dir.exists() and not out_dir.is_dir():
        raise ValueError(f"--out-dir: {args.out_dir} is not a directory")
    if args.out is not None:
        return [Path(args.out)]
    if args.out_dir is None:
        return [None] * len(args.problems)
    stems = [Path(problem).stem for problem in args.problems]
    repeated = sorted({stem for stem in stems if stems.count(stem) > 1})
    if repeated:
        raise ValueError(f"--out-dir: several problems would write {repeated[0]}.json")
    return [Path(args.out_dir) / f"{stem}.json" for stem in stems]


def _policy(args: argparse.Namespace):
    """The policy of ``--checkpoint`` (loaded once), or None.

    Loaded as `temp_gym.models.registry.policy_from_checkpoint` loads it: with the planner
    settings a shipped checkpoint carries (so the shipped file gives the default plan), and
    from its inference snapshot, without PyTorch, when one lies beside it.
    """
    if args.planner != "temp":
        if args.checkpoint is not None or args.attention_nodes is not None:
            raise ValueError("--checkpoint and --attention-nodes apply to --planner temp only")
        return None
    if args.checkpoint is None:
        return None
    from temp_gym.models.registry import policy_from_checkpoint

    return policy_from_checkpoint(args.checkpoint)


def _settings(args: argparse.Namespace):
    """The planner's settings of the flags and ``--set`` items, checked before any planning."""
    import yaml

    from temp_gym.planning.registry import settings_for

    given = {}
    for item in args.settings:
        key, sep, text = item.partition("=")
        if not sep or not key:
            raise ValueError(f"--set {item!r}: expected KEY=VALUE")
        if key == "policy":
            raise ValueError("--set policy: give a trained policy as --checkpoint PATH")
        try:
            given[key] = yaml.safe_load(text) if text.strip() else None
        except yaml.YAMLError:
            given[key] = text
    flags = {"seed": args.seed, "max_nodes": args.max_nodes, "time_limit": args.time_limit,
             "stop_at_first": args.stop_at_first, "step_size": args.step_size}  # fmt: skip
    if args.attention_nodes is not None:
        flags["attention_nodes"] = args.attention_nodes
    return settings_for(args.planner, None, **{**flags, **given})


def _solve(path: str, args: argparse.Namespace, settings):
    """Plan one problem file; bad input raises `ValueError`/`OSError`."""
    from temp_gym.planning import plan
    from temp_gym.problem import Problem

    problem = Problem.load(path)
    policy = getattr(settings, "policy", None)
    if policy is not None and args.checkpoint is not None:
        from temp_gym.planning.policy import check_compatible

        check_compatible(policy.robot, policy.dim, problem.robot, problem.dim, args.checkpoint)
    return plan(problem, args.planner, settings)


def _write(result, out: Path, flag: str) -> None:
    """Write ``result`` as JSON to ``out``; a failure names the flag and the file."""
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(result.to_dict()) + "\n")
    except OSError as error:
        raise OSError(f"{flag}: cannot write {out} ({error.strerror or error})") from None


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (`EXIT_CODES`)."""
    args = _parser().parse_args(argv)
    batch = len(args.problems) > 1
    try:
        outputs = _outputs(args)
        settings = _settings(args)
        policy = _policy(args)
        if policy is not None:
            settings = dataclasses.replace(settings, policy=policy)
    except (OSError, ValueError, ImportError) as error:
        _error(error)
        return BAD_INPUT
    except KeyboardInterrupt:
        _error("interrupted")
        return INTERRUPTED
    status = SOLVED
    for path, out in zip(args.problems, outputs):
        try:
            result = _solve(path, args, settings)
        except (OSError, ValueError, ImportError) as error:
            _error(f"{path}: {error}" if batch and path not in str(error) else error)
            status = BAD_INPUT
            continue
        except KeyboardInterrupt:
            _error("interrupted")
            return INTERRUPTED
        print(f"{path}: {result.summary()}" if batch else result.summary(), flush=True)
        if out is not None:  # after the summary, so a failed write loses no figure
            try:
                _write(result, out, "--out" if args.out is not None else "--out-dir")
            except OSError as error:
                _error(error)
                status = BAD_INPUT
                continue
        if not result.success and status == SOLVED:
            status = NO_PATH
    return status


if __name__ == "__main__":
    sys.exit(main())
