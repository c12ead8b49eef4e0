"""Structured arm workspaces: the arms' counterparts of the point worlds' families.

An arm's own generator (`temp_gym.worlds.arm_world`, the family ``boxes``) places three
or four pieces of furniture: tables, shelves, single pillars and solid walls. Nothing in it
asks the arm to reach through an opening, into a compartment or under a ceiling, which is
what most real cells ask. These families carry the point worlds' names
(`temp_gym.worlds.structured`), so one ``workspace_family`` setting means the same idea for
every robot, built from plates the arm's size (drawn for the iiwa's reach and scaled with
the arm's, `temp_gym.worlds.arm_world.arm_scale`):

=============  ===================================================================================
family         the arms' version (at the iiwa's size)
=============  ===================================================================================
``corridors``  one or two partitions around the robot (plates 0.7-1.3 m wide, 0.7-1.1 m tall),
               each with one or two windows (15-35 cm a side) of random place; the arm
               reaches through
``maze``       one or two shelving units of 2-4 x 2-4 compartments (cells 15-30 cm, 20-35 cm
               deep, on a stand), open towards the robot
``traps``      one to three bins (five-sided boxes of random size, open at the top, towards the
               robot or sideways), on stands
``narrow``     one or two slots (two tall parallel plates 15-35 cm apart), and half the time a
               partial ceiling over one side at 0.6-1.0 m
``clutter``    one or two tables, each with 4-10 small objects on it or floating in reach
=============  ===================================================================================

Every structure stands on one of the four sides of the robot (axis-aligned, like
`arm_world`'s templates); one or two of `arm_world`'s templates fill other sides. Every
piece keeps clear of the base, and at least `MIN_FREE_FRACTION` of random joint configurations
are free (arm against boxes and itself), so tasks can be drawn; tasks come from
`arm_world.generate_arm_task` as in the default family.

**The out-of-distribution scenes stay held out.** ``examples/ood/7d`` (built by
`temp_gym.evaluation.ood`) are single structures alone on the floor at fixed coordinates: one
window in a wall, a ceiling over the whole reach, one slot, one cubby behind the robot, a
ring of eight pillars. These families share elements with them (windows, slots, boxes open on
one side, ceilings) but never such a scene: partitions have random windows and other
furniture beside them and are narrower than the scene's wall, compartments come in grids,
ceilings cover one side only, and no family draws a ring of pillars.
``tests/worlds/test_arm_structured.py`` measures it, as ``tests/worlds/test_structured.py``
does for the point worlds.

All randomness comes from the `numpy.random.Generator` passed in.

Examples:
    >>> workspace = generate_arm_structured_workspace("kuka_iiwa14", np.random.default_rng(0),
    ...                                                "maze")
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from temp_gym.problem import Workspace
from temp_gym.worlds.arm.model import ArmModel
from temp_gym.worlds.arm_world import (
    FLOOR_TOP,
    SIDES,
    TEMPLATES,
    Box,
    arm_of,
    arm_scale,
    box_corners,
    draw_base_free,
    floor_slab,
    place,
    scaled,
    scene_drop,
)
from temp_gym.worlds.structured import MANIPULATION

MIN_FREE_FRACTION = 0.1
"""Least share of `FREE_PROBES` random joint configurations that must be free."""
FREE_PROBES = 256
"""Random configurations drawn to measure the free share of a candidate workspace."""
TRIES = 100
"""Candidate structures (or whole workspaces) drawn before giving up."""


def _plate(side: int, radial: float, lateral: tuple, height: tuple, half_thickness: float) -> Box:
    """A plate facing the robot: ``lateral`` and ``height`` are its (low, high) extents."""
    (l0, l1), (z0, z1) = lateral, height
    return place(side, radial, (l0 + l1) / 2, (z0 + z1) / 2,
                 (half_thickness, (l1 - l0) / 2, (z1 - z0) / 2))  # fmt: skip


def _wall_with_windows(
    side: int, radial: float, lateral: tuple, height: tuple, half_thickness: float, windows: list
) -> list[Box]:
    """A plate facing the robot with rectangular ``windows`` ``(l0, l1, z0, z1)`` cut out.

    Windows must not overlap along the lateral axis; the plate becomes a column of full height
    between windows and a piece below and above each window.
    """
    boxes = []
    edge = lateral[0]
    for l0, l1, z0, z1 in sorted(windows):
        if l0 > edge:
            boxes.append(_plate(side, radial, (edge, l0), height, half_thickness))
        if z0 > height[0]:
            boxes.append(_plate(side, radial, (l0, l1), (height[0], z0), half_thickness))
        if z1 < height[1]:
            boxes.append(_plate(side, radial, (l0, l1), (z1, height[1]), half_thickness))
        edge = l1
    if edge < lateral[1]:
        boxes.append(_plate(side, radial, (edge, lateral[1]), height, half_thickness))
    return boxes


def _partition(rng: np.random.Generator, side: int) -> list[Box]:
    """A wide plate with one or two windows the arm can reach through."""
    radial = rng.uniform(0.35, 0.7)
    half_width, centre = rng.uniform(0.35, 0.65), rng.uniform(-0.3, 0.3)
    lateral = (centre - half_width, centre + half_width)
    height = (FLOOR_TOP, rng.uniform(0.7, 1.1))
    count = int(rng.integers(1, 3))
    # Each window gets its own slot of the wall's width, so windows never overlap.
    slots = np.linspace(lateral[0] + 0.05, lateral[1] - 0.05, count + 1)
    windows = []
    for k in range(count):
        width = min(rng.uniform(0.15, 0.35), slots[k + 1] - slots[k] - 0.02)
        l0 = rng.uniform(slots[k], slots[k + 1] - width)
        tall = rng.uniform(0.15, 0.35)
        z0 = rng.uniform(0.1, height[1] - tall - 0.05)
        windows.append((l0, l0 + width, z0, z0 + tall))
    return _wall_with_windows(side, radial, lateral, height, rng.uniform(0.005, 0.015), windows)


def _stand(side: int, radial: float, lateral: float, top: float, half: tuple) -> list[Box]:
    """A solid stand from the floor up to ``top`` under a unit (none when ``top`` is low)."""
    if top - FLOOR_TOP < 0.03:
        return []
    height = (top - FLOOR_TOP) / 2
    return [place(side, radial, lateral, FLOOR_TOP + height, (half[0], half[1], height))]


def _compartments(rng: np.random.Generator, side: int) -> list[Box]:
    """A shelving unit of rows x columns compartments, open towards the robot, on a stand."""
    rows, columns = int(rng.integers(2, 5)), int(rng.integers(2, 5))
    cell_width = rng.uniform(0.15, 0.3) if columns < 4 else rng.uniform(0.15, 0.25)
    cell_height, depth = rng.uniform(0.15, 0.3), rng.uniform(0.1, 0.175)
    panel = rng.uniform(0.005, 0.012)
    near = rng.uniform(0.35, 0.65)
    radial = near + depth
    bottom = rng.uniform(FLOOR_TOP, 0.5)
    half_width = columns * cell_width / 2
    centre = rng.uniform(-0.4, 0.4)
    top = bottom + rows * cell_height
    boxes = [
        _plate(
            side,
            radial + depth + panel,
            (centre - half_width - panel, centre + half_width + panel),
            (bottom, top),
            panel,
        )
    ]  # fmt: skip  (the back)
    for z in np.linspace(bottom, top, rows + 1):
        boxes.append(place(side, radial, centre, z, (depth, half_width + panel, panel)))
    for lateral in np.linspace(centre - half_width, centre + half_width, columns + 1):
        boxes.append(place(side, radial, lateral, (bottom + top) / 2,
                           (depth, panel, (top - bottom) / 2)))  # fmt: skip
    return boxes + _stand(side, radial, centre, bottom - panel, (depth, half_width * 0.8))


def _bin(rng: np.random.Generator, side: int) -> list[Box]:
    """A five-sided box on a stand, open at the top, towards the robot or sideways."""
    depth, half_width, half_height = rng.uniform(0.1, 0.22, size=3)
    wall = rng.uniform(0.005, 0.012)
    radial = rng.uniform(0.35, 0.75) + depth
    centre = rng.uniform(-0.45, 0.45)
    bottom = rng.uniform(FLOOR_TOP, 0.6)
    z = bottom + half_height
    faces = {  # (radial, lateral, z) of each face's centre and half extents
        "near": (radial - depth, centre, z, (wall, half_width, half_height)),
        "far": (radial + depth, centre, z, (wall, half_width, half_height)),
        "left": (radial, centre - half_width, z, (depth, wall, half_height)),
        "right": (radial, centre + half_width, z, (depth, wall, half_height)),
        "bottom": (radial, centre, bottom, (depth, half_width, wall)),
        "top": (radial, centre, bottom + 2 * half_height, (depth, half_width, wall)),
    }
    opening = ("top", "near", "left", "right")[int(rng.integers(4))]
    boxes = [place(side, *face) for name, face in faces.items() if name != opening]
    return boxes + _stand(side, radial, centre, bottom - wall, (depth * 0.6, half_width * 0.6))


def _slot(rng: np.random.Generator, side: int) -> list[Box]:
    """Two tall parallel plates, 15-35 cm apart, reaching away from the robot."""
    gap, plate = rng.uniform(0.15, 0.35), rng.uniform(0.005, 0.015)
    near, length = rng.uniform(0.25, 0.5), rng.uniform(0.3, 0.6)
    centre = rng.uniform(-0.5, 0.5)
    top = rng.uniform(0.6, 1.2)
    radial, half_height = near + length / 2, (top - FLOOR_TOP) / 2
    return [
        place(side, radial, centre + sign * (gap / 2 + plate), FLOOR_TOP + half_height,
              (length / 2, plate, half_height))
        for sign in (-1.0, 1.0)
    ]  # fmt: skip


def _ceiling(rng: np.random.Generator, side: int) -> list[Box]:
    """A ceiling plate over one side of the robot, from near its base outwards."""
    near, far = rng.uniform(0.15, 0.35), rng.uniform(0.8, 1.2)
    half_width, centre = rng.uniform(0.4, 0.8), rng.uniform(-0.3, 0.3)
    z = rng.uniform(0.6, 1.0)
    return [place(side, (near + far) / 2, centre, z, ((far - near) / 2, half_width, 0.01))]


def _objects(rng: np.random.Generator, side: int) -> list[Box]:
    """A table with small objects on it, and small objects floating in reach on that side."""
    table = TEMPLATES["table"](rng, side)
    top_centre, top_half = table[0]
    boxes = list(table)
    for _ in range(int(rng.integers(4, 11))):
        half = rng.uniform(0.02, 0.07, size=3)
        if rng.random() < 0.5:  # on the table
            xy = rng.uniform(top_centre[:2] - top_half[:2], top_centre[:2] + top_half[:2])
            centre = np.array([*xy, top_centre[2] + top_half[2] + half[2]])
        else:  # floating in reach on this side
            centre = place(side, rng.uniform(0.3, 0.9), rng.uniform(-0.6, 0.6),
                           rng.uniform(0.1, 1.1), (0.0, 0.0, 0.0))[0]  # fmt: skip
        boxes.append((centre, half))
    return boxes


FAMILY_STRUCTURES: dict[str, tuple[dict[str, Callable], tuple[int, int]]] = {
    "corridors": ({"partition": _partition}, (1, 2)),
    "maze": ({"compartments": _compartments}, (1, 2)),
    "traps": ({"bin": _bin}, (1, 3)),
    "narrow": ({"slot": _slot}, (1, 2)),
    "clutter": ({"objects": _objects}, (1, 2)),
}
"""Per family: the structures it draws from (by name; one is drawn, with equal chances, for
each side it takes) and how many of them a workspace has (low, high inclusive)."""
EXTRA_TEMPLATES = (1, 2)
"""How many of `arm_world`'s templates fill other sides (low, high inclusive)."""


