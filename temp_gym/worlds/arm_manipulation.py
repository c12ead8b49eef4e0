"""Manipulation scenes for any arm: shelves, open boxes, cages and tables, turned at any angle.

The family ``manipulation`` draws the kinds of scene a manipulator meets in a benchmark such
as MotionBenchMaker (MBM): one to three structures around the robot, each one of

============  ==================================================================================
structure     pieces (sizes at the iiwa's reach, `arm_world.REFERENCE_REACH`)
============  ==================================================================================
bookshelf     2-6 boards (15-60 cm deep halves, 22-40 cm apart), held by two side panels
              (sometimes down to the ground) or four corner legs (boxes or cylinders); sometimes
              a vertical divider and a back panel; 0-3 cans and boxes on each board
open box      five sides (a bottom and four walls, the near one sometimes lower) of random size;
              a lid that is absent, tilted open about one of its four edges (17-75 degrees), or
              lying ajar; 0-3 objects inside; sometimes on a stand
cage          a base plate and a volume closed by plates, bars or nothing on each side, a front
              of one to three horizontal or two to four vertical bars (boxes or cylinders, some
              lying along x or y), a cap of a plate or bars, an object inside, sometimes legs
table         a top on four legs (boxes or cylinders), 2-8 boxes and upright cylinders of random
              sizes and yaws on it, and often 1-3 objects under it (on a lower board or on the
              ground)
============  ==================================================================================

Each structure faces the robot from a random direction (any angle about the vertical, not
only the four sides `arm_world`'s templates use), turned by up to `TWIST` about its own
centre, at a random distance; structures do not overlap and keep clear of the base. The
ground is, per workspace, a floor just below the base (`FLOOR_SHARE`), a floor 15-70 cm below
it with the robot on a pedestal (`PEDESTAL_SHARE`), or absent (the robot is mounted above
open space, as in MBM, and legs hang). Sizes are drawn for the iiwa's reach and scaled by
the arm's (`arm_world.arm_scale`), as the other arm families are. At least
`arm_structured.MIN_FREE_FRACTION` of random joint configurations are free by the robot's
own checker; tasks come from `arm_world.generate_arm_task`, near-surface goals included.

**How it differs from MBM.** MBM's Panda scenes (bookshelf small, tall and thin, box, cage,
table pick, table under pick) are single structures of fixed sizes and fixed object counts
(7 to 21 pieces), placed in front of the robot (yaws within +-90 degrees, the cage's within
+-28) at distances of about 0.2-1.5 m, with 3 cm cans and fixed props. Here the sizes, board
counts and spacings, object counts, kinds, sizes and yaws, and the sides' make-up are drawn;
one to three structures share a scene, from any direction, with a floor, a pedestal or
nothing below. No MBM problem or scene is used, and the MBM scenes are never drawn as they
are (only their kinds of structure).

All randomness comes from the `numpy.random.Generator` passed in: the same seed gives the
same workspace.

Examples:
    >>> workspace = generate_manipulation_workspace("franka_panda", np.random.default_rng(0))
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from temp_gym.problem import Workspace
from temp_gym.problem.obstacles import BOX
from temp_gym.worlds.arm_pieces import (
    Piece,
    as_obstacles,
    axis_quaternion,
    bar,
    bounding_boxes,
    box,
    objects_on,
    placed,
)
from temp_gym.worlds.arm_world import FLOOR_TOP, arm_of, arm_scale, base_free, scene_drop
from temp_gym.worlds.structured import MANIPULATION

FLOOR_SHARE = 0.4
"""Share of workspaces with a floor just below the base."""
PEDESTAL_SHARE = 0.4
"""Share with the robot on a pedestal over a lower floor; the rest have no ground."""
PEDESTAL_FLOOR = (-0.7, -0.15)
"""Range of the lower floor's top (m) under a pedestal."""
STRUCTURES = (1, 3)
"""How many structures a workspace has (low, high inclusive)."""
TWIST = 0.35
"""Largest turn (radians) of a structure about its own centre, away from facing the robot."""
SEPARATION = 0.05
"""Least gap (m) between two structures' footprints."""
PLACEMENT_TRIES = 50
"""Placements of a structure tried before the workspace is drawn with one fewer."""
TRIES = 100
"""Workspaces drawn before giving up on the free fraction."""

