"""The arms' out-of-distribution scenes: a task finder, and the Panda's scenes.

`arm_task` draws a known-solvable task in a fixed arm scene (the iiwa's scenes in
`temp_gym.evaluation.ood` use it too). The Panda's scenes are made of structures its
training family, ``manipulation`` (`temp_gym.worlds.arm_manipulation`), never draws in that
form: that family has shelves with at most one divider, boxes open at the top, cages and
tables, and no walls, ceilings or free-standing pillars. Here:

* ``window``: a wall across the reach with one window, turned 30 degrees;
* ``low_ceiling``: a ceiling over the whole reach at 0.7 m;
* ``pillar_ring``: eight upright cylinders in a ring around the robot;
* ``cubby_grid``: three by three compartments, open towards the robot, turned -50 degrees;
* ``side_box``: a box lying on its side, open towards the robot, behind it.

Each scene stands on the floor slab of `temp_gym.worlds.arm_world` (as the iiwa's do), at
fixed coordinates; the tasks are drawn from fixed seeds, so the scenes are fixed problems.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from temp_gym.problem import Problem, Workspace
from temp_gym.worlds.arm_pieces import Piece, as_obstacles, box, cylinder, placed, turn_about_z
from temp_gym.worlds.robots import FRANKA_PANDA, robot_spec

FEASIBILITY_NODES = 5_000
"""Node budget of the Informed RRT* run that shows an arm's task is solvable."""
PLATE = 0.01
"""Half thickness of a plate (m)."""
FLOOR = box((0.0, 0.0, -0.06), (1.5, 1.5, 0.05))
"""The generated worlds' floor slab (top at -1 cm), kept so that only the structures differ."""

Near = Callable[[np.ndarray], bool]
"""A predicate on the end effector's position (the last body's origin)."""


def arm_task(workspace: Workspace, start_near: Near, goal_near: Near, seed: int) -> Problem:
    """A task in a fixed arm scene: start and goal with the end effector in given regions.

    Configurations are drawn from a fixed seed; a pair is kept when both are free, the
    straight motion between them is blocked, and Informed RRT* (seed 0, `FEASIBILITY_NODES`
    nodes) connects them, so the task is known to be solvable. Deterministic: the same scene
    and seed give the same task.

    Raises:
        RuntimeError: no such pair in 400 batches of 512 configurations.
    """
    from temp_gym.planning.plan import plan
    from temp_gym.worlds.arm.model import load_arm

    spec = robot_spec(workspace.robot)
    arm = load_arm(spec.description)
    limits = workspace.bounds
    checker = spec.make_checker(workspace)
    rng = np.random.default_rng(seed)
    candidates: dict[str, list[np.ndarray]] = {"start": [], "goal": []}
    for _ in range(400):
        states = rng.uniform(limits[0], limits[1], size=(512, arm.dim))
        free = checker.states_free(states)
        effector = arm.forward_kinematics(states)[:, -1, :3, 3]
        for name, near in (("start", start_near), ("goal", goal_near)):
            hits = np.flatnonzero(free & np.array([bool(near(p)) for p in effector]))
            candidates[name].extend(states[hits[:4]])
        pairs = min(len(candidates["start"]), len(candidates["goal"]))
        for start, goal in zip(candidates["start"][:pairs], candidates["goal"][:pairs]):
            if checker.edge_free(start, goal):
                continue
            problem = Problem(workspace, start, goal, spec.goal_radius)
            result = plan(problem, planner="informed_rrt_star", seed=0,
                          max_nodes=FEASIBILITY_NODES, stop_at_first=True)  # fmt: skip
            if result.success:
                return problem
        candidates = {name: found[pairs:] for name, found in candidates.items()}
    raise RuntimeError("no solvable start and goal found for this scene")


def _panda_problem(pieces: list[Piece], start_near: Near, goal_near: Near, seed: int) -> Problem:
    limits = FRANKA_PANDA.joint_limits()
    workspace = Workspace.from_obstacles(FRANKA_PANDA.name, limits, as_obstacles([FLOOR, *pieces]))
    return arm_task(workspace, start_near, goal_near, seed)


def _local(point: np.ndarray, yaw: float) -> np.ndarray:
    """A world point in the frame of a structure turned by ``yaw`` about the base."""
    return turn_about_z(np.asarray(point, float), -yaw)


