"""``temp-view``: show a problem, and a stored path, in the browser.

Example:
    $ temp-view problem.json                  # the scene, start and goal
    $ temp-plan problem.json --out r.json && temp-view problem.json r.json
    $ temp-view my_arm_problem.json --robot my_arm.yaml   # an arm of your own
    temp-view: viewer at http://127.0.0.1:8080 (Ctrl-C to stop)

The path file is what ``temp-plan --out`` writes (a result with a ``"path"``), or a JSON
list of states. A result file holds no tree; ``temp-plan problem.json --view`` plans and
shows the tree too.

Exit status: 0 after Ctrl-C, 2 bad input (one line on stderr; nothing is served).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from temp_gym.config.command_line import add_robot_argument, register_robots
from temp_gym.jobs import BAD_INPUT

PROG = "temp-view"


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=PROG,
        description="Show a temp-gym problem, and optionally a stored path, in the browser "
        "(needs temp-gym[view]). Runs until Ctrl-C.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
        epilog="exit status: 0 stopped with Ctrl-C, 2 bad input",
    )
    parser.add_argument("problem", help="problem JSON file (temp_gym.problem)")
    parser.add_argument(
        "path",
        nargs="?",
        default=None,
        help="a result JSON of temp-plan --out, or a JSON list of states",
    )
    add_robot_argument(parser)
    parser.add_argument(
        "--host", default="127.0.0.1", help="address to serve on (127.0.0.1: this machine only)"
    )
    parser.add_argument(
        "--port", type=int, default=8080, help="port to serve on (busy: the next free one)"
    )
    return parser


def load_path(file: str | Path, dim: int) -> np.ndarray | None:
    """The states ``(K, dim)`` stored in ``file`` (None: a result without a solution).

    Raises:
        ValueError: naming the file and what is wrong with it.
        OSError: the file cannot be read.
    """
    try:
        text = Path(file).read_text()
    except OSError as error:  # the same kind of error, with a line a user can read
        reason = (error.strerror or type(error).__name__).lower()
        raise type(error)(f"{file}: cannot read the path file ({reason})") from None
    except UnicodeDecodeError as error:
        raise ValueError(f"{file}: not UTF-8 text (byte {error.start})") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as error:
        raise ValueError(f"{file}: not JSON ({error.msg}, line {error.lineno})") from None
    if isinstance(data, dict):
        if "path" not in data:
            raise ValueError(f"{file}: expected a result with a 'path', or a list of states")
        data = data["path"]
        if data is None:
            return None
    try:
        path = np.asarray(data, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{file}: path: expected a list of {dim}-number states") from None
    if path.ndim != 2 or path.shape[1] != dim or len(path) == 0:
        raise ValueError(
            f"{file}: path: expected a non-empty list of {dim}-number states, got shape "
            f"{path.shape}"
        )
    if not np.all(np.isfinite(path)):
        raise ValueError(f"{file}: path: expected finite numbers")
    return path


def path_outside_bounds(path: np.ndarray, problem) -> str | None:
    """Which state of ``path`` first leaves the problem's bounds, and how; None if none does."""
    from temp_gym.problem.query import outside_bounds
    from temp_gym.problem.robots import robot_named

    bounds = problem.bounds
    outside = np.flatnonzero(np.any((path < bounds[0]) | (path > bounds[1]), axis=1))
    if len(outside) == 0:
        return None
    joints = robot_named(problem.robot).joint_limits is not None
    first = int(outside[0])
    return (f"states outside the problem's bounds: {len(outside)} of {len(path)}; the first, "
            f"state {first}: {outside_bounds(path[first], bounds, joints)}")  # fmt: skip


def path_warning(path: np.ndarray, problem) -> str | None:
    """Why ``path`` is no solution of ``problem``, in one line; None when it is one.

    The viewer shows any path all the same; the warning keeps a stored path of another
    problem, or one in collision, from passing for a plan of this one.
    """
    from temp_gym.worlds.checkers import certify_path

    outside = path_outside_bounds(path, problem)
    if outside:
        return outside
    ends = problem.path_ends_error(path)
    if ends:
        return ends
    if not certify_path(problem, path):
        return "the exact collision checker refuses it (a state or motion in collision)"
    return None


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``temp-view``; returns the exit status."""
    args = _parser().parse_args(argv)
    try:
        from temp_gym.problem import Problem
        from temp_gym.viewer.plan_viewer import check_address, require_viser, serve_plan

        require_viser()
        check_address(args.host, args.port)
        register_robots(args.robot)
        problem = Problem.load(args.problem)
        path = None if args.path is None else load_path(args.path, problem.dim)
        if path is not None:
            warning = path_warning(path, problem)
            if warning:  # shown all the same: the viewer is for looking at any path
                print(f"{PROG}: warning: {args.path}: {warning}", file=sys.stderr)
        # Checked (the robot, the path) before anything is served.
        serve_plan(
            problem,
            path=path,
            host=args.host,
            port=args.port,
            announce=lambda line: print(f"{PROG}: {line}", flush=True),
        )
    except (OSError, ValueError, ImportError) as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return BAD_INPUT
    return 0


if __name__ == "__main__":
    sys.exit(main())
