"""The fast arm checker near surfaces: convex pieces decide what the spheres' bulge cannot.

`pieces_clear` must be a certificate (never clear a piece fcl finds closer than asked) and a
useful one (clear a piece fcl finds clearly farther); the support walk must find the lowest
corner; and the checker must accept a link a fraction of a millimetre above a table, leave it
along a certified motion, refuse it once it dips in, and never free a state or a motion the
exact checker refuses.
"""

from __future__ import annotations

import fcl
import numba
import numpy as np
import pytest

from temp_gym.problem import Workspace
from temp_gym.problem.obstacles import Box, Cylinder, Sphere
from temp_gym.worlds.arm.model import load_arm
from temp_gym.worlds.arm_world import generate_arm_task
from temp_gym.worlds.collision.arm_exact import obstacle_objects
from temp_gym.worlds.collision.arm_fast import ArmSphereChecker
from temp_gym.worlds.collision.arm_fast_hulls import _piece_lowest, hull_arrays, pieces_clear
from temp_gym.worlds.collision.arm_obstacles import arm_obstacles
from temp_gym.worlds.collision.arm_self import convex_model
from temp_gym.worlds.robots import robot_spec
from temp_gym.worlds.splits import split_workspace

ROBOTS = ["kuka_iiwa14", "franka_panda"]


@pytest.fixture(scope="module")
def arms():
    return {robot: load_arm(robot_spec(robot).description) for robot in ROBOTS}


@numba.njit
def _walk(poses, j, hulls, k, v):
    corners, _, _, _, neighbor_start, neighbors = hulls
    point, _ = _piece_lowest(poses, j, corners, neighbor_start, neighbors, k, (v[0], v[1], v[2]))
    return point[0] * v[0] + point[1] * v[1] + point[2] * v[2]


@numba.njit
def _clear(poses, j, hulls, tables, b, any_kind, growth):
    return pieces_clear(poses, j, hulls, tables, b, any_kind, growth)


def _poses(arm, state) -> np.ndarray:
    return np.ascontiguousarray(arm.forward_kinematics(state)[0][:, :3, :])


@pytest.mark.parametrize("robot", ROBOTS)
def test_support_walk_finds_the_lowest_corner(arms, robot):
    arm = arms[robot]
    hulls = hull_arrays(arm)
    corners, piece_start, body_pieces = hulls[:3]
    rng = np.random.default_rng(0)
    poses = _poses(arm, rng.uniform(*arm.joint_limits()))
    for j in range(1, arm.num_bodies):
        for p in range(body_pieces[j], body_pieces[j + 1]):
            first, last = piece_start[p], piece_start[p + 1]
            world = corners[first:last] @ poses[j, :, :3].T + poses[j, :, 3]
            for v in rng.normal(size=(20, 3)):
                start = int(rng.integers(first, last))
                assert _walk(poses, j, hulls, start, v) == pytest.approx(
                    float((world @ v).min()), abs=1e-12)  # fmt: skip


def _near_obstacle(rng, center):
    """An obstacle of a random kind whose center is ``center``, turned at random."""
    q = rng.normal(size=4)
    q = tuple(q / np.linalg.norm(q))
    kind = rng.integers(4)
    if kind == 0:
        return Box(tuple(center), tuple(rng.uniform(0.02, 0.1, 3)))
    if kind == 1:
        return Box(tuple(center), tuple(rng.uniform(0.02, 0.1, 3)), q)
    if kind == 2:
        return Cylinder(tuple(center), float(rng.uniform(0.02, 0.08)),
                        float(rng.uniform(0.05, 0.2)), q)  # fmt: skip
    return Sphere(tuple(center), float(rng.uniform(0.02, 0.08)))


@pytest.mark.parametrize("robot", ROBOTS)
def test_pieces_clear_is_a_certificate_and_converges(arms, robot):
    """Against fcl's distance from each piece's hull, for every obstacle kind, a few
    millimetres either side of the growth asked."""
    arm = arms[robot]
    hulls = hull_arrays(arm)
    corners, piece_start, body_pieces = hulls[:3]
    rng = np.random.default_rng(1)
    limits = arm.joint_limits()
    checked = cleared = 0
    for _ in range(40):
        state = rng.uniform(*limits)
        poses = _poses(arm, state)
        j = int(rng.integers(1, arm.num_bodies))
        if body_pieces[j] == body_pieces[j + 1]:
            continue
        pieces = range(body_pieces[j], body_pieces[j + 1])
        world = [corners[piece_start[p]:piece_start[p + 1]] @ poses[j, :, :3].T + poses[j, :, 3]
                 for p in pieces]  # fmt: skip
        models = [fcl.CollisionObject(convex_model(w)[0]) for w in world]
        anchor = world[0][rng.integers(len(world[0]))]
        for _ in range(10):
            direction = rng.normal(size=3)
            direction /= np.linalg.norm(direction)
            obstacle = _near_obstacle(rng, anchor + direction * rng.uniform(0.03, 0.15))
            obstacles = arm_obstacles(Workspace.from_obstacles(robot, limits, [obstacle]))
            target = obstacle_objects(obstacles)[0]
            distance = min(fcl.distance(m, target, fcl.DistanceRequest(), fcl.DistanceResult())
                           for m in models)  # fmt: skip
            if distance < 0:
                distance = 0.0
            checker = ArmSphereChecker(arm, np.array(limits), obstacles=obstacles)
            tables = checker._obstacle_arrays[0]
            any_kind = not obstacles.axis_aligned[0]
            for growth in (0.0, 0.002, max(distance - 0.001, 0.0), distance + 0.001):
                clear = _clear(poses, j, hulls, tables, 0, any_kind, growth)
                checked += 1
                cleared += clear
                if clear:  # fcl's GJK on curved shapes is good to about 1e-5 m
                    assert distance > growth - 2e-5, (distance, growth)
                if distance > growth + 2e-4:
                    assert clear, (distance, growth)
    assert 0 < cleared < checked


