"""MotionBenchMaker's Panda problems, loaded as they are: 7 scenes of 100 problems each.

MotionBenchMaker (Chamzas et al., 2022) ships each problem as a MoveIt planning scene
(``sceneNNNN.yaml``) and a motion-plan request (``requestNNNN.yaml``) in a folder per scene
(``box_panda/``, ``table_pick_panda/``, ...). VAMP's source distribution carries the Panda's
set as ``resources/panda/problems.tar.bz2`` (``docs/motionbenchmaker.md`` says how to get it).

The robot is ``franka_panda``, whose joints and limits are MotionBenchMaker's Panda's and
whose fingers it holds 6.5 cm open, as MotionBenchMaker's URDF fixes them. `load` reads every
problem without testing start and goal for collisions (`Problem.unchecked`), so the set loads
whole; `invalid` then lists the problems whose start or goal the exact checker calls in
collision, with its reason.

Example:
    >>> problems = load("problems.tar.bz2")
    >>> name, problem = problems[0]
    >>> name, len(problems), problem.robot
    ('bookshelf_small/0001', 700, 'franka_panda')
    >>> skipped = invalid(problems)   # {name: reason}
"""

from __future__ import annotations

import functools
import lzma
import re
import tarfile
import zlib
from collections.abc import Iterable
from pathlib import Path, PurePosixPath

import numpy as np

from temp_gym.limits import MAX_PROBLEM_BYTES
from temp_gym.problem import Problem, Workspace
from temp_gym.problem.parsing import positive_length
from temp_gym.worlds.checkers import make_checker
from temp_gym.worlds.robots import robot_spec
from temp_gym.worlds.robots.spec import refusal
from temp_gym.yaml_input import load_yaml

from .moveit import MoveItFile, request_joints, scene_obstacles

ROBOT = "franka_panda"
"""The robot MotionBenchMaker's Panda problems are loaded for."""
MODEL_NAME = "panda"
"""The ``robot_model_name`` of MotionBenchMaker's Panda scenes (its SRDF's robot name)."""
SCENE_SUFFIX = "_panda"
"""The suffix of MotionBenchMaker's Panda scene folders, left out of problem names."""
WORLD_FRAMES = {"", "world"}
"""Frame names of the scenes' world, which is the Panda base's frame (checked per scene)."""
FILE_NAME = re.compile(r"(scene|request)([0-9]+)\.yaml")
"""A problem's two files: ``sceneNNNN.yaml`` and ``requestNNNN.yaml``."""

_DAMAGED = (tarfile.TarError, OSError, EOFError, zlib.error, lzma.LZMAError)
"""What reading a damaged or truncated archive raises (bz2 reports its errors as `OSError`)."""

Files = dict[tuple[str, str], dict[str, tuple[str, bytes]]]
"""``(scene folder, number as written) -> {"scene" | "request": (file name for errors, bytes)}``."""


