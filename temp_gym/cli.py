"""``temp-plan``: solve problem files from the command line.

Example:
    $ temp-plan problem.json                  # TEMP with the shipped policy for the robot
    $ temp-plan problem.json --planner informed_rrt_star --seed 3 --max-nodes 2000 --out r.json
    informed_rrt_star seed=3: cost 26.8120, 2000 nodes, ...
    $ temp-plan problem.json --checkpoint runs/TEMP-2D-v0__quick__0/best.pt   # your own policy
    $ temp-plan problems/*.json --out-dir results/   # batch: one process, one result each
    $ temp-plan problem.json --set attention_patience=60   # any setting of the planner's class

``--set KEY=VALUE`` (repeatable) sets any field of the planner's settings class
(`temp_gym.planning.PLANNERS`; `temp_gym.planning.TEMPSettings` for ``temp``) that has no flag
of its own (a key with a flag is refused: one value, one place); the epilog of ``--help``
lists them. TEMP's settings not given take the policy's own: the shipped policy's,
or those a ``--checkpoint`` carries.

Batch mode plans every file in one process, so start-up (imports, the per-process warm-up of
the compiled kernels, loading the policy) is paid once; each file gets a summary line and,
with ``--out-dir``, ``{out-dir}/{file stem}.json``. A bad file is reported and skipped.

Every flag is checked before anything is planned or written. An output never replaces a
problem file given as input, nor any existing file that is not a result of ``temp-plan``
(recognised by its ``format`` field, `RESULT_FORMAT`).

Exit status (`EXIT_CODES`): 0 every problem was solved, 3 no path was found for some
problem, 2 bad input (a one-line error on stderr per bad file or argument, no traceback),
130 interrupted. 1 is left to Python: an unexpected error, with its traceback, is a bug.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import textwrap
from collections.abc import Sequence
from pathlib import Path

from temp_gym.config.checks import check_output_dir
from temp_gym.config.command_line import (
    CommandParser,
    DefaultsHelpFormatter,
    add_robot_argument,
    register_robots,
)
from temp_gym.jobs import BAD_INPUT, INTERRUPTED, brief, display_path, one_line
from temp_gym.limits import MAX_PROBLEM_BYTES

SOLVED = 0
NO_PATH = 3
EXIT_CODES = {
    SOLVED: "every problem solved",
    BAD_INPUT: "bad input",
    NO_PATH: "no path found",
    INTERRUPTED: "interrupted",
}
"""Exit status -> meaning."""

RESULT_FORMAT = "temp-gym plan result"
"""The ``format`` field of every result file ``temp-plan`` writes: an existing file is replaced
only if it has it (or is a result written before the field, `_LEGACY_RESULT_KEYS`)."""
_LEGACY_RESULT_KEYS = {"planner", "success", "path", "cost", "nodes", "history", "seed"}

BUILT_IN_PLANNERS = ("temp", "rrt_star", "informed_rrt_star", "rrt_connect", "ompl_rrt_star",
                     "ompl_informed_rrt_star", "ompl_rrt_connect", "ompl_bit_star")  # fmt: skip
"""The planners `temp_gym.planning.PLANNERS` registers, for the help text alone: reading them
from the registry would load numba (a second) on every ``--help``. A test keeps both equal;
``--planner`` is checked against the registry itself, planners registered later included."""
DEFAULT_MAX_NODES = 5000
"""`temp_gym.planning.PlanSettings.max_nodes`, for the help text alone (a test keeps both
equal)."""
OWN_SETTINGS = {"rrt_connect": ("range",), "ompl_rrt_star": ("k_nearest", "range"),
                "ompl_informed_rrt_star": ("k_nearest", "range"), "ompl_rrt_connect": ("range",),
                "ompl_bit_star": ("k_nearest", "samples_per_batch")}  # fmt: skip
"""The own fields of the settings classes that load the planners (`RRTConnectSettings` and
the OMPL planners'), for the help text alone: reading them would load numba (a test keeps both
equal)."""


class _HelpFormatter(DefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Every flag's default shown (`DefaultsHelpFormatter`), the epilog's lines kept."""


