"""``temp-benchmark``: run registered planners over a problem set, OMPL benchmark style.

Example:
    $ temp-benchmark --problems problems/ --planners rrt_star informed_rrt_star --out results/b
    $ temp-benchmark --split point2d:challenging:50 --planners temp rrt_star --out results/b2
    $ temp-benchmark --robot my_arm.yaml --problems my_arm_problems/ --planners rrt_connect --out b3
    $ python benchmarks/mbm.py mbm/ --planners temp rrt_star --out results/mbm

The problem set is a folder of problem JSON files (searched recursively; a file
``walls/0003.json`` is the problem ``walls/0003`` of scene ``walls``) or the evaluation's
generated test tasks (``--split ROBOT:DIFFICULTY:COUNT``). ``--group`` makes experiments of
it: one per scene (default), one for the whole set, or one per problem; ``--limit N`` keeps
the first N problems of each. Problems whose start or goal is invalid are skipped and listed.
Anytime planners run until the time limit unless ``--stop-at-first`` ends each run at its
first solution.

Outputs in ``--out``: ``logs/{experiment}.log`` (OMPL's benchmark log), ``benchmark.db``
(their SQLite database, for Planner Arena), ``summary.md`` and ``summary.csv``,
``plots/{experiment}.png``, and ``runs.jsonl`` (one record per run: rerunning the same command
resumes, skipping every stored run). Every flag is checked before a run starts; a bad one is
one line on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from temp_gym.config.checks import check_output_dir
from temp_gym.config.command_line import (
    add_robot_argument,
    count,
    number,
    register_robots,
    script_parser,
)
from temp_gym.distributed import add_backend_arguments
from temp_gym.jobs import BAD_INPUT, INTERRUPTED, JobError, one_line, report

PROG = "temp-benchmark"
DEFAULTS = {"time_limit": 10.0, "runs": 10, "seed": 0}
"""The flags' defaults (`temp_gym.evaluation.benchmark.BenchmarkSettings` holds the same)."""


@dataclass(frozen=True)
class ProblemSource:
    """A kind of problem set a script adds: its positional argument and its loader."""

    metavar: str
    """The positional argument's name in ``--help``."""
    help: str
    load: Callable[[str], tuple[list, list]]
    """``load(argument) -> (named problems, skipped (name, reason) pairs)``."""
    whole: Callable[[str], str] = lambda argument: Path(argument).stem
    """The name of the experiment of the whole set (``--group one``)."""


def build_parser(source: ProblemSource | None = None, prog: str = PROG) -> argparse.ArgumentParser:
    """The command's parser: the problem set (``source``'s, else a folder or a split)."""
    parser = script_parser(__doc__.splitlines()[0], prog=prog)
    if source is None:
        given = parser.add_mutually_exclusive_group(required=True)
        given.add_argument("--problems", metavar="FOLDER",
                           help="a folder of problem JSON files, searched recursively")  # fmt: skip
        given.add_argument("--split", metavar="ROBOT:DIFFICULTY:COUNT",
                           help="the evaluation's test tasks, e.g. point2d:easy:50")  # fmt: skip
    else:
        parser.add_argument("source", metavar=source.metavar, help=source.help)
    add_robot_argument(parser)
    parser.add_argument("--planners", nargs="+", required=True,
                        help="registered planner names (temp_gym.planning.PLANNERS)")  # fmt: skip
    parser.add_argument("--out", required=True, help="output folder (rerunning resumes in it)")
    parser.add_argument("--time-limit", type=number(0.0, above=True),
                        default=DEFAULTS["time_limit"],
                        help="seconds per run")  # fmt: skip
    parser.add_argument("--runs", type=count(1), default=DEFAULTS["runs"],
                        help="runs per planner and problem")  # fmt: skip
    seeds = "seed of the runs' seeds" + (" (and of a --split's tasks)" if source is None else "")
    parser.add_argument("--seed", type=count(0), default=DEFAULTS["seed"], help=seeds)
    parser.add_argument("--max-nodes", type=count(1), default=None,
                        help="node budget per run (None: high enough that the time limit "
                        "ends every run)")  # fmt: skip
    parser.add_argument("--stop-at-first", action="store_true",
                        help="end each run at its first solution instead of the time limit "
                        "(what a time to a first solution needs of anytime planners)")  # fmt: skip
    parser.add_argument(
        "--simplify",
        action="store_true",
        help="simplify each solved run's path (temp_gym.planning.simplify) and report its "
        "length beside the planner's, as OMPL's Benchmark does",
    )
    parser.add_argument(
        "--limit",
        type=count(1),
        default=None,
        metavar="N",
        help="run only the first N problems of each experiment (by name)",
    )
    parser.add_argument("--checkpoint", default=None, metavar="PATH",
                        help="temp: a trained policy (trainers/bc.py's best.pt) instead of each "
                        "robot's shipped one (a robot of your own ships none)")  # fmt: skip
    parser.add_argument("--group", choices=("scene", "one", "problem"), default="scene",
                        help="experiments: one per scene (a problem name's part before its "
                        "last '/'), one for the whole set, or one per problem")  # fmt: skip
    add_backend_arguments(parser, "1", "runs")
    return parser


