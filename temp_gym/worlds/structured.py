"""Structured point worlds: workspace families with walls, mazes, traps and narrow passages.

The default point workspace (`temp_gym.worlds.point_world.generate_point_workspace`, the
family ``boxes``) scatters independent random boxes; a policy trained only on it can learn
that clutter rather than planning. These families give demonstrations structure to learn
from, in 2D and 3D (walls are lines in 2D and slabs in 3D; their openings are gaps in 2D and
rectangular windows in 3D):

* ``corridors``: two to four parallel walls across the workspace (two or three in 3D), each
  with one to three openings (two to four in 3D) of random size and place, crossed by one
  wall with a door into every corridor; baffles jut from the walls and boxes stand in the
  corridors, clear of the walls;
* ``maze``: a grid maze with 4 to 8 cells per axis in 2D and 3 to 5 in 3D (a 3D grid, walls
  are plates), so the cell size is random: a random spanning tree (randomized Kruskal) joins
  the cells, every wall between two cells it does not join is a thin box, and a few more
  walls are removed so that the maze has loops;
* ``traps``: one to three cups (one or two in 3D; U shapes in 2D, five-sided boxes in 3D) of
  random size, position and opening direction, with random boxes around them (never on them);
* ``narrow``: one or two thick walls across the workspace, each pierced by one narrow passage
  of random width and position (a short tunnel), with random boxes beside the walls;
* ``clutter``: many small random boxes, added until a random occupancy up to the limit;
* ``shapes`` (`temp_gym.worlds.shapes`): a random mix of rotated boxes, spheres (discs) and,
  in 3D, cylinders, as many and as large as the ``boxes`` family's. It is the one family of
  other obstacle kinds than axis-aligned boxes, drawn for point robots only and not part of
  ``mixed``, whose draws stay as they were.

Every workspace lies within the bounds ``[0, size]^d`` of `DEFAULT_POINT_WORLDS`, covers at
most their ``max_occupancy`` of the space, and its free space is one connected region (up to
slivers), so that demonstrations rarely meet an unsolvable task. Occupancy and connectivity
are measured on a raster of `RASTER_CELL` cells that counts a cell as occupied when it
touches an obstacle, so the occupancy measured is an upper bound. All randomness comes from the
`numpy.random.Generator` passed in: the same generator state gives the same workspace.
`temp_gym.worlds.generators.generate_workspace` picks a family by name (``mixed``: one drawn
per workspace with the weights of `FAMILY_MIX`) through the robot's spec; the iiwa's versions
of the same names are `temp_gym.worlds.arm_structured`.

**The out-of-distribution scenes stay held out.** ``examples/ood/{2d,3d}`` (built by
`temp_gym.evaluation.ood`) are single hand-made structures alone in an empty workspace, at
fixed round coordinates: walls 0.5 thick with exactly one opening each (a gap, a window, at
alternating ends or corners), a cup centred on the start, floors, a regular lattice of
identical pillars. The families share some elements (walls with openings, cups) but never
such a scene: ``corridors`` crosses its parallel walls with another wall and fills the
corridors with baffles and boxes; ``narrow``'s walls are about four to nine times as thick
(tunnels, not slits) and have boxes beside them; ``traps``' cups have random sizes, places and
openings, among other boxes; ``maze`` fills the whole workspace with a grid of walls;
``clutter`` and ``boxes`` place boxes at random, not on a lattice.
``tests/worlds/test_structured.py`` measures it: no generated workspace comes near an OOD
scene's layout, up to mirrors, turns and moves under a cell (on occupancy grids of cells a
third of a step wide, the share of each one's occupied cells within a cell of the other's).
A policy trained on these families has still met walls with openings and cups, so its
results on the OOD scenes measure generalization to unseen layouts of familiar elements, not
to unseen elements.

Examples:
    >>> workspace = generate_structured_workspace("point2d", np.random.default_rng(0), "maze")
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import ndimage

from temp_gym.problem import Workspace, robot_named
from temp_gym.worlds.encoding import mark_obstacles, occupancy_obstacles
from temp_gym.worlds.point_world import DEFAULT_POINT_WORLDS
from temp_gym.worlds.robots import robot_spec
from temp_gym.worlds.shapes import SHAPES, draw_shapes

BOXES = "boxes"
"""The robot's own generator (random boxes in the point worlds): the pools datasets and
shipped policies were made from."""
MIXED = "mixed"
"""One family per workspace, drawn with the weights of `FAMILY_MIX`."""
WORKSPACE_FAMILIES = (BOXES, "corridors", "maze", "traps", "narrow", "clutter")
"""The families of axis-aligned boxes a single name selects, which ``mixed`` draws from."""
FAMILY_MIX = {family: 1.0 for family in WORKSPACE_FAMILIES}
"""Relative weights of the families in ``mixed``: equal, so that no structure dominates."""
MANIPULATION = "manipulation"
"""The arms' manipulation scenes (`temp_gym.worlds.arm_manipulation`): shelves, open boxes,
cages and tables turned at any angle, with cylinders and oriented boxes."""
ARM_FAMILIES = (MANIPULATION,)
"""Families only arms draw; ``mixed`` never draws them, so its workspaces stay as they were."""
FAMILY_NAMES = (*WORKSPACE_FAMILIES, SHAPES, *ARM_FAMILIES, MIXED)
"""Every name that selects workspaces: a family, or ``mixed``. ``shapes``
(`temp_gym.worlds.shapes`) is the point worlds' only, ``manipulation`` the arms' only; neither
is part of ``mixed``."""
RASTER_CELL = 0.25
"""Side of the raster cells behind the occupancy and connectivity checks (the 2D reference
lattice's spacing): a passage twice as wide always has a free cell across it."""
CONNECTED_FRACTION = 0.99
"""Least share of the free cells in the largest connected region of the free space."""
SNAP = 0.5
"""An opening that comes this close to the bounds reaches them: no wall thinner is left."""
TRIES = 200
"""Workspaces drawn before giving up on the occupancy or connectivity checks."""

Boxes = list[tuple[np.ndarray, np.ndarray]]
"""Boxes as ``(lower, upper)`` corners."""


def check_family(robot: str, family: str, field: str = "family") -> None:
    """Raise a `ValueError` unless ``family`` is a known name that ``robot`` can draw.

    Every robot draws ``boxes`` (its own generator); the others need the robot's spec to have
    structured families (`RobotSpec.structured_generator`: the point worlds here, the arms in
    `temp_gym.worlds.arm_structured`), and `ARM_FAMILIES` an arm. The message names ``field``
    (a config key, an argument) as the one-line errors do.
    """
    if family not in FAMILY_NAMES:
        raise ValueError(f"{field}: expected one of {FAMILY_NAMES}, got {family!r}")
    spec = robot_spec(robot)
    if family in ARM_FAMILIES and spec.description is None:
        raise ValueError(f"{field}: {family!r} is drawn for arms only, and {robot} is not an arm")
    if family != BOXES and spec.structured_generator is None:
        raise ValueError(
            f"{field}: {family!r} needs structured families, which {robot} has not; "
            f"it has only its own generator, {BOXES!r}"
        )
    if family == SHAPES and not is_point_robot(robot):
        raise ValueError(f"{field}: {SHAPES!r} is drawn for 2D and 3D point robots, not {robot}")


def is_point_robot(robot: str) -> bool:
    """Whether ``robot``'s configuration is its position in a 2D or 3D point world."""
    spec = robot_named(robot)
    return spec.dim == spec.workspace_dim and spec.dim in DEFAULT_POINT_WORLDS


def draw_family(rng: np.random.Generator) -> str:
    """A family drawn with the weights of `FAMILY_MIX` (what ``mixed`` does per workspace)."""
    weights = np.array(list(FAMILY_MIX.values()))
    return list(FAMILY_MIX)[int(rng.choice(len(weights), p=weights / weights.sum()))]


def generate_structured_workspace(robot: str, rng: np.random.Generator, family: str) -> Workspace:
    """Draw a workspace of ``family`` (not ``boxes`` or ``mixed``) for a point robot.

    Raises:
        ValueError: an unknown family, or a robot that is not a 2D or 3D point robot.
        RuntimeError: no workspace passed the occupancy and connectivity checks in `TRIES`.
    """
    check_family(robot, family)
    if family not in BUILDERS and family != SHAPES:
        raise ValueError(
            f"family: {family!r} is not structured; expected one of {(*BUILDERS, SHAPES)}"
        )
    if not is_point_robot(robot):
        raise ValueError(f"robot: {robot} is not a 2D or 3D point robot")
    dim = robot_named(robot).dim
    config = DEFAULT_POINT_WORLDS[dim]
    size = config.size
    bounds = np.array([np.zeros(dim), np.full(dim, size)])
    for _ in range(TRIES):
        if family == SHAPES:
            workspace = Workspace.from_obstacles(robot, bounds, draw_shapes(dim, size, rng))
            free = obstacles_free_raster(workspace)
            if _passes(free, config.max_occupancy):
                return workspace
            continue
        boxes = BUILDERS[family](dim, size, rng)
        lower = np.clip(np.array([box[0] for box in boxes]), 0.0, size)
        upper = np.clip(np.array([box[1] for box in boxes]), 0.0, size)
        kept = np.all(upper > lower, axis=1)
        lower, upper = lower[kept], upper[kept]
        if _passes(free_raster(lower, upper, dim, size), config.max_occupancy):
            return Workspace(robot, bounds, (lower + upper) / 2, (upper - lower) / 2)
    raise RuntimeError(f"no {family} workspace passed the checks in {TRIES} draws")


# ---- the checks -------------------------------------------------------------------------------
def _passes(free: np.ndarray, max_occupancy: float) -> bool:
    """Whether a raster of free cells keeps to the occupancy limit and is one region."""
    occupancy = 1.0 - free.mean()
    return occupancy <= max_occupancy and largest_region_share(free) >= CONNECTED_FRACTION


def obstacles_free_raster(workspace: Workspace) -> np.ndarray:
    """`free_raster` of a workspace of any obstacle kinds: cells overlapping none of them.

    The occupancy grid's kernel (`temp_gym.worlds.encoding.mark_obstacles`) on `RASTER_CELL`
    cells over the bounds; a cell touching an obstacle is occupied.
    """
    region, *obstacles = occupancy_obstacles(workspace)
    cells = int(round(float(region[1, 0] - region[0, 0]) / RASTER_CELL))
    occupied = np.zeros(cells**workspace.workspace_dim, dtype=np.bool_)
    mark_obstacles(occupied, region, *obstacles, cells)
    return ~occupied.reshape((cells,) * workspace.workspace_dim)


def free_raster(lower: np.ndarray, upper: np.ndarray, dim: int, size: float) -> np.ndarray:
    """Free cells of a `RASTER_CELL` grid over ``[0, size]^dim``: those touching no box."""
    occupied = np.zeros((int(round(size / RASTER_CELL)),) * dim, dtype=bool)
    for box in zip(lower, upper):
        occupied[_raster_block(*box, occupied.shape[0])] = True
    return ~occupied


def _raster_block(lower: np.ndarray, upper: np.ndarray, cells: int) -> tuple[slice, ...]:
    """The raster cells a box touches, as an index."""
    first = np.clip(np.floor(lower / RASTER_CELL).astype(int), 0, cells)
    stop = np.clip(np.ceil(upper / RASTER_CELL).astype(int), 0, cells)
    return tuple(slice(a, b) for a, b in zip(first, stop))


def largest_region_share(free: np.ndarray) -> float:
    """Share of the free cells in the largest face-connected region of them (0 if none)."""
    labels, count = ndimage.label(free)
    if count == 0:
        return 0.0
    sizes = np.bincount(labels.ravel())[1:]
    return float(sizes.max() / sizes.sum())


# ---- building blocks --------------------------------------------------------------------------
def _subtract(box: tuple[np.ndarray, np.ndarray], hole: tuple[np.ndarray, np.ndarray]) -> Boxes:
    """``box`` minus ``hole`` as disjoint boxes (at most two per axis)."""
    lower, upper = box[0].copy(), box[1].copy()
    if np.any(hole[1] <= lower) or np.any(hole[0] >= upper):
        return [(lower, upper)]
    pieces = []
    for k in range(len(lower)):
        if hole[0][k] > lower[k]:
            below = upper.copy()
            below[k] = hole[0][k]
            pieces.append((lower.copy(), below))
            lower[k] = hole[0][k]
        if hole[1][k] < upper[k]:
            above = lower.copy()
            above[k] = hole[1][k]
            pieces.append((above, upper.copy()))
            upper[k] = hole[1][k]
    return pieces


def _wall(axis: int, center: float, half: float, holes: Boxes, dim: int, size: float) -> Boxes:
    """A wall across the workspace, normal to ``axis``, minus ``holes`` (full-dim boxes)."""
    lower, upper = np.zeros(dim), np.full(dim, size)
    lower[axis], upper[axis] = center - half, center + half
    pieces = [(lower, upper)]
    for hole in holes:
        pieces = [part for piece in pieces for part in _subtract(piece, hole)]
    return [(a, b) for a, b in pieces if np.all(b - a > 1e-9)]


def _spread(rng, count: int, low: float, high: float, gap: float) -> np.ndarray:
    """``count`` sorted positions in ``[low, high]``, at least ``gap`` apart, uniformly."""
    slack = high - low - (count - 1) * gap
    return low + np.sort(rng.uniform(0.0, slack, size=count)) + gap * np.arange(count)


def _opening(rng, axis, center, half, along, low, high, widths, dim, size):
    """One opening in the wall normal to ``axis`` at ``center``, as a box to cut out.

    It lies within ``[low, high]`` along the in-plane axis ``along`` and anywhere along the
    others; its width per axis is drawn from ``widths``. What is left of the wall beside it
    is either nothing or at least `SNAP` wide: no slivers.
    """
    lower, upper = np.zeros(dim), np.zeros(dim)
    lower[axis], upper[axis] = center - half - 1.0, center + half + 1.0
    for k in (k for k in range(dim) if k != axis):
        start, stop = (low, high) if k == along else (0.0, size)
        width = min(rng.uniform(*widths), stop - start - 2 * SNAP)
        rest = stop - start - width
        before = rng.uniform(0.0, rest)
        before = 0.0 if before < SNAP else rest if rest - before < SNAP else before
        lower[k], upper[k] = start + before, start + before + width
    return lower, upper


def _openings(rng, axis, center, half, count, widths, dim, size) -> Boxes:
    """``count`` openings in a wall, one in each of ``count`` equal segments of its span."""
    along = 1 if axis == 0 else 0
    segment = size / count
    spans = [(i * segment, (i + 1) * segment) for i in range(count)]
    return [_opening(rng, axis, center, half, along, *span, widths, dim, size) for span in spans]


def _uniform_boxes(rng, count: int, halves, dim: int, size: float) -> Boxes:
    """``count`` boxes with half sides drawn from ``halves`` and centres anywhere."""
    half = rng.uniform(*halves, size=(count, dim))
    center = rng.uniform(0.0, size, size=(count, dim))
    return list(zip(center - half, center + half))


def _clear_of(boxes: Boxes, keep_out: Boxes, margin: float) -> Boxes:
    """The ``boxes`` that stay ``margin`` away from every ``keep_out`` box."""

    def clear(lower: np.ndarray, upper: np.ndarray) -> bool:
        return not any(
            np.all(upper > lo - margin) and np.all(lower < hi + margin) for lo, hi in keep_out
        )

    return [box for box in boxes if clear(*box)]


def _slab(axis: int, low: float, high: float, dim: int, size: float) -> tuple:
    """The box ``[low, high]`` along ``axis``, across the whole workspace otherwise."""
    lower, upper = np.zeros(dim), np.full(dim, size)
    lower[axis], upper[axis] = low, high
    return lower, upper


def _boxes_between(rng, count, halves, axis, walls, dim, size, margin: float) -> Boxes:
    """``count`` random boxes in the bands between parallel walls (and the bounds).

    ``walls`` are their ``(low, high)`` faces along ``axis``, sorted. A box stays ``margin``
    away from the walls along ``axis``, so a free layer runs along every wall face: no box
    blocks an opening or closes a band.
    """
    faces = [0.0, *[face for wall in walls for face in wall], size]
    bands = [(faces[i] + margin, faces[i + 1] - margin) for i in range(0, len(faces), 2)]
    bands = [(low, high) for low, high in bands if high - low > 2 * halves[0]]
    boxes = []
    for _ in range(count if bands else 0):
        low, high = bands[int(rng.integers(len(bands)))]
        half = rng.uniform(*halves, size=dim)
        half[axis] = min(half[axis], (high - low) / 2)
        center = rng.uniform(0.0, size, size=dim)
        center[axis] = rng.uniform(low + half[axis], high - half[axis])
        boxes.append((center - half, center + half))
    return boxes


# ---- the families -----------------------------------------------------------------------------
def corridors(dim: int, size: float, rng: np.random.Generator) -> Boxes:
    """Parallel walls with openings, crossed by a wall with a door into every corridor."""
    axis = int(rng.integers(dim))
    positions = _spread(rng, int(rng.integers(2, 5 if dim == 2 else 4)), 2.5, size - 2.5, 3.5)
    half = rng.uniform(0.3, 0.6)
    openings, widths = ((1, 4), (1.5, 3.5)) if dim == 2 else ((2, 5), (3.0, 6.0))
    walls = [(position - half, position + half) for position in positions]
    boxes: Boxes = []
    for position in positions:
        count = int(rng.integers(*openings))
        holes = _openings(rng, axis, position, half, count, widths, dim, size)
        boxes += _wall(axis, position, half, holes, dim, size)
    faces = [0.0, *[face for wall in walls for face in wall], size]
    bands = list(zip(faces[::2], faces[1::2]))  # the corridors along ``axis``
    across = int(rng.choice([k for k in range(dim) if k != axis]))
    middle = rng.uniform(3.0, size - 3.0)
    doors = [_opening(rng, across, middle, half, axis, *band, widths, dim, size) for band in bands]
    boxes += _wall(across, middle, half, doors, dim, size)
    for _ in range(int(rng.integers(0, 4))):  # baffles: jut from a wall, stop short of the next
        low, high = bands[int(rng.integers(len(bands)))]
        length = rng.uniform(0.3, 0.6) * (high - low)
        start = low if rng.random() < 0.5 else high - length
        lower, upper = _slab(axis, start, start + length, dim, size)
        side = int(rng.choice([k for k in range(dim) if k != axis]))
        spot = rng.uniform(1.0, size - 1.0)
        lower[side], upper[side] = spot - half, spot + half
        boxes.append((lower, upper))
    count, halves = ((3, 9), (0.3, 1.0)) if dim == 2 else ((12, 25), (0.6, 1.6))
    inside = _boxes_between(rng, int(rng.integers(*count)), halves, axis, walls, dim, size, 0.75)
    cross = [_slab(across, middle - half, middle + half, dim, size)]
    return boxes + _clear_of(inside, cross, 0.75)


def maze(dim: int, size: float, rng: np.random.Generator) -> Boxes:
    """A grid maze: the walls a random spanning tree of the cells keeps, a few more removed."""
    shape = rng.integers(4, 9, size=dim) if dim == 2 else rng.integers(3, 6, size=dim)
    cell = size / shape
    half = rng.uniform(0.2, 0.35) if dim == 2 else rng.uniform(0.3, 0.5)
    index = np.arange(int(np.prod(shape))).reshape(shape)
    faces = []  # (axis, cell on the low side, cell on the high side)
    for axis in range(dim):
        low = index[tuple(slice(0, -1) if k == axis else slice(None) for k in range(dim))]
        high = index[tuple(slice(1, None) if k == axis else slice(None) for k in range(dim))]
        faces += [(axis, int(a), int(b)) for a, b in zip(low.ravel(), high.ravel())]
    parent = list(range(index.size))

    def root(node: int) -> int:
        while parent[node] != node:
            parent[node] = parent[parent[node]]
            node = parent[node]
        return node

    walls = []
    for face in (faces[i] for i in rng.permutation(len(faces))):  # randomized Kruskal
        a, b = root(face[1]), root(face[2])
        if a == b:
            walls.append(face)
        else:
            parent[a] = b
    loops = int(rng.integers(0, index.size // 8 + 1))
    removed = set(rng.choice(len(walls), size=min(loops, len(walls)), replace=False).tolist())
    boxes: Boxes = []
    for i, (axis, low_cell, _) in enumerate(walls):
        if i in removed:
            continue
        corner = np.array(np.unravel_index(low_cell, shape))
        lower, upper = corner * cell - half, (corner + 1) * cell + half  # corners closed
        face = (corner[axis] + 1) * cell[axis]
        lower[axis], upper[axis] = face - half, face + half
        boxes.append((lower, upper))
    return boxes


def traps(dim: int, size: float, rng: np.random.Generator) -> Boxes:
    """One to three cups open in random directions, random boxes around (not on) them."""
    cups: Boxes = []
    boxes: Boxes = []
    for _ in range(int(rng.integers(1, 4 if dim == 2 else 3))):
        for _ in range(50):  # a place that keeps clear of the other cups
            half = rng.uniform(0.25, 0.5)
            outer = rng.uniform(3.0, 8.0 if dim == 2 else 10.0, size=dim) + 2 * half
            lower = rng.uniform(1.5, size - 1.5 - outer)
            upper = lower + outer
            if _clear_of([(lower, upper)], cups, 1.5):
                break
        else:
            continue
        cups.append((lower, upper))
        opening = (int(rng.integers(dim)), int(rng.integers(2)))
        for axis in range(dim):
            for side in range(2):
                if (axis, side) == opening:
                    continue
                wall_lower, wall_upper = lower.copy(), upper.copy()
                if side == 0:
                    wall_upper[axis] = lower[axis] + 2 * half
                else:
                    wall_lower[axis] = upper[axis] - 2 * half
                boxes.append((wall_lower, wall_upper))
    count, halves = ((4, 13), (0.4, 1.5)) if dim == 2 else ((20, 41), (0.8, 2.2))
    around = _uniform_boxes(rng, int(rng.integers(*count)), halves, dim, size)
    return boxes + _clear_of(around, cups, 1.0)


def narrow(dim: int, size: float, rng: np.random.Generator) -> Boxes:
    """One or two thick walls, each with one narrow passage, random boxes beside them."""
    axis = int(rng.integers(dim))
    count = int(rng.integers(1, 3))
    positions = _spread(rng, count, 4.0, size - 4.0, 6.0)
    half = rng.uniform(1.25, 2.25) if count == 1 else rng.uniform(0.9, 1.4)
    widths = (0.7, 1.4) if dim == 2 else (1.2, 2.0)
    walls: Boxes = []
    for position in positions:
        hole = _openings(rng, axis, position, half, 1, widths, dim, size)
        walls += _wall(axis, position, half, hole, dim, size)
    count, halves = ((3, 9), (0.4, 1.2)) if dim == 2 else ((8, 17), (0.6, 1.6))
    faces = [(position - half, position + half) for position in positions]
    count = int(rng.integers(*count))
    return walls + _boxes_between(rng, count, halves, axis, faces, dim, size, 0.75)


def clutter(dim: int, size: float, rng: np.random.Generator) -> Boxes:
    """Many small random boxes, added until a random share of the raster is occupied."""
    target = rng.uniform(0.2, DEFAULT_POINT_WORLDS[dim].max_occupancy)
    count, halves = (160, (0.25, 0.75)) if dim == 2 else (220, (0.6, 1.5))
    half = rng.uniform(*halves, size=(count, dim))
    center = rng.uniform(0.0, size, size=(count, dim))
    cells = int(round(size / RASTER_CELL))
    occupied = np.zeros((cells,) * dim, dtype=bool)
    filled = 0
    boxes: Boxes = []
    for c, h in zip(center, half):
        block = _raster_block(c - h, c + h, cells)
        added = int((~occupied[block]).sum())
        if filled + added > target * occupied.size:
            break
        occupied[block] = True
        filled += added
        boxes.append((c - h, c + h))
    return boxes


BUILDERS: dict[str, Callable[[int, float, np.random.Generator], Boxes]] = {
    "corridors": corridors,
    "maze": maze,
    "traps": traps,
    "narrow": narrow,
    "clutter": clutter,
}
"""The structured families' builders: ``(dim, size, rng) -> boxes``, before the checks."""