def own_settings() -> dict[str, list[str]]:
    """Built-in planner -> the settings of its class beyond the common ones, for ``--help``.

    Read from the settings classes that load without the planners (`PlanSettings`,
    `TEMPSettings`) and `OWN_SETTINGS`; ``rrt_star`` and ``informed_rrt_star`` have none.
    """
    from temp_gym.planning.settings import PlanSettings, field_names
    from temp_gym.planning.temp_settings import TEMPSettings

    common = field_names(PlanSettings)
    temp = sorted(field_names(TEMPSettings) - common - {"policy"})
    return {"temp": temp} | {name: sorted(own) for name, own in OWN_SETTINGS.items()}


def _parser() -> argparse.ArgumentParser:
    from temp_gym.planning.settings import PlanSettings, field_names

    listed = [f"every planner takes {', '.join(sorted(field_names(PlanSettings)))}"] + [
        f"{name} also {', '.join(names)}" for name, names in own_settings().items()
    ]
    parser = CommandParser(
        prog="temp-plan",
        description="Solve temp-gym problem JSON files with one planner.",
        formatter_class=_HelpFormatter,
        epilog=textwrap.fill("settings of --set: " + "; ".join(listed) + ".", 79)
        + "\n\n"
        + textwrap.fill(
            "exit status: "
            + ", ".join(f"{code} {meaning}" for code, meaning in EXIT_CODES.items())
            + ". Units: world units (point robots) or radians (the arm).",
            79,
        ),
    )
    parser.add_argument(
        "problems",
        nargs="+",
        metavar="problem",
        help="problem JSON files (temp_gym.problem; docs/security.md lists the sizes accepted)",
    )
    add_robot_argument(parser)
    parser.add_argument(
        "--planner",
        default="temp",
        help=f"one of {', '.join(BUILT_IN_PLANNERS)}, or one registered with "
        "temp_gym.planning.register_planner",
    )
    parser.add_argument(
        "--checkpoint", default=None, help="temp: a trained policy (None: the shipped one)"
    )
    parser.add_argument(
        "--attention-nodes",
        type=int,
        default=None,
        help="temp: attention-phase budget n, in tree nodes (None: the policy's)",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the planner's generator")
    parser.add_argument(
        "--time-limit",
        type=float,
        default=None,
        help="seconds of search per problem (None: no limit; see temp_gym.plan for what it covers)",
    )
    parser.add_argument(
        "--max-nodes",
        type=int,
        default=DEFAULT_MAX_NODES,
        help="tree-size budget, in nodes",
    )
    parser.add_argument(
        "--step-size",
        type=float,
        default=None,
        help="steering step: the longest tree edge, in world units for a point robot or "
        "radians for the arm (None: the robot's, 5%% of the bounds' largest side for a point "
        "robot, 0.5 rad for the arm)",
    )
    parser.add_argument("--stop-at-first", action="store_true", help="stop at the first solution")
    parser.add_argument(
        "--simplify",
        action="store_true",
        help="shorten the found path by vertex reduction and random shortcuts, certified again "
        "(temp_gym.planning.simplify)",
    )
    parser.add_argument(
        "--set",
        dest="settings",
        action="append",
        default=None,
        metavar="KEY=VALUE",
        help="a setting of the planner's settings class, repeatable; listed below, e.g. "
        "attention_patience=60 (None: the defaults; TEMP's: the policy's own)",
    )
    parser.add_argument(
        "--out",
        default=None,
        help="one problem: write its result (path included) as JSON to this file (None: "
        "print the summary line only)",
    )
    parser.add_argument(
        "--out-dir",
        default=None,
        help="write each result to {out-dir}/{problem file stem}.json, making the folder "
        "(None: print the summary lines only)",
    )
    parser.add_argument(
        "--view",
        action="store_true",
        help="one problem: then show the scene, tree and path in the browser at "
        "http://127.0.0.1:8080 (needs temp-gym[view]) until Ctrl-C",
    )
    return parser


def _error(message: object) -> None:
    print(one_line(f"temp-plan: error: {message}"), file=sys.stderr, flush=True)


def _settings(args: argparse.Namespace):
    """The planner's settings of the flags and ``--set`` items, checked before any planning.

    Raises:
        ValueError: one line naming the flag (``--max-nodes``, ``--set KEY``) and the reason.
    """
    from temp_gym.planning import PLANNERS
    from temp_gym.planning.registry import owners_of, planners_phrase, settings_for

    if args.planner not in PLANNERS:
        raise ValueError(f"--planner: unknown planner {brief(args.planner)}; expected one of "
                         f"{sorted(PLANNERS)}")  # fmt: skip
    if args.time_limit is not None and not args.time_limit >= 0:  # inf: no limit, as plan()
        raise ValueError(f"--time-limit: expected a number of seconds >= 0, got "
                         f"{args.time_limit}")  # fmt: skip
    given = {}
    for item in args.settings or ():
        key, sep, text = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"--set {brief(item)}: expected KEY=VALUE")
        if key == "policy":
            raise ValueError("--set policy: give a trained policy as --checkpoint PATH")
        given[key] = _setting_value(text)
    flags = {"seed": args.seed, "max_nodes": args.max_nodes, "time_limit": args.time_limit,
             "stop_at_first": args.stop_at_first, "step_size": args.step_size}  # fmt: skip
    if args.attention_nodes is not None:
        flags["attention_nodes"] = args.attention_nodes
    for key in given:  # two places for one value: which would win is no user's guess
        if key in (*flags, "attention_nodes"):
            flag = f"--{key.replace('_', '-')}"
            raise ValueError(f"--set {key}: {key} has its own flag; give it as {flag}")
        owners = owners_of(key)
        if owners and args.planner not in [owner.name for owner in owners]:
            takes = "takes" if len(owners) == 1 else "take"
            use = f"--planner {owners[0].name} --set {key}=..."
            raise ValueError(f"--set {key}: only {planners_phrase(owners)} {takes} it, not "
                             f"{args.planner}; use {use}")  # fmt: skip
    try:
        return settings_for(args.planner, None, **{**flags, **given})
    except (TypeError, ValueError) as error:  # "max_nodes: ..." names the flag --max-nodes
        field, _, reason = str(error).partition(":")
        if field in given:
            raise ValueError(f"--set {field}:{reason}") from None
        if field in flags:
            raise ValueError(f"--{field.replace('_', '-')}:{reason}") from None
        raise ValueError(str(error)) from None