Ground = float | None
"""The top of the ground (m), or None when there is none."""


def _low_end(rng: np.random.Generator, ground: Ground, top: float) -> float:
    """Where supports from ``top`` down end: the ground, or, without one, 40-80 cm lower."""
    return ground if ground is not None else top - rng.uniform(0.4, 0.8)


def _bookshelf(rng: np.random.Generator, ground: Ground) -> tuple[list[Piece], np.ndarray]:
    """Boards on side panels or corner legs, with cans and boxes on them."""
    near, depth, width = rng.uniform(0.35, 0.8), rng.uniform(0.15, 0.6), rng.uniform(0.3, 0.65)
    board, spacing = rng.uniform(0.01, 0.025), rng.uniform(0.22, 0.4)
    bottom = rng.uniform(-0.45, 0.7)
    if ground is not None:
        bottom = max(bottom, ground + board)
    count = min(int(rng.integers(2, 7)), max(2, int((1.35 - bottom) / spacing) + 1))
    x = near + depth
    heights = bottom + spacing * np.arange(count)
    top = heights[-1] + board
    pieces = [box((x, 0.0, z), (depth, width, board)) for z in heights]
    low = ground if ground is not None and rng.random() < 0.5 else bottom - board
    middle, half_height = (low + top) / 2, (top - low) / 2
    if rng.random() < 0.6:  # side panels
        panel = rng.uniform(0.01, 0.025)
        pieces += [box((x, side * (width + panel), middle), (depth, panel, half_height))
                   for side in (-1.0, 1.0)]  # fmt: skip
    else:  # corner legs
        leg, round_leg = rng.uniform(0.015, 0.03), rng.random() < 0.5
        for dx in (-1.0, 1.0):
            for dy in (-1.0, 1.0):
                at = (x + dx * (depth - leg), dy * (width - leg))
                pieces.append(bar((*at, low), (*at, top), leg, round_leg))
    shelves = [(-width, width)]
    if rng.random() < 0.35:  # a vertical divider between the lowest and highest boards
        lateral, half_thickness = rng.uniform(-0.5, 0.5) * width, rng.uniform(0.01, 0.02)
        inner = (heights[-1] - heights[0]) / 2 - board
        pieces.append(
            box((x, lateral, (heights[0] + heights[-1]) / 2), (depth, half_thickness, inner))
        )
        shelves = [(-width, lateral - half_thickness), (lateral + half_thickness, width)]
    if rng.random() < 0.3:  # a back panel
        panel = rng.uniform(0.01, 0.02)
        pieces.append(box((x + depth + panel, 0.0, middle), (panel, width, half_height)))
    for k, z in enumerate(heights):
        room = spacing - 2 * board if k + 1 < count else 0.5
        for y0, y1 in shelves:
            pieces += objects_on(rng, int(rng.integers(0, 4)), (x - depth, x + depth, y0, y1),
                                  z + board, room)  # fmt: skip
    return pieces, np.array([x, 0.0, 0.0])


def _lid(
    rng: np.random.Generator, x: float, halves: tuple, top: float, thickness: float
) -> list[Piece]:
    """A lid over a box centred at ``x``: none, tilted open about one edge, or lying ajar."""
    choice = rng.random()
    if choice < 0.35:
        return []
    edge = int(rng.integers(4))  # the hinge: far, left, near, right
    turn = edge * np.pi / 2
    a, b = (halves[0], halves[1]) if edge % 2 == 0 else (halves[1], halves[0])
    if choice < 0.8:  # tilted open about the hinge edge: the edge across from it rises
        angle = rng.uniform(0.3, 1.3)
        center = (x + a - a * np.cos(angle) + thickness * np.sin(angle), 0.0,
                  top + a * np.sin(angle) + thickness * np.cos(angle))  # fmt: skip
        lid = Piece(BOX, np.array(center), np.array([a, b, thickness]), axis_quaternion(1, angle))
    else:  # lying flat, pushed off towards the hinge edge
        lid = box((x + rng.uniform(0.3, 0.8) * 2 * a, 0.0, top + thickness), (a, b, thickness))
    return [lid.turned(turn, np.array([x, 0.0, 0.0]))]