def _window() -> Problem:
    """A wall 55 cm away, 1.6 m wide and 1.1 m tall, with a 50 x 45 cm window, turned 30 deg.

    The start has the hand in front of the wall beside the window, the goal through it.
    """
    x, yaw = 0.55, np.pi / 6
    wall = [
        box((x, -0.525, 0.545), (PLATE, 0.275, 0.555)),
        box((x, 0.525, 0.545), (PLATE, 0.275, 0.555)),
        box((x, 0.0, 0.12), (PLATE, 0.25, 0.13)),
        box((x, 0.0, 0.9), (PLATE, 0.25, 0.2)),
    ]
    return _panda_problem(
        placed(wall, yaw),
        lambda p: 0.1 < (q := _local(p, yaw))[0] < x - 0.1 and abs(q[1]) > 0.35,
        lambda p: (q := _local(p, yaw))[0] > x + 0.05 and abs(q[1]) < 0.15 and 0.35 < q[2] < 0.6,
        seed=11,
    )


def _low_ceiling() -> Problem:
    """A ceiling over the whole reach at 0.7 m: the arm stays folded to swing around."""
    return _panda_problem([box((0.0, 0.0, 0.71), (1.2, 1.2, PLATE))], lambda p: p[0] > 0.35,
                          lambda p: p[0] < -0.35, seed=12)  # fmt: skip


def _pillar_ring() -> Problem:
    """Eight cylinders 8 cm across, floor to 1 m, in a ring of radius 0.5 m around the robot."""
    pillars = []
    for k in range(8):
        angle = 2 * np.pi * k / 8 + np.pi / 8
        pillars.append(cylinder((0.5 * np.cos(angle), 0.5 * np.sin(angle), 0.495), 0.04, 0.505))
    outside = 0.6
    return _panda_problem(pillars, lambda p: np.hypot(p[0], p[1]) > outside and p[0] > 0.25,
                          lambda p: np.hypot(p[0], p[1]) > outside and p[0] < -0.25,
                          seed=13)  # fmt: skip


def _cubby_grid() -> Problem:
    """Three by three cells (30 cm wide, 28 cm tall, 30 cm deep) from 0.1 m up, turned -50 deg.

    They are open towards the robot, on a stand; the goal has the hand within 20 cm of the
    right half of the grid's face, or in a cell there.
    """
    near, depth, cell, tall, bottom, yaw = 0.55, 0.15, 0.3, 0.28, 0.1, -5 * np.pi / 18
    x, half_width = near + depth, 1.5 * cell
    top = bottom + 3 * tall
    pieces = [box((x + depth + PLATE, 0.0, (bottom + top) / 2), (PLATE, half_width, 1.5 * tall))]
    pieces += [
        box((x, 0.0, bottom + k * tall), (depth, half_width + PLATE, PLATE)) for k in range(4)
    ]
    pieces += [box((x, -half_width + k * cell, (bottom + top) / 2), (depth, PLATE, 1.5 * tall))
               for k in range(4)]  # fmt: skip
    stand = (bottom - PLATE + 0.01) / 2  # from the floor's top (-1 cm) to the lowest board
    pieces.append(box((x, 0.0, bottom - PLATE - stand), (depth, 0.8 * half_width, stand)))
    return _panda_problem(
        placed(pieces, yaw),
        lambda p: _local(p, yaw)[0] < -0.2,
        lambda p: near - 0.2 < (q := _local(p, yaw))[0] < x and 0.0 < q[1] < half_width
        and bottom < q[2] < top,
        seed=14,
    )  # fmt: skip


def _side_box() -> Problem:
    """A 60 cm box lying on its side behind the robot, open towards it, on a stand.

    The goal has the hand in its opening.
    """
    near, half, bottom, yaw = 0.4, 0.3, 0.2, 5 * np.pi / 6
    x, z = near + half, bottom + half
    stand = (bottom - PLATE + 0.01) / 2  # from the floor's top (-1 cm) to the bottom plate
    pieces = [
        box((x + half, 0.0, z), (PLATE, half, half)),  # back
        box((x, -half, z), (half, PLATE, half)),  # sides
        box((x, half, z), (half, PLATE, half)),
        box((x, 0.0, bottom), (half, half, PLATE)),  # bottom and top
        box((x, 0.0, bottom + 2 * half), (half, half, PLATE)),
        box((x, 0.0, bottom - PLATE - stand), (0.6 * half, 0.6 * half, stand)),  # the stand
    ]
    return _panda_problem(
        placed(pieces, yaw),
        lambda p: _local(p, yaw)[0] < -0.2,
        lambda p: (q := _local(p, yaw))[0] > near - 0.05 and abs(q[1]) < half - 0.06
        and bottom + 0.06 < q[2] < bottom + 2 * half - 0.06,
        seed=15,
    )  # fmt: skip


PANDA_BUILDERS: dict[str, Callable[[], Problem]] = {
    "window": _window,
    "low_ceiling": _low_ceiling,
    "pillar_ring": _pillar_ring,
    "cubby_grid": _cubby_grid,
    "side_box": _side_box,
}
"""The Panda's out-of-distribution scenes, by name."""


__all__ = ["FEASIBILITY_NODES", "PANDA_BUILDERS", "arm_task"]