def _hull_distance(arm, state, body, box) -> float:
    """fcl's distance from body ``body``'s convex pieces to ``box`` (axis-aligned)."""
    corners, piece_start, body_pieces = hull_arrays(arm)[:3]
    poses = _poses(arm, state)
    slab = fcl.CollisionObject(fcl.Box(*(2 * np.asarray(box.half_extents))),
                               fcl.Transform(np.asarray(box.center, dtype=np.float64)))  # fmt: skip
    out = np.inf
    for p in range(body_pieces[body], body_pieces[body + 1]):
        world = corners[piece_start[p] : piece_start[p + 1]] @ poses[body, :, :3].T
        piece = fcl.CollisionObject(convex_model(world + poses[body, :, 3])[0])
        out = min(out, fcl.distance(piece, slab, fcl.DistanceRequest(), fcl.DistanceResult()))
    return out


def _table_under(arm, state, body, gap):
    """A 6 cm slab whose top is ``gap`` below body ``body``'s lowest hull corner."""
    hulls = hull_arrays(arm)
    corners, piece_start, body_pieces = hulls[:3]
    poses = _poses(arm, state)
    rows = slice(piece_start[body_pieces[body]], piece_start[body_pieces[body + 1]])
    world = corners[rows] @ poses[body, :, :3].T + poses[body, :, 3]
    low = world[np.argmin(world[:, 2])]
    return Box((low[0], low[1], low[2] - gap - 0.01), (0.03, 0.03, 0.01))


@pytest.mark.parametrize("robot", ROBOTS)
def test_a_link_a_fraction_of_a_millimetre_above_a_table(arms, robot):
    """Free by the pieces though the spheres may touch; refused once it dips in; left along
    a certified motion; the exact checker agrees."""
    arm = arms[robot]
    spec = robot_spec(robot)
    limits = arm.joint_limits()
    rng = np.random.default_rng(2)
    body = arm.num_bodies - 1  # the hand
    tried = accepted = bulge_refused = 0
    while tried < 12:
        state = rng.uniform(*limits)
        above = _table_under(arm, state, body, 0.0004)
        workspace = Workspace.from_obstacles(robot, limits, [above])
        exact = spec.make_checker(workspace, exact=True)
        if not exact.states_free(state[None])[0] or any(
                _hull_distance(arm, state, other, above) < 0.003
                for other in range(1, body)):  # fmt: skip
            continue  # another link (or the arm itself) is in the way
        tried += 1
        fast = spec.make_checker(workspace)
        spheres_only = ArmSphereChecker(arm, workspace.bounds, obstacles=arm_obstacles(workspace),
                                        near_surfaces=False)  # fmt: skip
        accepted += bool(fast.states_free(state[None])[0])
        bulge_refused += not spheres_only.states_free(state[None])[0]
        # Dipped 0.4 mm in: refused by both.
        dipped = Workspace.from_obstacles(robot, limits, [_table_under(arm, state, body, -0.0004)])
        assert not spec.make_checker(dipped).states_free(state[None])[0]
        assert not spec.make_checker(dipped, exact=True).states_free(state[None])[0]
        # Lifting the hand: a motion the fast checker certifies only if the exact one does.
        for i in range(arm.dim):
            end = state.copy()
            end[i] = np.clip(end[i] + rng.choice([-0.3, 0.3]), *limits[:, i])
            if fast.edge_free(state, end):
                assert exact.edge_free(state, end)
    assert accepted == tried
    assert bulge_refused > 0  # the spheres alone refuse some of them


@pytest.mark.parametrize("robot", ROBOTS)
def test_never_frees_what_the_exact_checker_refuses(arms, robot):
    """Near-surface states and motions out of them in test workspaces: the pieces only free
    what the spheres refused, and nothing the exact checker refuses."""
    spec = robot_spec(robot)
    arm = arms[robot]
    rng = np.random.default_rng(3)
    freed = 0
    for index in range(3):
        workspace = split_workspace(robot, "test", index, "boxes")
        fast, exact = spec.make_checker(workspace), spec.make_checker(workspace, exact=True)
        spheres_only = ArmSphereChecker(arm, workspace.bounds, obstacles=arm_obstacles(workspace),
                                        near_surfaces=False)  # fmt: skip
        task = generate_arm_task(workspace, rng, "any", spec.goal_radius, near="both")
        ends = np.array([task.start, task.goal])
        states = np.concatenate([ends + rng.normal(0, 0.004, size=(200, arm.dim)) for ends
                                 in ends])  # fmt: skip
        states = np.clip(states, *workspace.bounds)
        new, old = fast.states_free(states), spheres_only.states_free(states)
        assert not np.any(old & ~new)
        assert not np.any(new & ~exact.states_free(states))
        freed += int(np.sum(new & ~old))
        starts = states[new][:60]
        goals = np.clip(starts + rng.normal(0, 0.1, size=starts.shape), *workspace.bounds)
        moves, old_moves = fast.edges_free(starts, goals), spheres_only.edges_free(starts, goals)
        assert not np.any(old_moves & ~moves)
        assert not np.any(moves & ~exact.edges_free(starts, goals))
    assert freed > 0