def _open_box(rng: np.random.Generator, ground: Ground) -> tuple[list[Piece], np.ndarray]:
    """A bottom and four walls, a lid tilted open, ajar or absent, objects inside."""
    depth, width = rng.uniform(0.15, 0.4, size=2)
    height, wall = rng.uniform(0.1, 0.35), rng.uniform(0.01, 0.025)
    x = rng.uniform(0.15, 0.6) + depth + wall
    bottom = rng.uniform(-0.6, 0.5)
    if ground is not None:
        bottom = max(bottom, ground + wall)
    floor = bottom + wall
    top = floor + 2 * height
    near = height * (rng.uniform(0.5, 1.0) if rng.random() < 0.5 else 1.0)
    pieces = [
        box((x, 0.0, bottom), (depth + wall, width + wall, wall)),
        box((x - depth, 0.0, floor + near), (wall, width + wall, near)),
        box((x + depth, 0.0, floor + height), (wall, width + wall, height)),
        box((x, -width, floor + height), (depth + wall, wall, height)),
        box((x, width, floor + height), (depth + wall, wall, height)),
    ]
    pieces += _lid(rng, x, (depth + wall, width + wall), top, wall)
    pieces += objects_on(rng, int(rng.integers(0, 4)),
                          (x - depth + wall, x + depth - wall, -width + wall, width - wall),
                          floor, 2 * height)  # fmt: skip
    if ground is not None and bottom - wall - ground > 0.03 and rng.random() < 0.6:
        stand = (bottom - wall - ground) / 2
        pieces.append(box((x, 0.0, ground + stand), (0.6 * depth, 0.6 * width, stand)))
    return pieces, np.array([x, 0.0, 0.0])


def _face_bars(rng: np.random.Generator, corners: tuple, thickness: float,
               round_bar: bool, horizontal: bool, count: int) -> list[Piece]:  # fmt: skip
    """``count`` bars across a vertical face, ``corners`` ``((start, end), (low, high))``.

    ``start`` and ``end`` are the ends of its bottom edge (x, y), ``low`` and ``high`` its
    heights; ``horizontal`` bars run along the edge, the others stand.
    """
    (start, end), (low, high) = corners
    start, end = np.asarray(start, float), np.asarray(end, float)
    spots = (np.arange(count) + rng.uniform(0.6, 1.4, size=count)) / (count + 0.5)
    if horizontal:
        return [bar((*start, low + f * (high - low)), (*end, low + f * (high - low)), thickness,
                     round_bar) for f in spots]  # fmt: skip
    return [bar((*(start + f * (end - start)), low), (*(start + f * (end - start)), high),
                 thickness, round_bar) for f in spots]  # fmt: skip


def _cage(rng: np.random.Generator, ground: Ground) -> tuple[list[Piece], np.ndarray]:
    """A volume closed by plates, bars or nothing, barred at the front, with an object in."""
    depth, width, height = rng.uniform(0.2, 0.4, size=3)
    plate, thickness = rng.uniform(0.01, 0.025), rng.uniform(0.01, 0.025)
    round_bar = rng.random() < 0.5
    x = rng.uniform(0.3, 0.6) + depth
    bottom = rng.uniform(-0.3, 0.5)
    if ground is not None:
        bottom = max(bottom, ground + plate)
    low, high = bottom + plate, bottom + plate + 2 * height
    pieces = [box((x, 0.0, bottom), (depth + plate, width + plate, plate))]
    faces = {  # (bottom edge's two ends, the plate's centre and half sides)
        "far": (
            ((x + depth, -width), (x + depth, width)),
            (x + depth + plate, 0.0),
            (plate, width),
        ),
        "left": (((x - depth, -width), (x + depth, -width)), (x, -width - plate), (depth, plate)),
        "right": (((x - depth, width), (x + depth, width)), (x, width + plate), (depth, plate)),
    }
    for edge, (cx, cy), (hx, hy) in faces.values():
        choice = rng.random()
        if choice < 0.5:
            pieces.append(box((cx, cy, (low + high) / 2), (hx, hy, height)))
        elif choice < 0.85:
            pieces += _face_bars(rng, (edge, (low, high)), thickness, round_bar,
                                 rng.random() < 0.5, int(rng.integers(2, 5)))  # fmt: skip
    front = ((x - depth, -width), (x - depth, width))
    horizontal = rng.random() < 0.6
    count = int(rng.integers(1, 4)) if horizontal else int(rng.integers(2, 5))
    pieces += _face_bars(rng, (front, (low, high)), thickness, round_bar, horizontal, count)
    if rng.random() < 0.6:
        pieces.append(box((x, 0.0, high + plate), (depth + plate, width + plate, plate)))
    else:  # a cap of bars across
        for f in np.linspace(-1.0, 1.0, int(rng.integers(2, 5)) + 2)[1:-1]:
            pieces.append(
                bar(
                    (x + f * depth, -width, high + thickness),
                    (x + f * depth, width, high + thickness),
                    thickness,
                    round_bar,
                )
            )
    if rng.random() < 0.7:
        room = (x - depth + plate, x + depth - plate, -width + plate, width - plate)
        pieces += objects_on(rng, 1, room, low, 2 * height)
    if ground is not None and bottom - plate - ground > 0.05 and rng.random() < 0.5:
        for dx in (-1.0, 1.0):
            for dy in (-1.0, 1.0):
                at = (x + dx * depth, dy * width)
                pieces.append(bar((*at, ground), (*at, bottom - plate), thickness, round_bar))
    return pieces, np.array([x, 0.0, 0.0])