def _settings(args: argparse.Namespace):
    """The benchmark's settings of the flags; a bad value names its flag."""
    from temp_gym.evaluation.benchmark import DEFAULT_MAX_NODES, BenchmarkSettings

    try:
        return BenchmarkSettings(
            planners=tuple(args.planners), time_limit=args.time_limit, runs=args.runs,
            seed=args.seed, max_nodes=args.max_nodes or DEFAULT_MAX_NODES,
            stop_at_first=args.stop_at_first, simplify=args.simplify,
            checkpoint=args.checkpoint,
        )  # fmt: skip
    except ValueError as error:
        field, _, reason = str(error).partition(":")
        raise ValueError(f"--{field.replace('_', '-')}:{reason}") from None


def _check_out(out: Path, inputs: Sequence[str]) -> None:
    check_output_dir(out, "--out")
    for given in inputs:
        folder = Path(given).absolute()
        if folder.is_dir() and (out.absolute() == folder or folder in out.absolute().parents):
            raise ValueError(f"--out: {out} is inside the problem folder {given}; its files "
                             "would be read as problems")  # fmt: skip


def _load(args: argparse.Namespace, source: ProblemSource | None) -> tuple[list, list, str]:
    """The named problems, the skipped ones and the whole set's experiment name."""
    from temp_gym.evaluation.benchmark_problems import folder_problems, split_problems

    if source is not None:
        problems, skipped = source.load(args.source)
        return list(problems), list(skipped), source.whole(args.source)
    if args.problems is not None:
        problems, skipped = folder_problems(args.problems)
        return problems, skipped, Path(args.problems).absolute().name
    return split_problems(args.split, args.seed), [], args.split.replace(":", "-")


def _check_policies(problems: list, settings) -> None:
    """Refuse, before any run, a ``temp`` planner without a policy for some problem's robot.

    Every run of it would otherwise be recorded as a crash.
    """
    from temp_gym.evaluation.benchmark import checkpoint_policy
    from temp_gym.models.registry import shipped_checkpoint

    for _, problem in {(p.robot, p.dim): (name, p) for name, p in problems}.values():
        if settings.checkpoint is not None:
            try:
                checkpoint_policy(settings.checkpoint, problem)
            except ValueError as error:
                raise ValueError(f"--checkpoint: {error}") from None
            continue
        try:
            shipped_checkpoint(problem.robot)
        except FileNotFoundError:
            raise ValueError(
                f"--planners temp: no pretrained policy ships for robot {problem.robot!r}; give "
                "one with --checkpoint PATH (trainers/bc.py trains one)"
            ) from None


def run(args: argparse.Namespace, source: ProblemSource | None = None) -> str:
    """Check the flags, load the problems, run what is missing, write the outputs.

    Returns the summary's Markdown (also printed).

    Raises:
        ValueError, JobError: a bad flag, problem set or output folder (one line).
    """
    if getattr(args, "overrides", None):
        raise ValueError(f"unexpected argument {args.overrides[0]!r}")
    register_robots(args.robot)
    settings = _settings(args)
    out = Path(args.out)
    # A generated split reads no folder: any --out will do.
    inputs = [args.source] if source is not None else [args.problems]
    _check_out(out, [given for given in inputs if given is not None])
    from temp_gym.evaluation.benchmark import check_manifest, run_benchmark

    check_manifest(out, settings)  # before the problems load: a wrong folder is found at once
    from temp_gym.evaluation.benchmark_problems import group_experiments, select_problems
    from temp_gym.evaluation.benchmark_report import write_outputs
    from temp_gym.files import DirectoryLock

    problems, skipped, whole = _load(args, source)
    problems, more = select_problems(problems)
    skipped += more
    for name, reason in skipped:
        report(one_line(f"{PROG}: skipping {name}: {reason}"))
    if not problems:
        raise ValueError("problems: no problem left to run (every one was skipped)")
    if "temp" in settings.planners:
        _check_policies(problems, settings)
    experiments = group_experiments(problems, args.group, whole)
    if args.limit is not None:
        experiments = {name: sorted(members, key=lambda named: named[0])[: args.limit]
                       for name, members in experiments.items()}  # fmt: skip
        problems = [named for members in experiments.values() for named in members]
    records = run_benchmark(problems, settings, out, workers=args.workers or 1,
                            backend=args.backend, address=args.ray_address,
                            progress=not args.no_progress)  # fmt: skip
    # Another run of the same command may be writing them too: one at a time, each whole.
    with DirectoryLock(out, "writing the benchmark's outputs", wait=True):
        text = write_outputs(experiments, records, settings, out, skipped)
    print(text)
    report(f"logs: {out / 'logs'}; database: {out / 'benchmark.db'}; plots: {out / 'plots'}")
    return text


def main(argv: Sequence[str] | None = None, source: ProblemSource | None = None) -> int:
    """Run the command line; 0 done, 2 bad input (one line), 130 interrupted."""
    parser = build_parser(source)
    args = parser.parse_args(argv)
    return run_checked(args, source)


def run_checked(args: argparse.Namespace, source: ProblemSource | None = None) -> int:
    """`run`, with a bad input as one line and exit status 2, Ctrl-C as 130."""
    try:
        run(args, source)
    except (ValueError, OSError, ImportError, JobError) as error:
        print(one_line(f"{PROG}: error: {error}"), file=sys.stderr, flush=True)
        return BAD_INPUT
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted; rerun the same command to resume", file=sys.stderr)
        return INTERRUPTED
    return 0


if __name__ == "__main__":
    sys.exit(main())


__all__ = ["ProblemSource", "build_parser", "main", "run", "run_checked"]