def load(path: str | Path, goal_radius: float | None = None) -> list[tuple[str, Problem]]:
    """Every problem of a MotionBenchMaker Panda set, as ``(name, problem)`` pairs.

    ``path`` is the ``problems.tar.bz2`` archive (read in memory, nothing is extracted) or an
    unpacked folder (``problems/`` or the folder holding it). A problem's name is its scene
    without ``_panda`` and its number as in its files, e.g. ``"table_pick/0001"``; the list is
    sorted by scene, then number. ``goal_radius`` is the goal region's radius in joint space
    (radians); None takes the Panda's default, its spec's ``goal_radius``.

    Start and goal are not tested for collisions here (`invalid` does that).

    Raises:
        ValueError: one line naming the file and field of anything it cannot represent:
            meshes, planes, cones, octomaps, attached objects, frames away from the robot
            base, a moved robot base, unknown joints, fingers not at the Panda's held
            opening, position or orientation goals, more than one goal.
    """
    spec = robot_spec(ROBOT)
    radius = (spec.goal_radius if goal_radius is None
              else positive_length(goal_radius, "goal_radius"))  # fmt: skip
    bounds = spec.joint_limits()
    joints, held, base = _panda()
    problems = []
    for (folder, number), pair in sorted(_problem_files(Path(path)).items(), key=_order):
        for kind in ("scene", "request"):
            if kind not in pair:
                other = next(iter(pair.values()))[0]
                raise ValueError(f"{other}: no {kind}{number}.yaml beside it")
        (scene_name, scene_bytes), (request_name, request_bytes) = pair["scene"], pair["request"]
        scene_file, request_file = MoveItFile(scene_name), MoveItFile(request_name)
        for name, data in ((scene_name, scene_bytes), (request_name, request_bytes)):
            if not data.strip():
                raise ValueError(f"{name}: the file is empty")
        scene = load_yaml(scene_bytes, scene_name)
        obstacles = scene_obstacles(scene_file, scene, MODEL_NAME, WORLD_FRAMES | {base})
        request = load_yaml(request_bytes, request_name)
        start, goal = request_joints(request_file, request, joints, held)
        try:
            workspace = Workspace.from_obstacles(ROBOT, bounds, obstacles)
        except ValueError as error:
            raise scene_file.error("world.collision_objects", str(error)) from None
        try:
            problem = Problem.unchecked(workspace, start, goal, radius)
        except ValueError as error:
            raise ValueError(f"{request_file.name}: {error}") from None
        problems.append((f"{folder.removesuffix(SCENE_SUFFIX)}/{number}", problem))
    return problems


def invalid(problems: Iterable[tuple[str, Problem]]) -> dict[str, str]:
    """The problems whose start or goal the exact checker calls in collision: name -> reason.

    The reason names the point (``start`` or ``goal``) and gives the exact checker's own
    words: the colliding link pairs, or the link touching an obstacle with the penetration.

    Example:
        >>> invalid(load("problems.tar.bz2"))["box/0042"]   # doctest: +SKIP
        'start: collision: panda_hand touches box 3, penetration 1.2 mm (fcl on ...)'
    """
    reasons = {}
    for name, problem in problems:
        checker = make_checker(problem, exact=True)
        states = np.stack([problem.start, problem.goal])
        free = checker.states_free(states)
        refused = [
            f"{point}: {refusal(checker, state)}"
            for point, state, ok in zip(("start", "goal"), states, free)
            if not ok
        ]
        if refused:
            reasons[name] = "; ".join(refused)
    return reasons


@functools.cache
def _panda() -> tuple[tuple[str, ...], dict[str, float], str]:
    """The Panda's joints, its held joints (the fingers) with their values, and its base link."""
    from temp_gym.worlds.arm.model import load_arm

    arm = load_arm(robot_spec(ROBOT).description)
    return arm.joint_names, dict(arm.chain.fixed_values), arm.body_names[0]


def _order(item: tuple[tuple[str, str], dict]) -> tuple[str, int]:
    """Problems sorted by scene name (without ``_panda``), then by number."""
    (folder, number), _ = item
    return folder.removesuffix(SCENE_SUFFIX), int(number)


