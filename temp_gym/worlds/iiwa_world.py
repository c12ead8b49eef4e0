"""Random, structured workspaces and start-goal tasks for the KUKA iiwa 14.

A workspace is a floor slab just below the base plus three or four furniture templates placed
in the arm's reach, each built from axis-aligned boxes:

========  ==============================================================================
template  boxes
========  ==============================================================================
table     a top board on four legs, in front of one side of the robot
shelf     two side panels, a back panel and three or four boards
pillar    one tall square column anywhere around the robot
wall      one thin, wide plate on one side
========  ==============================================================================

Tables, shelves and walls face the robot from one of the four axis directions (boxes stay
axis-aligned); their distance, size and lateral offset are random. Nothing touches link_0,
and about half of the random joint configurations are collision-free (the tests check the
fraction stays within 30-80 %), so tasks are plannable but not trivial.

Start and goal keep a clearance of half the edge checker's resolution (1 cm) from every box.
The certified edge check grows the spheres at an edge's end states by up to that much, so a
state that is free but closer to a box is a trap: no edge of planning length leaves it. Before
this rule, 4 of the 200 7D test tasks had such a start and no planner could grow a tree there.

Difficulty of a task, measured with the fast checker (which is conservative, so the exact
checker agrees that start and goal are free):

* ``"easy"``: the straight joint-space motion from start to goal is free;
* ``"challenging"``: it is blocked, so a planner has to go around;
* ``"any"``: either.

All randomness comes from the `numpy.random.Generator` passed in: the same seed gives the
same workspace and tasks.

Examples:
    >>> rng = np.random.default_rng(0)
    >>> workspace = generate_iiwa_workspace(KUKA_IIWA14.name, rng)
    >>> problem = generate_iiwa_task(workspace, rng, "challenging", goal_radius=0.1)
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from temp_gym.problem import Problem, Workspace
from temp_gym.worlds.collision.iiwa_fast import IiwaSphereChecker
from temp_gym.worlds.difficulty import check_difficulty
from temp_gym.worlds.iiwa14.kinematics import NUM_JOINTS, joint_limits

FLOOR_TOP = -0.01
"""Top of the floor slab (m); link_0's lowest point is at z = 0."""
SIDES = (
    # (radial axis, sign): a template "in front of" the robot along +x, -x, +y or -y.
    (0, 1.0),
    (0, -1.0),
    (1, 1.0),
    (1, -1.0),
)

Box = tuple[np.ndarray, np.ndarray]
"""A box as ``(center, half extents)``."""


def floor_slab() -> Box:
    """The floor: a slab just below the base, wider than the arm's reach."""
    return np.array([0.0, 0.0, FLOOR_TOP - 0.05]), np.array([1.5, 1.5, 0.05])


def place(side: int, radial: float, lateral: float, z: float, half: tuple) -> Box:
    """A box given in a side's frame as a world ``(center, half)``.

    ``side`` indexes `SIDES`; position and ``half`` are (radial, lateral, z) in its frame.
    """
    axis, sign = SIDES[side]
    center = np.zeros(3)
    center[axis] = sign * radial
    center[1 - axis] = lateral
    center[2] = z
    half_world = np.zeros(3)
    half_world[axis], half_world[1 - axis], half_world[2] = half
    return center, half_world


def _table(rng: np.random.Generator, side: int) -> list[Box]:
    near = rng.uniform(0.25, 0.5)
    depth, width = rng.uniform(0.15, 0.3), rng.uniform(0.25, 0.5)
    top, thickness = rng.uniform(0.05, 0.55), rng.uniform(0.01, 0.025)
    lateral = rng.uniform(-0.3, 0.3)
    radial = near + depth
    leg = rng.uniform(0.015, 0.03)
    height = (top - thickness - FLOOR_TOP) / 2
    boxes = [place(side, radial, lateral, top, (depth, width, thickness))]
    for dr in (-1, 1):
        for dl in (-1, 1):
            boxes.append(
                place(side, radial + dr * (depth - leg), lateral + dl * (width - leg),
                       FLOOR_TOP + height, (leg, leg, height))
            )  # fmt: skip
    return boxes


def _shelf(rng: np.random.Generator, side: int) -> list[Box]:
    near = rng.uniform(0.4, 0.6)
    depth, width = rng.uniform(0.12, 0.2), rng.uniform(0.25, 0.45)
    height, panel = rng.uniform(0.5, 0.75), rng.uniform(0.01, 0.02)
    lateral = rng.uniform(-0.35, 0.35)
    radial = near + depth
    z = FLOOR_TOP + height
    boxes = [
        place(side, radial, lateral + dl * (width + panel), z, (depth, panel, height))
        for dl in (-1, 1)
    ]
    boxes.append(place(side, radial + depth + panel, lateral, z, (panel, width + 2 * panel,
                                                                   height)))  # fmt: skip
    for board_z in np.linspace(FLOOR_TOP, FLOOR_TOP + 2 * height, rng.integers(3, 5) + 1)[1:]:
        boxes.append(place(side, radial, lateral, board_z - panel, (depth, width, panel)))
    return boxes


def _pillar(rng: np.random.Generator, side: int) -> list[Box]:
    del side  # pillars stand anywhere around the robot
    distance, angle = rng.uniform(0.4, 0.85), rng.uniform(0, 2 * np.pi)
    half = rng.uniform(0.03, 0.08)
    height = rng.uniform(0.6, 0.9)
    center = np.array([distance * np.cos(angle), distance * np.sin(angle), FLOOR_TOP + height])
    return [(center, np.array([half, half, height]))]


