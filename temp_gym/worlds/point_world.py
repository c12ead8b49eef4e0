"""Point worlds: seeded generators of box workspaces and start-goal tasks, easy or challenging.

A point robot's configuration is its position, so its workspace is a box world ``[0, 20]^d``
(d = 2 or 3) scattered with random boxes. All randomness comes from the
`numpy.random.Generator` passed in; nothing touches global state, so the same seed always
gives the same problems.

**Difficulty, measurably.** For a task with start s and goal g, let
``ratio = reference_cost / |g - s|`` where ``reference_cost`` is the cost of the reference path
of `temp_gym.worlds.reference` (lattice shortest path, shortcut; 1.0 when the straight segment
is free). Then, for point worlds:

* **easy**: ``ratio <= EASY_MAX_RATIO`` (1.05): the straight line is free or nearly so;
* **challenging**: the straight line is blocked and ``ratio >= CHALLENGING_MIN_RATIO[d]``
  (1.20 in 2D, 1.10 in 3D, where a third axis makes detours shorter): the robot must make a
  real detour around obstacles.

Tasks in between are neither and are only drawn with ``difficulty="any"``. Both kinds keep start
and goal at least ``MIN_DISTANCE_FRACTION`` of the workspace diagonal apart. The iiwa's own
definition lives in `temp_gym.worlds.arm_world`; `temp_gym.worlds.generators` draws for any
robot through its spec.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from temp_gym.problem import Problem, Workspace, robot_named
from temp_gym.worlds.collision.point import PointBoxChecker
from temp_gym.worlds.collision.point_shapes import point_checker
from temp_gym.worlds.difficulty import check_difficulty
from temp_gym.worlds.reference import ReferencePlanner

EASY_MAX_RATIO = 1.05
CHALLENGING_MIN_RATIO = {2: 1.20, 3: 1.10}
MIN_DISTANCE_FRACTION = 0.4
POINT_WORLD_SIZE = 20.0
MAX_TASK_TRIES = 500
REFERENCE_CACHE_SIZE = 16
"""Workspaces whose reference planner (a lattice graph) is kept for their next tasks."""


@dataclass(frozen=True)
class PointWorldConfig:
    """How random point workspaces are drawn (defaults follow the paper's 20 x 20 worlds)."""

    size: float = POINT_WORLD_SIZE
    """Side of the cubic workspace [0, size]^d."""
    min_boxes: int = 8
    """Fewest boxes."""
    max_boxes: int = 14
    """Most boxes (inclusive)."""
    min_half_extent: float = 0.4
    """Smallest half side of a box."""
    max_half_extent: float = 2.8
    """Largest half side of a box."""
    max_occupancy: float = 0.35
    """Reject workspaces whose boxes cover more than this fraction of the space."""


DEFAULT_POINT_WORLDS = {
    2: PointWorldConfig(),
    # 3D needs many more boxes for the same clutter: a detour in 3D has one more way around.
    3: PointWorldConfig(min_boxes=30, max_boxes=45, min_half_extent=0.8, max_half_extent=3.2),
}


def generate_point_workspace(
    robot: str, rng: np.random.Generator, config: PointWorldConfig | None = None
) -> Workspace:
    """Draw a random box workspace in [0, size]^d for the point robot ``robot`` (d = 2 or 3)."""
    dim = robot_named(robot).dim
    if dim not in (2, 3):
        raise ValueError(f"robot: point worlds are 2D or 3D, got {dim}D {robot!r}")
    config = config or DEFAULT_POINT_WORLDS[dim]
    bounds = np.array([np.zeros(dim), np.full(dim, config.size)])
    for _ in range(100):
        count = int(rng.integers(config.min_boxes, config.max_boxes + 1))
        halves = rng.uniform(config.min_half_extent, config.max_half_extent, size=(count, dim))
        centers = rng.uniform(0.0, config.size, size=(count, dim))
        probe = rng.uniform(0.0, config.size, size=(4000, dim))
        checker = PointBoxChecker(bounds, centers - halves, centers + halves)
        if 1.0 - checker.states_free(probe).mean() <= config.max_occupancy:
            return Workspace(robot, bounds, centers, halves)
    raise RuntimeError("could not draw a workspace under the occupancy limit; loosen the config")


def classify_task(
    reference: ReferencePlanner, start: np.ndarray, goal: np.ndarray
) -> tuple[str, float]:
    """Return ``(label, ratio)`` for a point task: label is easy, challenging or neither."""
    straight = float(np.linalg.norm(np.asarray(goal) - np.asarray(start)))
    solution = reference.solve(start, goal)
    ratio = solution.cost / straight if straight > 0 else 1.0
    blocked = not reference.checker.edge_free(start, goal)
    if ratio <= EASY_MAX_RATIO:
        return "easy", ratio
    if blocked and ratio >= CHALLENGING_MIN_RATIO[len(start)] and np.isfinite(ratio):
        return "challenging", ratio
    return "neither", ratio


@functools.lru_cache(maxsize=REFERENCE_CACHE_SIZE)
def reference_planner(workspace: Workspace) -> ReferencePlanner:
    """The `ReferencePlanner` of ``workspace``, built once for its many tasks."""
    return ReferencePlanner(workspace)


def generate_point_task(
    workspace: Workspace,
    rng: np.random.Generator,
    difficulty: str,
    goal_radius: float,
) -> Problem:
    """Draw a start-goal task of the requested difficulty in a point workspace.

    Args:
        workspace: where to plan.
        rng: the only source of randomness.
        difficulty: ``"any"``, ``"easy"`` or ``"challenging"`` (see the module docstring).
        goal_radius: radius of the goal ball.

    Raises:
        RuntimeError: if no task of that difficulty turns up in `MAX_TASK_TRIES` draws.
    """
    check_difficulty(difficulty)
    checker = point_checker(workspace)
    lower, upper = workspace.bounds
    min_distance = MIN_DISTANCE_FRACTION * float(np.linalg.norm(upper - lower))
    reference = reference_planner(workspace) if difficulty != "any" else None
    for _ in range(MAX_TASK_TRIES):
        pair = rng.uniform(lower, upper, size=(2, workspace.dim))
        if np.linalg.norm(pair[1] - pair[0]) < min_distance or not checker.states_free(pair).all():
            continue
        if difficulty != "any":
            label, _ = classify_task(reference, pair[0], pair[1])
            if label != difficulty:
                continue
        return Problem(workspace, pair[0], pair[1], goal_radius)
    raise RuntimeError(
        f"no {difficulty} task found in {MAX_TASK_TRIES} draws; this workspace may be too open "
        "or too cluttered for it"
    )
