"""Hand-made out-of-distribution problems: structures the task generators never draw.

The default generators (`temp_gym.worlds.point_world`, `temp_gym.worlds.arm_world`) scatter
a handful of independent random boxes. A policy trained on them can learn that clutter, not
planning.
This family is built to tell the two apart: every problem is a deliberate structure, made of
thin walls or many small pieces, whose solution leaves the straight line by far:

* ``bug_trap*``: a cup around the start, open away from the goal; the way out first leads
  away from the goal.
* ``zigzag*``: walls across the world with openings at alternating ends: a long serpentine
  path.
* ``narrow_gap*``: a wall across the world with one narrow gap off-centre, about a step wide.
* ``double_wall``: two walls with their gaps at opposite ends: an S-shaped detour.
* ``long_detour``: a wall almost across, start and goal on its two sides near the closed end:
  a detour many times the straight line.
* ``forest``: a lattice of many small pillars, many more and smaller boxes than any world of
  the default generator has.

and the same ideas in 3D (``cup``, ``window``, ``floors``, ``double_window``, ``pillars``,
``long_detour``). Point worlds are ``[0, 20]^d`` as generated ones, with the generators' goal
radius, so only the structure differs. No training generator produces these layouts: the
opt-in families of `temp_gym.worlds.structured` have walls with openings, cups and clutter,
but randomized and never such a scene (``tests/worlds/test_structured.py`` measures it;
``tests/worlds/test_arm_structured.py`` for the arms' families).

The arms' scenes (the iiwa's here, the Panda's in `temp_gym.evaluation.ood_arm`, made of
structures its training family ``manipulation`` never draws in that form) have tasks drawn
from fixed seeds and checked solvable.

The problems are fixed (no randomness) and stored as JSON under
``examples/ood/{2d,3d,7d,panda}/``; ``python -m temp_gym.evaluation.ood`` rewrites the point
robots' files from the builders here, and the tests check that the two agree; the arms' files,
whose tasks a search finds by planning, are rewritten only when named (`REBUILT_BY_DEFAULT`).
`load_ood_family` reads them.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

from temp_gym.config import script_parser
from temp_gym.config.checks import check_output_dir
from temp_gym.evaluation.ood_arm import PANDA_BUILDERS
from temp_gym.jobs import run_script
from temp_gym.problem import Problem, Workspace
from temp_gym.worlds.robots import FRANKA_PANDA, KUKA_IIWA14, POINT2D, POINT3D, RobotSpec

EXAMPLES_DIR = Path(__file__).resolve().parents[2] / "examples" / "ood"
WORLD_DIRS = {spec.name: spec.short_name for spec in (POINT2D, POINT3D, KUKA_IIWA14, FRANKA_PANDA)}
"""Robot -> folder of its family under `EXAMPLES_DIR` (the robot's short name)."""


def _world_size() -> float:
    """`temp_gym.worlds.point_world.POINT_WORLD_SIZE`, imported when a problem is built.

    The point worlds' module loads numba, which ``--help`` should not.
    """
    from temp_gym.worlds.point_world import POINT_WORLD_SIZE

    return POINT_WORLD_SIZE


WALL = 0.25
"""Half thickness of a wall (world units): half a steering step."""


def _box(lower, upper) -> dict:
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    return {
        "center": ((lower + upper) / 2).tolist(),
        "half_extents": ((upper - lower) / 2).tolist(),
    }


def _problem(spec: RobotSpec, boxes: list[dict], start, goal) -> Problem:
    return Problem.from_dict(
        {
            "robot": spec.name,
            "bounds": [[0.0] * spec.dim, [_world_size()] * spec.dim],
            "obstacles": boxes,
            "start": [float(v) for v in start],
            "goal": [float(v) for v in goal],
            "goal_radius": spec.goal_radius,
        }
    )


# ---- 2D ---------------------------------------------------------------------------------------
def _bug_trap_2d(opening: str) -> Problem:
    """A cup of three walls around the start; the goal lies behind its closed end."""
    w, lo, hi = WALL, 6.5, 13.5
    left = _box([lo - w, lo], [lo + w, hi])
    right = _box([hi - w, lo], [hi + w, hi])
    top = _box([lo - w, hi - w], [hi + w, hi + w])
    if opening == "down":  # open at the bottom, goal above
        return _problem(POINT2D, [left, right, top], [10, 10], [10, 18.5])
    # open to the left, goal to the right: the cup turned by a quarter
    bottom = _box([lo, lo - w], [hi, lo + w])
    right_wall = _box([hi - w, lo - w], [hi + w, hi + w])
    return _problem(POINT2D, [_box([lo, hi - w], [hi, hi + w]), bottom, right_wall],
                    [10, 10], [18.5, 10])  # fmt: skip


def _zigzag_2d(walls: int) -> Problem:
    """``walls`` horizontal walls whose 4-unit openings alternate between the two sides."""
    boxes = []
    for i in range(walls):
        y = _world_size() * (i + 1) / (walls + 1)
        x0, x1 = (0.0, 16.0) if i % 2 == 0 else (4.0, _world_size())
        boxes.append(_box([x0, y - WALL], [x1, y + WALL]))
    return _problem(POINT2D, boxes, [2, 1], [2, 19])


def _narrow_gap_2d(width: float) -> Problem:
    """A wall across the world at x = 10 with one gap of ``width`` around y = 4."""
    gap_low, gap_high = 4.0 - width / 2, 4.0 + width / 2
    boxes = [
        _box([10 - WALL, 0.0], [10 + WALL, gap_low]),
        _box([10 - WALL, gap_high], [10 + WALL, _world_size()]),
    ]
    return _problem(POINT2D, boxes, [3, 16], [17, 16])


def _double_wall_2d() -> Problem:
    """Two walls with their gaps at opposite ends: an S-shaped detour."""
    boxes = [
        _box([7 - WALL, 0.0], [7 + WALL, 17.0]),
        _box([13 - WALL, 3.0], [13 + WALL, _world_size()]),
    ]
    return _problem(POINT2D, boxes, [2, 2], [18, 18])


def _long_detour_2d() -> Problem:
    """A wall from the left edge almost across; start and goal sit on its two sides."""
    return _problem(POINT2D, [_box([0.0, 10 - WALL], [17.5, 10 + WALL])], [2, 8], [2, 12])


def _forest_2d() -> Problem:
    """A lattice of 0.8-wide pillars every 2.2 units, rows shifted: many small boxes."""
    boxes = []
    for row in range(9):
        for col in range(9):
            x = 1.7 + 2.2 * col + (1.1 if row % 2 else 0.0)
            y = 1.7 + 2.2 * row
            if x < 19.6:
                boxes.append(_box([x - 0.4, y - 0.4], [x + 0.4, y + 0.4]))
    return _problem(POINT2D, boxes, [0.5, 0.5], [18.2, 19.3])


# ---- 3D ---------------------------------------------------------------------------------------
def _cup_3d() -> Problem:
    """A box around the start, open at the bottom; the goal lies above its lid."""
    w, lo, hi = WALL, 7.0, 13.0
    boxes = [
        _box([lo - w, lo, lo], [lo + w, hi, hi]),
        _box([hi - w, lo, lo], [hi + w, hi, hi]),
        _box([lo, lo - w, lo], [hi, lo + w, hi]),
        _box([lo, hi - w, lo], [hi, hi + w, hi]),
        _box([lo - w, lo - w, hi - w], [hi + w, hi + w, hi + w]),
    ]
    return _problem(POINT3D, boxes, [10, 10, 10], [10, 10, 18.5])


def _wall_with_hole(x: float, hole_center, half: float) -> list[dict]:
    """A wall across the world at ``x`` with a square hole of side ``2 half`` at (y, z)."""
    y, z = hole_center
    s = _world_size()
    return [
        _box([x - WALL, 0.0, 0.0], [x + WALL, y - half, s]),
        _box([x - WALL, y + half, 0.0], [x + WALL, s, s]),
        _box([x - WALL, y - half, 0.0], [x + WALL, y + half, z - half]),
        _box([x - WALL, y - half, z + half], [x + WALL, y + half, s]),
    ]


def _window_3d() -> Problem:
    """A wall across the world with a 2 x 2 window in a far corner."""
    return _problem(POINT3D, _wall_with_hole(10.0, (4.0, 16.0), 1.0), [3, 16, 4], [17, 16, 4])


def _double_window_3d() -> Problem:
    """Two walls whose windows sit in opposite corners."""
    boxes = _wall_with_hole(7.0, (4.0, 4.0), 1.25) + _wall_with_hole(13.0, (16.0, 16.0), 1.25)
    return _problem(POINT3D, boxes, [2, 10, 10], [18, 10, 10])


def _floors_3d() -> Problem:
    """Three floors, each with a 3 x 3 hole, the holes in alternating corners."""
    boxes = []
    s = _world_size()
    for i, z in enumerate((5.0, 10.0, 15.0)):
        hx, hy = (3.0, 3.0) if i % 2 == 0 else (17.0, 17.0)
        h = 1.5
        boxes += [
            _box([0.0, 0.0, z - WALL], [hx - h, s, z + WALL]),
            _box([hx + h, 0.0, z - WALL], [s, s, z + WALL]),
            _box([hx - h, 0.0, z - WALL], [hx + h, hy - h, z + WALL]),
            _box([hx - h, hy + h, z - WALL], [hx + h, s, z + WALL]),
        ]
    boxes = [b for b in boxes if min(b["half_extents"]) > 0]
    return _problem(POINT3D, boxes, [10, 10, 1.5], [10, 10, 18.5])


def _pillars_3d() -> Problem:
    """A lattice of 0.8-wide vertical pillars every 2.5 units, floor to ceiling."""
    boxes = []
    for i in range(8):
        for j in range(8):
            x, y = 1.75 + 2.5 * i, 1.75 + 2.5 * j
            boxes.append(_box([x - 0.4, y - 0.4, 0.0], [x + 0.4, y + 0.4, _world_size()]))
    return _problem(POINT3D, boxes, [0.5, 0.5, 10], [18.0, 18.0, 10])


def _long_detour_3d() -> Problem:
    """A wall across all but a 2.5-unit strip at the far end; start and goal on its sides."""
    s = _world_size()
    return _problem(POINT3D, [_box([0.0, 0.0, 10 - WALL], [17.5, s, 10 + WALL])],
                    [2, 10, 8], [2, 10, 12])  # fmt: skip


# ---- 7D (the iiwa) ----------------------------------------------------------------------------
FLOOR = _box([-1.5, -1.5, -0.11], [1.5, 1.5, -0.01])
"""The generated worlds' floor slab, kept so that only the furniture differs."""
PLATE = 0.01
"""Half thickness of a plate (m)."""


def _arm_problem(boxes: list[dict], start_near, goal_near, seed: int,
                 spec: RobotSpec = KUKA_IIWA14) -> Problem:  # fmt: skip
    """A task in a fixed scene of axis-aligned ``boxes`` (`ood_arm.arm_task`)."""
    from temp_gym.evaluation.ood_arm import arm_task

    centers = np.array([b["center"] for b in boxes], dtype=np.float64)
    halves = np.array([b["half_extents"] for b in boxes], dtype=np.float64)
    workspace = Workspace(spec.name, spec.joint_limits(), centers, halves)
    return arm_task(workspace, start_near, goal_near, seed)


def _window_7d() -> Problem:
    """A wide wall in front of the robot with a 50 x 50 cm window; the goal reaches through."""
    x, w = 0.55, PLATE
    boxes = [
        FLOOR,
        _box([x - w, -0.9, -0.01], [x + w, -0.25, 1.2]),
        _box([x - w, 0.25, -0.01], [x + w, 0.9, 1.2]),
        _box([x - w, -0.25, -0.01], [x + w, 0.25, 0.3]),
        _box([x - w, -0.25, 0.8], [x + w, 0.25, 1.2]),
    ]
    return _arm_problem(boxes, lambda p: p[0] < -0.2,
                         lambda p: p[0] > x + 0.05 and abs(p[1]) < 0.2 and 0.35 < p[2] < 0.75,
                         seed=1)  # fmt: skip


def _low_ceiling_7d() -> Problem:
    """A ceiling over the whole reach at 0.85 m: the arm must stay folded to swing around."""
    boxes = [FLOOR, _box([-1.2, -1.2, 0.85], [1.2, 1.2, 0.87])]
    return _arm_problem(boxes, lambda p: p[0] > 0.4, lambda p: p[0] < -0.4, seed=2)


def _slot_7d() -> Problem:
    """Two tall plates 30 cm apart beside the robot; the goal has the hand inside the slot."""
    boxes = [
        FLOOR,
        _box([0.25, 0.4 - PLATE, -0.01], [0.9, 0.4 + PLATE, 1.0]),
        _box([0.25, 0.7 - PLATE, -0.01], [0.9, 0.7 + PLATE, 1.0]),
    ]
    return _arm_problem(boxes, lambda p: p[1] < -0.3,
                         lambda p: 0.45 < p[1] < 0.65 and p[0] > 0.3, seed=3)  # fmt: skip


def _cubby_7d() -> Problem:
    """A closed box open towards the robot, on a stand behind it; the goal is inside."""
    x0, x1, y0, y1, z0, z1 = -0.95, -0.5, -0.25, 0.25, 0.3, 0.75
    boxes = [
        FLOOR,
        _box([x0, y0, z0 - 2 * PLATE], [x1, y1, z0]),  # floor of the cubby
        _box([x0, y0, z1], [x1, y1, z1 + 2 * PLATE]),  # top
        _box([x0, y0 - 2 * PLATE, z0], [x1, y0, z1]),  # sides
        _box([x0, y1, z0], [x1, y1 + 2 * PLATE, z1]),
        _box([x0 - 2 * PLATE, y0, z0], [x0, y1, z1]),  # back
        _box([-0.85, -0.2, -0.01], [-0.6, 0.2, z0 - 2 * PLATE]),  # stand
    ]
    return _arm_problem(boxes, lambda p: p[0] > 0.3,
                         lambda p: x0 + 0.05 < p[0] < x1 and y0 + 0.05 < p[1] < y1 - 0.05
                         and z0 + 0.05 < p[2] < z1 - 0.05, seed=4)  # fmt: skip


def _pillar_ring_7d() -> Problem:
    """Eight pillars in a ring around the robot: many narrow gaps."""
    boxes = [FLOOR]
    for k in range(8):
        angle = 2 * np.pi * k / 8 + np.pi / 8
        x, y = 0.55 * np.cos(angle), 0.55 * np.sin(angle)
        boxes.append(_box([x - 0.05, y - 0.05, -0.01], [x + 0.05, y + 0.05, 1.1]))
    return _arm_problem(boxes, lambda p: np.hypot(p[0], p[1]) > 0.7 and p[0] > 0.3,
                         lambda p: np.hypot(p[0], p[1]) > 0.7 and p[0] < -0.3, seed=5)  # fmt: skip


BUILDERS: dict[str, dict[str, Callable[[], Problem]]] = {
    POINT2D.name: {
        "bug_trap": lambda: _bug_trap_2d("down"),
        "bug_trap_side": lambda: _bug_trap_2d("left"),
        "zigzag_3": lambda: _zigzag_2d(3),
        "zigzag_5": lambda: _zigzag_2d(5),
        "narrow_gap": lambda: _narrow_gap_2d(1.0),
        "narrow_gap_tight": lambda: _narrow_gap_2d(0.7),
        "double_wall": _double_wall_2d,
        "long_detour": _long_detour_2d,
        "forest": _forest_2d,
    },
    POINT3D.name: {
        "cup": _cup_3d,
        "window": _window_3d,
        "double_window": _double_window_3d,
        "floors": _floors_3d,
        "pillars": _pillars_3d,
        "long_detour": _long_detour_3d,
    },
    KUKA_IIWA14.name: {
        "window": _window_7d,
        "low_ceiling": _low_ceiling_7d,
        "slot": _slot_7d,
        "cubby": _cubby_7d,
        "pillar_ring": _pillar_ring_7d,
    },
    FRANKA_PANDA.name: PANDA_BUILDERS,
}
"""Robot -> name -> builder of each problem of the family."""


def build_ood_family(robot: str) -> dict[str, Problem]:
    """The family of ``robot``, built from code (what the stored files must equal)."""
    if robot not in BUILDERS:
        raise ValueError(f"robot: no out-of-distribution family for {robot!r}")
    return {name: build() for name, build in BUILDERS[robot].items()}


def load_ood_family(robot: str, directory: str | Path | None = None) -> dict[str, Problem]:
    """The stored family of ``robot`` (``examples/ood/<short name>/*.json``), by name."""
    if robot not in WORLD_DIRS:
        raise ValueError(f"robot: no out-of-distribution family for {robot!r}")
    folder = Path(directory) if directory is not None else EXAMPLES_DIR / WORLD_DIRS[robot]
    files = sorted(folder.glob("*.json"))
    if not files:
        raise FileNotFoundError(f"{folder}: no problems (python -m temp_gym.evaluation.ood)")
    return {path.stem: Problem.load(path) for path in files}


REBUILT_BY_DEFAULT = ("point2d", "point3d")
"""The families `main` writes unless told others: the point robots', which their builders give
exactly (the tests check the stored files). The arms' tasks come from a seeded search that
plans, so today's planners and checkers may find others: their stored files are the family of
record, rewritten only when named."""


def main(argv: list[str] | None = None) -> None:
    """Write the families' problems to ``examples/ood`` (`REBUILT_BY_DEFAULT`, or ``--robots``)."""
    parser = script_parser(
        "Write the out-of-distribution problems.",
        epilog="Output: {out}/{2d,3d,7d,panda}/{problem}.json, made if missing, replaced if "
        "present. The arms' families are searched by planning: name them with --robots to "
        "draw them anew.",
    )
    parser.add_argument("--out", type=Path, default=EXAMPLES_DIR, help="folder of the families")
    parser.add_argument("--robots", nargs="+", choices=list(WORLD_DIRS),
                        default=list(REBUILT_BY_DEFAULT), help="the families to write")  # fmt: skip
    args = parser.parse_args(argv)
    check_output_dir(args.out, "--out")
    for robot in dict.fromkeys(args.robots):
        folder = WORLD_DIRS[robot]
        target = args.out / folder
        target.mkdir(parents=True, exist_ok=True)
        for name, problem in build_ood_family(robot).items():
            problem.save(target / f"{name}.json")
        print(f"{target}: {len(BUILDERS[robot])} problems")


if __name__ == "__main__":
    sys.exit(run_script("python -m temp_gym.evaluation.ood", main))