def _table(rng: np.random.Generator, ground: Ground) -> tuple[list[Piece], np.ndarray]:
    """A top on four legs, objects of random kinds, sizes and yaws on it and often under it."""
    depth, width = rng.uniform(0.25, 0.65), rng.uniform(0.35, 1.0)
    thickness = rng.uniform(0.01, 0.03)
    x = rng.uniform(0.25, 0.65) + depth
    top = rng.uniform(-0.25, 0.45)
    if ground is not None:
        top = max(top, ground + 0.25)
    low = _low_end(rng, ground, top)
    leg, round_leg, inset = rng.uniform(0.02, 0.04), rng.random() < 0.4, rng.uniform(0.0, 0.1)
    pieces = [box((x, 0.0, top), (depth, width, thickness))]
    reach_x, reach_y = depth - leg - inset, width - leg - inset
    for dx in (-1.0, 1.0):
        for dy in (-1.0, 1.0):
            at = (x + dx * reach_x, dy * reach_y)
            pieces.append(bar((*at, low), (*at, top - thickness), leg, round_leg))
    surface = top + thickness
    pieces += objects_on(rng, int(rng.integers(2, 9)), (x - depth, x + depth, -width, width),
                          surface, 0.5)  # fmt: skip
    if rng.random() < 0.6:  # objects under the table
        inner = (x - reach_x + leg, x + reach_x - leg, -reach_y + leg, reach_y - leg)
        if ground is None or rng.random() < 0.5:  # on a lower board between the legs
            z = low + (top - low) * rng.uniform(0.15, 0.5)
            pieces.append(box((x, 0.0, z), (reach_x + leg, reach_y + leg, thickness)))
            pieces += objects_on(rng, int(rng.integers(1, 4)), inner, z + thickness,
                                  top - 2 * thickness - z)  # fmt: skip
        else:  # on the ground
            pieces += objects_on(
                rng, int(rng.integers(1, 4)), inner, ground, top - thickness - ground
            )
    return pieces, np.array([x, 0.0, 0.0])


BUILDERS: dict[str, Callable[[np.random.Generator, Ground], tuple[list[Piece], np.ndarray]]] = {
    "bookshelf": _bookshelf,
    "open_box": _open_box,
    "cage": _cage,
    "table": _table,
}
"""Each structure's builder: ``(rng, ground) -> (pieces, anchor)`` in the frame facing along
+x (the anchor is the point it turns about)."""


def _ground(rng: np.random.Generator) -> tuple[Ground, list[Piece]]:
    """The workspace's ground top and its pieces: a floor, a pedestal on a lower floor, none."""
    choice = rng.random()
    if choice < FLOOR_SHARE:
        return FLOOR_TOP, [box((0.0, 0.0, FLOOR_TOP - 0.05), (1.5, 1.5, 0.05))]
    if choice < FLOOR_SHARE + PEDESTAL_SHARE:
        level, side = rng.uniform(*PEDESTAL_FLOOR), rng.uniform(0.12, 0.25)
        floor = box((0.0, 0.0, level - 0.05), (1.5, 1.5, 0.05))
        pedestal = box((0.0, 0.0, (FLOOR_TOP + level) / 2), (side, side, (FLOOR_TOP - level) / 2))
        return level, [floor, pedestal]
    return None, []