def _setting_value(text: str):
    """A ``--set`` value: a YAML scalar (``60``, ``0.5``, ``true``, ``null``), else the text.

    Numbers YAML reads as text (``1e-3``) are numbers here; an empty value is None (not set).
    """
    from temp_gym.config.loading import parse_value

    if not text.strip():
        return None
    value = parse_value(text)
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return value


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def _is_our_result(path: Path) -> bool:
    """Whether ``path`` holds a result ``temp-plan`` wrote (`RESULT_FORMAT`)."""
    try:
        with open(path, "rb") as handle:
            raw = handle.read(MAX_PROBLEM_BYTES + 1)
        data = json.loads(raw.decode("utf-8")) if len(raw) <= MAX_PROBLEM_BYTES else None
    except (OSError, ValueError, RecursionError):
        return False
    if not isinstance(data, dict):
        return False
    return data.get("format") == RESULT_FORMAT or _LEGACY_RESULT_KEYS <= set(data)


def _check_output(out: Path, inputs: list[Path], flag: str) -> None:
    """Refuse an output that is an input, or an existing file that is not our result."""
    shown = display_path(out)
    for given in inputs:
        if out.absolute() == given.absolute() or _same_file(out, given):
            raise ValueError(f"{flag}: {shown} is the problem file {display_path(given)}; "
                             "choose another output")  # fmt: skip
    if out.is_dir():
        raise ValueError(f"{flag}: {shown} is a directory")
    if out.exists() and not _is_our_result(out):
        raise ValueError(f"{flag}: {shown} exists and is not a temp-plan result; move it or "
                         "choose another output")  # fmt: skip
    try:
        check_output_dir(out.parent, flag)
    except ValueError as error:
        raise ValueError(str(error)) from None