def _free_fraction(arm: ArmModel, boxes: list[Box], rng: np.random.Generator) -> float:
    from temp_gym.worlds.collision.arm_fast import ArmSphereChecker

    limits = arm.joint_limits()
    checker = ArmSphereChecker(arm, limits, *box_corners(boxes))
    states = rng.uniform(*limits, size=(FREE_PROBES, arm.dim))
    return float(checker.states_free(states).mean())


def generate_arm_structured_workspace(
    robot: str, rng: np.random.Generator, family: str
) -> Workspace:
    """Draw an arm workspace of a structured ``family`` (see the module docstring).

    ``manipulation`` is drawn by `temp_gym.worlds.arm_manipulation`.

    Raises:
        ValueError: an unknown family or a bad ``rng``.
        RuntimeError: no workspace kept the base free and enough configurations free in
            `TRIES` draws.
    """
    if family == MANIPULATION:
        from temp_gym.worlds.arm_manipulation import generate_manipulation_workspace

        return generate_manipulation_workspace(robot, rng)
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng: expected a numpy.random.Generator, got {type(rng).__name__}")
    if family not in FAMILY_STRUCTURES:
        raise ValueError(f"family: expected one of {tuple(FAMILY_STRUCTURES)}, got {family!r}")
    arm = arm_of(robot)
    scale, drop = arm_scale(arm), scene_drop(arm)

    def draw(build: Callable, rng: np.random.Generator, side: int) -> list[Box]:
        """``build``'s boxes on ``side``, scaled, redrawn until they keep clear of the base."""
        return draw_base_free(build, rng, side, TRIES, build.__name__.strip("_"), arm, scale,
                              drop)  # fmt: skip

    builders, (low, high) = FAMILY_STRUCTURES[family]
    names = list(builders)
    templates = list(TEMPLATES)
    for _ in range(TRIES):
        sides = [int(side) for side in rng.permutation(len(SIDES))]
        boxes = scaled([floor_slab()], scale, drop)
        for _ in range(int(rng.integers(low, high + 1))):
            builder = builders[names[int(rng.integers(len(names)))]]
            boxes += draw(builder, rng, sides.pop())
        if family == "narrow" and rng.random() < 0.5:
            boxes += draw(_ceiling, rng, sides.pop())
        extra = min(int(rng.integers(EXTRA_TEMPLATES[0], EXTRA_TEMPLATES[1] + 1)), len(sides))
        for _ in range(extra):
            template = TEMPLATES[templates[int(rng.integers(len(templates)))]]
            boxes += draw(template, rng, sides.pop())
        if _free_fraction(arm, boxes, rng) >= MIN_FREE_FRACTION:
            centers = np.array([c for c, _ in boxes])
            halves = np.array([h for _, h in boxes])
            return Workspace(robot, arm.joint_limits(), centers, halves)
    raise RuntimeError(f"no {family} {robot} workspace kept {MIN_FREE_FRACTION:.0%} free in "
                       f"{TRIES}")  # fmt: skip


__all__ = ["FAMILY_STRUCTURES", "MIN_FREE_FRACTION", "generate_arm_structured_workspace"]