def _footprint(pieces: list[Piece]) -> np.ndarray:
    """``[[x0, y0], [x1, y1]]``: the pieces' bounding rectangle seen from above."""
    lower, upper = bounding_boxes(pieces)
    return np.array([lower.min(axis=0)[:2], upper.max(axis=0)[:2]])


def _overlaps(footprint: np.ndarray, others: list[np.ndarray], gap: float) -> bool:
    return any(
        np.all(footprint[0] < other[1] + gap) and np.all(other[0] < footprint[1] + gap)
        for other in others
    )


def draw_structure(rng: np.random.Generator, name: str, ground: Ground) -> list[Piece]:
    """Structure ``name`` built and placed around the robot at reference size (unscaled).

    It faces the robot from a random direction, turned by up to `TWIST` about its centre.
    """
    pieces, anchor = BUILDERS[name](rng, ground)
    return placed(pieces, rng.uniform(0.0, 2 * np.pi), rng.uniform(-TWIST, TWIST), anchor)


def manipulation_scene(
    robot: str, rng: np.random.Generator
) -> tuple[list[Piece], list[list[Piece]]]:
    """One candidate scene, scaled to the arm: the ground's pieces and each structure's.

    Every structure keeps clear of the base and of the other structures' footprints; one
    that finds no such place in `PLACEMENT_TRIES` is left out.
    """
    arm = arm_of(robot)
    scale, drop = arm_scale(arm), scene_drop(arm)
    ground, ground_pieces = _ground(rng)
    ground_pieces = [piece.scaled(scale, drop) for piece in ground_pieces]
    names = list(BUILDERS)
    structures: list[list[Piece]] = []
    footprints: list[np.ndarray] = []
    for _ in range(int(rng.integers(STRUCTURES[0], STRUCTURES[1] + 1))):
        name = names[int(rng.integers(len(names)))]
        for _ in range(PLACEMENT_TRIES):
            structure = [piece.scaled(scale, drop)
                         for piece in draw_structure(rng, name, ground)]  # fmt: skip
            footprint = _footprint(structure)
            if _overlaps(footprint, footprints, SEPARATION * scale):
                continue
            lower, upper = bounding_boxes(structure)
            if base_free(arm, list(zip((lower + upper) / 2, (upper - lower) / 2))):
                structures.append(structure)
                footprints.append(footprint)
                break
    return ground_pieces, structures


def free_fraction(workspace: Workspace, rng: np.random.Generator, probes: int) -> float:
    """Share of ``probes`` random joint configurations that the robot's checker finds free."""
    from temp_gym.worlds.robots import robot_spec

    checker = robot_spec(workspace.robot).make_checker(workspace)
    states = rng.uniform(*workspace.bounds, size=(probes, workspace.dim))
    return float(checker.states_free(states).mean())


def generate_manipulation_workspace(robot: str, rng: np.random.Generator) -> Workspace:
    """Draw a manipulation scene for the arm ``robot`` (see the module docstring).

    Raises:
        ValueError: a bad ``rng`` or a robot that is not an arm.
        RuntimeError: no scene kept `arm_structured.MIN_FREE_FRACTION` free in `TRIES` draws.
    """
    from temp_gym.worlds.arm_structured import FREE_PROBES, MIN_FREE_FRACTION

    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng: expected a numpy.random.Generator, got {type(rng).__name__}")
    limits = arm_of(robot).joint_limits()
    for _ in range(TRIES):
        ground, structures = manipulation_scene(robot, rng)
        pieces = ground + [piece for structure in structures for piece in structure]
        workspace = Workspace.from_obstacles(robot, limits, as_obstacles(pieces))
        if free_fraction(workspace, rng, FREE_PROBES) >= MIN_FREE_FRACTION:
            return workspace
    raise RuntimeError(f"no {MANIPULATION} {robot} workspace kept {MIN_FREE_FRACTION:.0%} free "
                       f"in {TRIES}")  # fmt: skip


__all__ = [
    "BUILDERS",
    "MANIPULATION",
    "draw_structure",
    "free_fraction",
    "generate_manipulation_workspace",
    "manipulation_scene",
]