def _outputs(args: argparse.Namespace) -> list[Path | None]:
    """Where each problem's result goes (None: nowhere), checked before any planning."""
    if args.out is not None and len(args.problems) > 1:
        raise ValueError("--out takes one problem; use --out-dir for several")
    if args.out is not None and args.out_dir is not None:
        raise ValueError("--out and --out-dir: give one of them")
    inputs = [Path(problem) for problem in args.problems]
    if args.out is not None:
        out = Path(args.out)
        _check_output(out, inputs, "--out")
        return [out]
    if args.out_dir is None:
        return [None] * len(args.problems)
    out_dir = Path(args.out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ValueError(f"--out-dir: {display_path(out_dir)} is not a directory")
    check_output_dir(out_dir, "--out-dir")
    stems = [path.stem for path in inputs]
    repeated = sorted({stem for stem in stems if stems.count(stem) > 1})
    if repeated:
        raise ValueError(f"--out-dir: several problems would write {display_path(repeated[0])}"
                         ".json")  # fmt: skip
    outputs = [out_dir / f"{stem}.json" for stem in stems]
    for out in outputs:
        _check_output(out, inputs, "--out-dir")
    return outputs


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


def _solve(path: str, args: argparse.Namespace, settings):
    """Plan one problem file; bad input raises `ValueError`/`OSError`."""
    from temp_gym.planning import plan
    from temp_gym.problem import Problem

    problem = Problem.load(path)
    policy = getattr(settings, "policy", None)
    if policy is not None and args.checkpoint is not None:
        from temp_gym.planning.policy import check_compatible

        check_compatible(policy.robot, policy.dim, problem.robot, problem.dim, args.checkpoint)
    return plan(problem, args.planner, settings, simplify=args.simplify)


def _check_view(args: argparse.Namespace) -> None:
    """``--view`` takes one problem and the viewer's extra (`temp_gym.viewer`)."""
    if len(args.problems) > 1:
        raise ValueError("--view takes one problem")
    from temp_gym.viewer.plan_viewer import require_viser

    require_viser()


def _view(path: str, result) -> None:
    """Serve the plan in the browser until Ctrl-C (`temp_gym.viewer.serve_plan`)."""
    from temp_gym.problem import Problem
    from temp_gym.viewer import serve_plan

    def announce(line: str) -> None:
        print(f"temp-plan: {line}", flush=True)

    serve_plan(Problem.load(path), result=result, announce=announce)


def _write(result, out: Path, flag: str) -> None:
    """Write ``result`` as JSON to ``out``; a failure names the flag and the file."""
    from temp_gym.files import write_json_atomic

    try:
        write_json_atomic(out, {"format": RESULT_FORMAT, **result.to_dict()},
                          indent=None, sort_keys=False)  # fmt: skip
    except OSError as error:
        raise OSError(
            f"{flag}: cannot write {display_path(out)} ({error.strerror or error})"
        ) from None


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (`EXIT_CODES`)."""
    args = _parser().parse_args(argv)
    batch = len(args.problems) > 1
    try:
        register_robots(args.robot)
        settings = _settings(args)
        outputs = _outputs(args)
        if args.view:
            _check_view(args)
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
        shown = display_path(path)
        try:
            result = _solve(path, args, settings)
        except (OSError, ValueError, ImportError) as error:
            message = str(error)
            _error(f"{shown}: {message}" if batch and str(path) not in message else message)
            status = BAD_INPUT
            continue
        except KeyboardInterrupt:
            _error("interrupted")
            return INTERRUPTED
        print(f"{shown}: {result.summary()}" if batch else result.summary(), flush=True)
        if out is not None:  # after the summary, so a failed write loses no figure
            try:
                _write(result, out, "--out" if args.out is not None else "--out-dir")
            except OSError as error:
                _error(error)
                status = BAD_INPUT
                continue
        if not result.success and status == SOLVED:
            status = NO_PATH
        if args.view:
            try:
                _view(path, result)
            except (OSError, ValueError) as error:  # a robot it cannot draw, a busy address
                _error(f"--view: {error}")
                return BAD_INPUT
    return status


if __name__ == "__main__":
    sys.exit(main())