def _wall(rng: np.random.Generator, side: int) -> list[Box]:
    radial, thickness = rng.uniform(0.5, 0.85), rng.uniform(0.01, 0.03)
    width, height = rng.uniform(0.3, 0.8), rng.uniform(0.4, 0.8)
    lateral = rng.uniform(-0.4, 0.4)
    return [place(side, radial, lateral, FLOOR_TOP + height, (thickness, width, height))]


TEMPLATES = {"table": _table, "shelf": _shelf, "pillar": _pillar, "wall": _wall}


def box_corners(boxes: list[Box]) -> tuple[np.ndarray, np.ndarray]:
    """The ``(lower, upper)`` corners of ``(center, half)`` boxes, one row per box."""
    lower = np.array([c - h for c, h in boxes])
    upper = np.array([c + h for c, h in boxes])
    return lower, upper


def draw_base_free(
    build: Callable[[np.random.Generator, int], list[Box]],
    rng: np.random.Generator,
    side: int,
    tries: int,
    what: str,
) -> list[Box]:
    """``build(rng, side)`` redrawn until its boxes keep clear of link_0.

    Raises:
        RuntimeError: every one of ``tries`` draws touched the base (the message names
            ``what``).
    """
    for _ in range(tries):
        boxes = build(rng, side)
        if IiwaSphereChecker(joint_limits(), *box_corners(boxes)).base_free:
            return boxes
    raise RuntimeError(f"{what}: no base-free placement in {tries} draws")


def generate_iiwa_workspace(
    robot: str, rng: np.random.Generator, max_tries: int = 100
) -> Workspace:
    """Draw a floor and 3-4 random furniture templates in the iiwa's reach.

    Args:
        robot: the iiwa's registered name (`temp_gym.worlds.robots.kuka_iiwa14`).
        rng: the only source of randomness.
        max_tries: templates redrawn when one touches the robot's base, before giving up.

    Raises:
        ValueError: ``rng`` is not a `numpy.random.Generator`.
        RuntimeError: no base-free placement was found in ``max_tries`` draws.
    """
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng: expected a numpy.random.Generator, got {type(rng).__name__}")
    bounds = joint_limits()
    boxes: list[Box] = [floor_slab()]
    names = list(TEMPLATES)

    def any_template(rng: np.random.Generator, side: int) -> list[Box]:
        return TEMPLATES[names[rng.integers(len(names))]](rng, side)

    sides = list(rng.permutation(len(SIDES)))
    for _ in range(int(rng.integers(3, 5))):
        side = int(sides.pop())
        boxes += draw_base_free(any_template, rng, side, max_tries, "generate_iiwa_workspace")
    centers = np.array([c for c, _ in boxes])
    halves = np.array([h for _, h in boxes])
    return Workspace(robot, bounds, centers, halves)


def generate_iiwa_task(
    workspace: Workspace,
    rng: np.random.Generator,
    difficulty: str,
    goal_radius: float,
    max_tries: int = 2000,
) -> Problem:
    """Draw a free start and goal in ``workspace`` matching ``difficulty``.

    Args:
        workspace: an iiwa workspace, e.g. from `generate_iiwa_workspace`.
        rng: the only source of randomness.
        difficulty: ``"easy"`` (straight motion free), ``"challenging"`` (blocked) or
            ``"any"``; see the module docstring.
        goal_radius: radius (rad) of the goal ball; start and goal are more than two radii apart.
        max_tries: start-goal pairs drawn before giving up.

    Raises:
        ValueError: bad ``workspace``, ``difficulty`` or ``goal_radius``.
        RuntimeError: no pair matched within ``max_tries``.
    """
    if not isinstance(workspace, Workspace) or workspace.dim != NUM_JOINTS:
        raise ValueError(f"workspace: expected an iiwa Workspace, got {workspace!r}")
    check_difficulty(difficulty)
    if not (isinstance(goal_radius, (int, float)) and 0 < goal_radius < np.inf):
        raise ValueError(f"goal_radius: expected a positive number, got {goal_radius!r}")
    checker = IiwaSphereChecker(
        workspace.bounds, workspace.obstacle_lower, workspace.obstacle_upper
    )
    lower, upper = workspace.bounds
    clearance = checker.resolution / 2  # so that edges can leave start and goal (docstring)
    batch = 64
    for first in range(0, max_tries, batch):
        count = min(batch, max_tries - first)
        starts = rng.uniform(lower, upper, size=(count, NUM_JOINTS))
        goals = rng.uniform(lower, upper, size=(count, NUM_JOINTS))
        ok = checker.states_free(starts, clearance) & checker.states_free(goals, clearance)
        ok &= np.linalg.norm(goals - starts, axis=1) > 2 * goal_radius
        if difficulty != "any":
            straight = checker.edges_free(starts, goals)
            ok &= straight if difficulty == "easy" else ~straight
        hits = np.flatnonzero(ok)
        if len(hits):
            k = hits[0]
            return Problem(workspace, starts[k], goals[k], float(goal_radius))
    raise RuntimeError(
        f"generate_iiwa_task: no {difficulty!r} start-goal pair in {max_tries} tries"
    )


__all__ = [
    "FLOOR_TOP",
    "SIDES",
    "TEMPLATES",
    "box_corners",
    "draw_base_free",
    "floor_slab",
    "generate_iiwa_task",
    "generate_iiwa_workspace",
    "place",
]
