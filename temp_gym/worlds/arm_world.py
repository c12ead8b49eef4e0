"""Random furniture workspaces and start-goal tasks for any arm.

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
axis-aligned); their distance, size and lateral offset are random. Sizes are drawn for an arm
of the iiwa's reach (`REFERENCE_REACH`) and the whole scene is then scaled by the arm's reach
over it (`arm_scale`), so every arm gets furniture of its own size. Nothing touches the base.

**Tasks.** A start and a goal are drawn uniformly in the joint limits until both are free
(fast checker: the exact checker then agrees). A share `NEAR_SURFACE_SHARE` of goals is drawn
*near a surface*: the arm within 2-10 mm of an obstacle, its hand nearest (`near_surface`), as
a grasp, a placement or an insertion has it; `generate_arm_task(..., near="both")` draws starts
there too. Edges leave and reach such states because the fast checker refines its edge checks
near surfaces (`temp_gym.worlds.collision.arm_fast`). Tasks can be drawn in any arm workspace,
whatever its obstacles' kinds: the checkers and `near_surface` measure every kind.

Difficulty of a task, measured with the fast checker:

* ``"easy"``: the straight joint-space motion from start to goal is free;
* ``"challenging"``: it is blocked, so a planner has to go around;
* ``"any"``: either.

All randomness comes from the `numpy.random.Generator` passed in: the same seed gives the
same workspace and tasks.

Examples:
    >>> rng = np.random.default_rng(0)
    >>> workspace = generate_arm_workspace("kuka_iiwa14", rng)
    >>> problem = generate_arm_task(workspace, rng, "challenging", goal_radius=0.1)
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from temp_gym.problem import Problem, Workspace
from temp_gym.worlds.arm.model import ArmModel, load_arm
from temp_gym.worlds.difficulty import check_difficulty

FLOOR_TOP = -0.01
"""Top of the floor slab (m) for an arm of `REFERENCE_REACH` whose base's lowest point is at
z = 0; scaled with the scene."""
REFERENCE_REACH = 1.5490807825132829
"""The reach (`ArmModel.reach`, m) the templates' sizes are drawn for: the iiwa's."""
NEAR_SURFACE_SHARE = 0.25
"""Share of drawn goals placed near a surface (`near_surface`)."""
NEAR_SURFACE = (0.002, 0.010)
"""How far (m, by the exact checker) from an obstacle a state near a surface is."""
NEAR_DRAW_BATCHES = 8
"""Batches of 256 uniform states drawn per attempt at states near a surface."""
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


def arm_of(robot: str) -> ArmModel:
    """The arm registered as ``robot`` (its spec's description, loaded)."""
    from temp_gym.worlds.robots import robot_spec

    spec = robot_spec(robot)
    if spec.description is None:
        raise ValueError(f"robot: {robot!r} is not an arm")
    return load_arm(spec.description)


def arm_scale(arm: ArmModel) -> float:
    """How much larger than the templates' drawn sizes an arm's scene is (1 for the iiwa)."""
    return arm.reach() / REFERENCE_REACH


def scene_drop(arm: ArmModel) -> float:
    """How far (m, at most 0) an arm's scene is lowered so that its floor stays below the base.

    The templates stand on a floor just below z = 0, where the built-in arms' bases end. A base
    that reaches lower (a round foot, a mount plate, a mobile base folded into it) would stand
    in that floor, and no state of the arm would be free: its scene goes down by the base's
    lowest point instead, when that is more than half the floor's gap below z = 0. Cached on
    the arm.
    """
    key = "scene_drop"
    if key not in arm._arrays:
        pieces = [piece for piece in arm.geometry[0].pieces if len(piece)]
        lowest = min((float(piece[:, 2].min()) for piece in pieces), default=0.0)
        arm._arrays[key] = lowest if lowest < FLOOR_TOP * arm_scale(arm) / 2 else 0.0
    return arm._arrays[key]


def scaled(boxes: list[Box], scale: float, drop: float = 0.0) -> list[Box]:
    """The scene ``boxes`` scaled about the origin (the base) by ``scale``, raised by ``drop``.

    ``drop`` is `scene_drop`, at most 0.
    """
    if scale == 1.0 and drop == 0.0:
        return boxes
    lowered = np.array([0.0, 0.0, drop])
    return [(center * scale + lowered, half * scale) for center, half in boxes]


def base_free(arm: ArmModel, boxes: list[Box]) -> bool:
    """Whether the arm's base, at the origin, keeps clear of ``boxes`` (exact test).

    Axis-aligned ``(center, half)`` boxes, as the generators build them;
    `temp_gym.worlds.collision.arm_exact.base_collides` takes obstacles of any kind.
    """
    from temp_gym.worlds.collision.arm_exact import base_collides
    from temp_gym.worlds.collision.arm_obstacles import ArmObstacles

    if not boxes:
        return True
    centers, halves = np.array([c for c, _ in boxes]), np.array([h for _, h in boxes])
    return not base_collides(arm, ArmObstacles.boxes(centers, halves))


def draw_base_free(
    build: Callable[[np.random.Generator, int], list[Box]],
    rng: np.random.Generator,
    side: int,
    tries: int,
    what: str,
    arm: ArmModel,
    scale: float = 1.0,
    drop: float = 0.0,
) -> list[Box]:
    """``build(rng, side)`` redrawn until its boxes, as `scaled`, keep clear of the arm's base.

    Returns the scaled boxes.

    Raises:
        RuntimeError: every one of ``tries`` draws touched the base (the message names
            ``what``).
    """
    for _ in range(tries):
        boxes = scaled(build(rng, side), scale, drop)
        if base_free(arm, boxes):
            return boxes
    raise RuntimeError(f"{what}: no base-free placement in {tries} draws")


def generate_arm_workspace(robot: str, rng: np.random.Generator, max_tries: int = 100) -> Workspace:
    """Draw a floor and 3-4 random furniture templates in the arm's reach.

    Args:
        robot: a registered arm's name.
        rng: the only source of randomness.
        max_tries: templates redrawn when one touches the robot's base, before giving up.

    Raises:
        ValueError: ``rng`` is not a `numpy.random.Generator`.
        RuntimeError: no base-free placement was found in ``max_tries`` draws.
    """
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng: expected a numpy.random.Generator, got {type(rng).__name__}")
    arm = arm_of(robot)
    scale, drop = arm_scale(arm), scene_drop(arm)
    bounds = arm.joint_limits()
    boxes: list[Box] = scaled([floor_slab()], scale, drop)
    names = list(TEMPLATES)

    def any_template(rng: np.random.Generator, side: int) -> list[Box]:
        return TEMPLATES[names[rng.integers(len(names))]](rng, side)

    sides = list(rng.permutation(len(SIDES)))
    for _ in range(int(rng.integers(3, 5))):
        side = int(sides.pop())
        boxes += draw_base_free(any_template, rng, side, max_tries, "generate_arm_workspace",
                                arm, scale, drop)  # fmt: skip
    centers = np.array([c for c, _ in boxes])
    halves = np.array([h for _, h in boxes])
    return Workspace(robot, bounds, centers, halves)


def near_surface(checker, states: np.ndarray, hand_only: bool = True) -> np.ndarray:
    """``bool[N]``: the arm is within `NEAR_SURFACE` of an obstacle (exact checker ``checker``).

    Any obstacle kind: the exact checker's report measures each. With ``hand_only``, the body
    nearest an obstacle must also be the last (the hand).
    """
    last = checker.arm.body_names[-1]
    out = np.zeros(len(states), dtype=bool)
    for k, state in enumerate(states):
        report = checker.obstacle_report(state)
        if report and NEAR_SURFACE[0] <= report[0][2] <= NEAR_SURFACE[1]:
            out[k] = not hand_only or report[0][0] == last
    return out


def _draw_near(fast, exact, rng: np.random.Generator, lower: np.ndarray, upper: np.ndarray,
               count: int, batches: int = NEAR_DRAW_BATCHES) -> np.ndarray:  # fmt: skip
    """Up to ``count`` states near a surface, ``(<= count, dim)``.

    Free states whose grown spheres touch an obstacle, kept when the exact checker puts the
    hand within `NEAR_SURFACE` of one; at most ``batches`` batches of 256 uniform states are drawn,
    so a workspace with no such state gives fewer (or none) instead of drawing forever.
    """
    found: list[np.ndarray] = []
    for _ in range(batches):
        states = rng.uniform(lower, upper, size=(256, len(lower)))
        close = fast.states_free(states) & ~fast.states_free(states, fast.resolution / 2)
        for state in states[close]:
            if near_surface(exact, state[None])[0]:
                found.append(state)
                if len(found) == count:
                    return np.array(found)
    return np.array(found).reshape(-1, len(lower))


def full_turn_joints(arm: ArmModel, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """``bool (dim,)``: the revolute joints whose range (within the bounds) exceeds a turn."""
    from temp_gym.worlds.arm.urdf import REVOLUTE

    return (arm.chain.joint_types == REVOLUTE) & (np.asarray(upper) - np.asarray(lower) > 2 * np.pi)


def in_start_turn(goals: np.ndarray, starts: np.ndarray, turning: np.ndarray,
                  lower: np.ndarray, upper: np.ndarray) -> np.ndarray:  # fmt: skip
    """``goals`` with each ``turning`` joint moved by whole turns nearest its start's value.

    The same poses: a joint whose range exceeds a turn (a UR arm's +-2 pi) reaches a pose in
    several windings, and a goal a turn away from the start is often reachable only through
    the floor (the known limitations). Values stay within ``lower`` and ``upper``.
    """
    if not turning.any():
        return goals
    goals = goals.copy()
    value, start = goals[:, turning], starts[:, turning]
    low, high = lower[turning], upper[turning]
    turns = np.floor((value - start) / (2 * np.pi))
    best = value
    for k in (turns, turns + 1):  # the values a whole turn apart on either side of the start
        shifted = value - 2 * np.pi * k
        better = (shifted >= low) & (shifted <= high) & (np.abs(shifted - start)
                                                         < np.abs(best - start))  # fmt: skip
        best = np.where(better, shifted, best)
    goals[:, turning] = best
    return goals


def generate_arm_task(
    workspace: Workspace,
    rng: np.random.Generator,
    difficulty: str,
    goal_radius: float,
    max_tries: int = 2000,
    near: str | None = None,
) -> Problem:
    """Draw a free start and goal in ``workspace`` matching ``difficulty``.

    Args:
        workspace: an arm's workspace, e.g. from `generate_arm_workspace`.
        rng: the only source of randomness.
        difficulty: ``"easy"`` (straight motion free), ``"challenging"`` (blocked) or
            ``"any"``; see the module docstring.
        goal_radius: radius of the goal ball; start and goal are more than two radii apart.
        max_tries: start-goal pairs drawn before giving up.
        near: ``"goal"`` or ``"both"``: the goal (and the start) near a surface; ``"none"``:
            neither; None: the goal with probability `NEAR_SURFACE_SHARE`.

    Raises:
        ValueError: bad ``workspace``, ``difficulty``, ``goal_radius`` or ``near``.
        RuntimeError: no pair matched within ``max_tries``.
    """
    from temp_gym.worlds.robots import robot_spec

    if not isinstance(workspace, Workspace) or robot_spec(workspace.robot).description is None:
        raise ValueError(f"workspace: expected an arm's Workspace, got {workspace!r}")
    check_difficulty(difficulty)
    if not (isinstance(goal_radius, (int, float)) and 0 < goal_radius < np.inf):
        raise ValueError(f"goal_radius: expected a positive number, got {goal_radius!r}")
    if near not in (None, "none", "goal", "both"):
        raise ValueError(f"near: expected None, 'none', 'goal' or 'both', got {near!r}")
    spec = robot_spec(workspace.robot)
    fast = spec.make_checker(workspace)
    if near is None:
        near = "goal" if rng.random() < NEAR_SURFACE_SHARE else "none"
    exact = spec.make_checker(workspace, exact=True) if near != "none" else None
    lower, upper = workspace.bounds
    dim = workspace.dim
    turning = full_turn_joints(arm_of(workspace.robot), lower, upper)
    batch = 64 if near == "none" else 8
    for first in range(0, max_tries, batch):
        count = min(batch, max_tries - first)
        if near == "both":
            starts = _draw_near(fast, exact, rng, lower, upper, count)
        else:
            starts = rng.uniform(lower, upper, size=(count, dim))
        if near == "none":
            goals = rng.uniform(lower, upper, size=(count, dim))
        else:
            goals = _draw_near(fast, exact, rng, lower, upper, count)
        count = min(len(starts), len(goals))  # fewer near a surface, or none, in this attempt
        starts, goals = starts[:count], in_start_turn(goals[:count], starts[:count], turning,
                                                      lower, upper)  # fmt: skip
        ok = fast.states_free(starts) & fast.states_free(goals)
        ok &= np.linalg.norm(goals - starts, axis=1) > 2 * goal_radius
        if difficulty != "any":
            straight = fast.edges_free(starts, goals)
            ok &= straight if difficulty == "easy" else ~straight
        hits = np.flatnonzero(ok)
        if len(hits):
            k = hits[0]
            return Problem(workspace, starts[k], goals[k], float(goal_radius))
    raise RuntimeError(f"generate_arm_task: no {difficulty!r} start-goal pair in {max_tries} tries")


__all__ = [
    "FLOOR_TOP",
    "SIDES",
    "TEMPLATES",
    "box_corners",
    "draw_base_free",
    "floor_slab",
    "NEAR_SURFACE",
    "NEAR_SURFACE_SHARE",
    "REFERENCE_REACH",
    "arm_of",
    "arm_scale",
    "base_free",
    "generate_arm_task",
    "generate_arm_workspace",
    "near_surface",
    "scaled",
    "place",
    "scene_drop",
    "full_turn_joints",
    "in_start_turn",
]