def _problem_files(path: Path) -> Files:
    """Every scene and request file under ``path`` (an archive or a folder), by problem.

    A scene and its request pair up within one folder, by the number in their names (ASCII
    digits); a number written two ways (``scene1.yaml``, ``scene0001.yaml``) or a problem
    found in two folders of one name is refused, never left to chance.
    """
    if not path.exists():
        raise ValueError(f"path: {path} does not exist")
    if path.is_file():
        entries = _archive_entries(path)
    elif path.is_dir():
        entries = _folder_entries(path)
    else:
        raise ValueError(f"path: {path} is neither a folder nor a tar archive")
    files: Files = {}
    numbers: dict[tuple[str, str, int], tuple[str, str]] = {}  # -> (digits, a file's name)
    places: dict[tuple[str, str], str] = {}  # (folder, digits) -> its directory
    for directory, folder, file_name, size, read in entries:
        match = FILE_NAME.fullmatch(file_name)
        if match is None:
            continue
        name = f"{folder}/{file_name}"
        if not folder.isprintable():
            raise ValueError(f"{name!r}: a folder name with control characters")
        if not folder.endswith(SCENE_SUFFIX):
            raise ValueError(f"{name}: not a Panda problem (its folder does not end in "
                             f"{SCENE_SUFFIX!r})")  # fmt: skip
        if size > MAX_PROBLEM_BYTES:
            raise ValueError(f"{name}: larger than {MAX_PROBLEM_BYTES // 2**20} MB")
        kind, digits = match.groups()
        spelled, first = numbers.setdefault((directory, folder, int(digits)), (digits, name))
        if spelled != digits:
            raise ValueError(f"{name}: problem {int(digits)} is numbered {spelled} in {first}; "
                             "number a problem's scene and request alike, once")  # fmt: skip
        if places.setdefault((folder, digits), directory) != directory:
            both = f"{places[(folder, digits)] or '.'} and {directory or '.'}"
            raise ValueError(f"{name}: found in two folders named {folder} in {path} ({both})")
        pair = files.setdefault((folder, digits), {})
        if kind in pair:
            raise ValueError(f"{name}: found twice in {path}")
        pair[kind] = (name, read())
    if not files:
        inside = path.is_dir() and any(FILE_NAME.fullmatch(p.name) for p in path.iterdir())
        hint = f"; pass the folder that holds {path.name}" if inside else ""
        raise ValueError(
            f"path: no MotionBenchMaker problems in {path} (sceneNNNN.yaml and "
            f"requestNNNN.yaml in <scene>{SCENE_SUFFIX} folders){hint}"
        )
    return files


def _archive_entries(path: Path) -> list:
    """``(directory, folder, file name, size, read)`` of each problem file of a tar archive.

    Regular files and links to them (tar stores a hard-linked file's second name as a link);
    a member named outside the archive's own folders (absolute, or through ``..``) is
    refused, though nothing is ever extracted.
    """
    try:
        archive = tarfile.open(path, "r:*")
        entries = []
        with archive:
            for member in archive:
                name = PurePosixPath(member.name)
                parts = name.parts
                if len(parts) < 2 or not FILE_NAME.fullmatch(parts[-1]):
                    continue
                if name.is_absolute() or ".." in parts:
                    raise ValueError(f"{member.name}: an archive member outside the archive "
                                     "(absolute, or through '..'); not read")  # fmt: skip
                if not (member.isfile() or member.islnk() or member.issym()):
                    continue
                try:
                    handle = archive.extractfile(member)
                except KeyError:
                    handle = None
                if handle is None:
                    raise ValueError(f"{member.name}: a link to {member.linkname}, which the "
                                     "archive does not hold as a file")  # fmt: skip
                data = handle.read(MAX_PROBLEM_BYTES + 1)
                entries.append((str(name.parent.parent), parts[-2], parts[-1], len(data),
                                lambda data=data: data))  # fmt: skip
    except _DAMAGED as error:
        # tarfile's own messages run over several lines, one per compression it tried.
        reason = ("not a tar archive, plain or compressed, or a damaged or truncated one"
                  if isinstance(error, tarfile.ReadError) else
                  f"{type(error).__name__}: {' '.join(str(error).split())}")  # fmt: skip
        raise ValueError(
            f"path: {path} is neither a folder nor a readable tar archive ({reason})"
        ) from None
    return entries


def _folder_entries(path: Path) -> list:
    """``(directory, folder, file name, size, read)`` of the files of each scene folder."""
    root = path / "problems" if (path / "problems").is_dir() else path
    entries = []
    for folder in sorted(p for p in root.iterdir() if p.is_dir()):
        for file in sorted(folder.iterdir()):
            if file.is_file() and FILE_NAME.fullmatch(file.name):
                entries.append((str(root), folder.name, file.name, file.stat().st_size,
                                file.read_bytes))  # fmt: skip
    return entries


__all__ = ["load", "invalid"]
