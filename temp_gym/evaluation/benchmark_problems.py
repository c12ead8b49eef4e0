"""The problem sets a benchmark runs: named problems, grouped into experiments.

A problem set is a list of ``(name, Problem)``: from a folder of problem JSON files
(`folder_problems`; a file ``walls/0003.json`` is named ``walls/0003``), from the evaluation's
generated test tasks (`split_problems`), or from any loader returning that list (a
MotionBenchMaker archive through ``temp_gym.benchmarks.motionbenchmaker.load``, named
``<scene>/<NNNN>``). `group_experiments` splits the set into experiments, one benchmark log
each: by scene (the part of a name before its last ``/``), one for the whole set, or one per
problem as OMPL's Benchmark runs them.

A problem whose start or goal is not free cannot be a `Problem` (its constructor refuses it),
so a folder's file whose start or goal is invalid is skipped and listed, not fatal; a
``skip`` callable (`select_problems`) skips more, e.g. a loader's own validity test.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Callable, Collection, Sequence
from pathlib import Path

from temp_gym.limits import MAX_TASKS
from temp_gym.problem import Problem

GROUPINGS = ("scene", "one", "problem")
"""How problems group into experiments: by scene, all in one, one per problem."""
NamedProblem = tuple[str, Problem]
SkipRule = Callable[[str, Problem], "str | None"] | Collection[str] | None
"""What to skip besides the problems that cannot load: a callable giving the reason to skip
a problem (None: keep it), or the names of the problems to skip."""

_ENDPOINT_ERROR = re.compile(r"^(start|goal)\b")


def folder_problems(folder: str | Path) -> tuple[list[NamedProblem], list[tuple[str, str]]]:
    """The problem files under ``folder`` (recursively, sorted), and those skipped.

    Returns ``(problems, skipped)``: ``skipped`` lists ``(name, reason)`` for each file whose
    start or goal is invalid (out of bounds or in collision).

    Raises:
        ValueError: ``folder`` is not a folder, holds no ``.json`` file, or holds a file that
            is no problem for another reason (naming the file and the field).
    """
    root = Path(folder)
    if not root.is_dir():
        what = "does not exist" if not root.exists() else "is not a folder"
        raise ValueError(f"problems: {folder} {what}")
    paths = sorted(path for path in root.rglob("*.json") if path.is_file())
    if not paths:
        raise ValueError(f"problems: {folder} holds no problem .json file")
    problems, skipped = [], []
    for path in paths:
        name = path.relative_to(root).with_suffix("").as_posix()
        try:
            problem = Problem.load(path)
        except ValueError as error:
            if _ENDPOINT_ERROR.match(str(error)):
                skipped.append((name, str(error)))
                continue
            raise ValueError(f"problems: {path}: {error}") from None
        except OSError as error:
            raise ValueError(f"problems: {path}: {error.strerror or error}") from None
        problems.append((name, problem))
    return problems, skipped


def split_problems(spec: str, seed: int = 0) -> list[NamedProblem]:
    """The evaluation's test tasks of ``spec`` = ``ROBOT:DIFFICULTY:COUNT``.

    Task ``i`` is `temp_gym.evaluation.runner.evaluation_problem` ``(robot, difficulty, i,
    seed)``, named ``{robot}-{difficulty}/{i:04d}``: unseen test workspaces, deterministic.

    Raises:
        ValueError: a malformed spec, an unknown robot or difficulty, a count below 1 or
            above `MAX_TASKS`.
    """
    from temp_gym.evaluation.runner import _DIFFICULTY_CODES, evaluation_problem
    from temp_gym.worlds.robots import robot_spec

    robot, difficulty, count = (spec.split(":") + ["", "", ""])[:3]
    if spec.count(":") != 2 or not count.isdigit() or int(count) < 1:
        raise ValueError(f"split: expected ROBOT:DIFFICULTY:COUNT (COUNT >= 1), got {spec!r}")
    if int(count) > MAX_TASKS:  # the evaluation's bound: a huge count would draw for days
        raise ValueError(f"split: COUNT must be at most {MAX_TASKS:,}, got {int(count):,}")
    if difficulty not in _DIFFICULTY_CODES:
        raise ValueError(f"split: difficulty {difficulty!r} is none of {sorted(_DIFFICULTY_CODES)}")
    try:
        robot_spec(robot)
    except (KeyError, ValueError) as error:
        raise ValueError(f"split: {error}") from None
    return [
        (f"{robot}-{difficulty}/{index:04d}", evaluation_problem(robot, difficulty, index, seed))
        for index in range(int(count))
    ]


def select_problems(
    problems: Sequence[NamedProblem], skip: SkipRule = None
) -> tuple[list[NamedProblem], list[tuple[str, str]]]:
    """``problems`` without those ``skip`` names, and the skipped ones with their reasons.

    Raises:
        ValueError: two problems with the same name (their runs could not be told apart).
    """
    seen: set[str] = set()
    for name, _ in problems:
        if name in seen:
            raise ValueError(f"problems: two problems are named {name!r}")
        seen.add(name)
    kept, skipped = [], []
    for name, problem in problems:
        if skip is None:
            reason = None
        elif callable(skip):
            reason = skip(name, problem)
        else:
            reason = "listed to skip" if name in skip else None
        if reason:
            skipped.append((name, str(reason)))
        else:
            kept.append((name, problem))
    return kept, skipped


def experiment_name(text: str) -> str:
    """``text`` as an experiment name: one word of letters, digits, ``.``, ``_``, ``-``.

    OMPL's readers keep only the last word of the ``Experiment`` line, and the name also
    names the experiment's files.
    """
    name = re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("._") or "problems"
    return name


def group_experiments(
    problems: Sequence[NamedProblem], by: str = "scene", whole: str = "problems"
) -> dict[str, list[NamedProblem]]:
    """Experiment name -> its problems, in the order given.

    ``by``: ``scene`` (the part of each name before its last ``/``; a name without one is
    in the experiment ``whole``), ``one`` (all in ``whole``), ``problem`` (one experiment
    per problem).

    Raises:
        ValueError: an unknown ``by``, or two scenes that map to the same experiment name.
    """
    if by not in GROUPINGS:
        raise ValueError(f"group: expected one of {GROUPINGS}, got {by!r}")
    groups: dict[str, list[NamedProblem]] = {}
    sources: dict[str, str] = {}
    for name, problem in problems:
        if by == "one":
            label = whole
        elif by == "problem":
            label = name
        else:
            label = name.rpartition("/")[0] or whole
        experiment = experiment_name(label)
        if sources.setdefault(experiment, label) != label:
            raise ValueError(
                f"group: {sources[experiment]!r} and {label!r} both make experiment {experiment!r}"
            )
        groups.setdefault(experiment, []).append((name, problem))
    return groups


def problem_digest(problem: Problem) -> str:
    """A short digest of ``problem``'s JSON: a stored run counts only for the same problem."""
    text = json.dumps(problem.to_dict(), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


__all__ = [
    "GROUPINGS",
    "experiment_name",
    "folder_problems",
    "group_experiments",
    "problem_digest",
    "select_problems",
    "split_problems",
]
