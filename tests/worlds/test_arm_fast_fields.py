"""Distance fields in the fast arm checker: certified lower bounds, and no verdict changed.

The fields only speed up the self-collision walk, so the checker must answer exactly as it
does without them, state by state (with and without clearance), edge by edge and pair by pair.
"""

from __future__ import annotations

import numba
import numpy as np
import pytest
from arm_fixtures import motions_from

from temp_gym.worlds.arm.model import load_arm
from temp_gym.worlds.arm_world import generate_arm_workspace
from temp_gym.worlds.collision.arm_fast import ArmSphereChecker, _self_fields, sphere_trees
from temp_gym.worlds.collision.arm_fast_fields import FIELD_CAP, body_fields, field_bound
from temp_gym.worlds.robots import robot_spec

ROBOTS = ["kuka_iiwa14", "franka_panda"]


@pytest.fixture(scope="module")
def arms():
    return {robot: load_arm(robot_spec(robot).description) for robot in ROBOTS}


@numba.njit
def _bounds(values, layout, body, points, center, radius):
    """`field_bound` at each point."""
    out = np.empty(len(points))
    for i in range(len(points)):
        out[i] = field_bound(values, layout, body, points[i, 0], points[i, 1], points[i, 2],
                             center[0], center[1], center[2], radius)  # fmt: skip
    return out


@numba.njit
def _nearest_gap(points, centers, radii):
    out = np.empty(len(points))
    for i in range(len(points)):
        gaps = np.sqrt(((centers - points[i]) ** 2).sum(axis=1)) - radii
        out[i] = gaps.min()
    return out


def _leaf_distance(trees, body, points):
    """Exact distance from each point (body frame) to the body's leaf spheres."""
    chosen = trees.sphere_body == body
    return _nearest_gap(points, trees.centers[chosen], trees.radii[chosen])


@pytest.mark.parametrize("robot", ROBOTS)
def test_a_field_bounds_the_distance_from_below_and_closely(arms, robot):
    """On the grid, off it and near the surface, the bound never exceeds the distance to the
    leaves; where the field stores the distance (below the cap) it loses at most twice the
    distance to the nearest grid point (a grid cell's diagonal), plus float32 rounding."""
    trees = sphere_trees(arms[robot])
    values, layout = _self_fields(arms[robot], True)
    bodies = np.flatnonzero(layout[:, 0] >= 0)
    assert len(bodies) > 0
    rng = np.random.default_rng(0)
    for body in bodies:
        root = trees.body_start[body]
        center, radius = trees.node_centers[root], trees.node_radii[root]
        spread = radius + 1.5 * FIELD_CAP  # reaches past the grid's edge
        points = center + rng.uniform(-spread, spread, size=(4000, 3))
        # and points just outside the leaves, where the walk asks most
        chosen = np.flatnonzero(trees.sphere_body == body)[rng.integers(0, 100, 1000)]
        direction = rng.normal(size=(1000, 3))
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        points = np.concatenate([points, trees.centers[chosen] + direction * (
            trees.radii[chosen, None] + rng.uniform(0.0, 0.03, (1000, 1)))])  # fmt: skip
        truth = _leaf_distance(trees, body, points)
        bound = _bounds(values, layout, body, points, center, radius)
        assert np.all(bound <= truth + 1e-12), float(np.max(bound - truth))
        spacing = layout[body, 2]
        low = layout[body, 3:6]
        high = low + spacing * (layout[body, 1] - 1)
        inside = np.all((points >= low) & (points <= high), axis=1) & (truth < FIELD_CAP - spacing)
        assert inside.sum() > 1000
        loss = truth[inside] - bound[inside]
        assert loss.max() <= spacing * np.sqrt(3) + 1e-6, float(loss.max())


def test_inside_a_cell_the_bound_is_the_best_of_its_corners(arms):
    """Never below the nearest grid point's bound, and above it where another corner is
    better: a bound from the nearest point alone prunes less of the other body's tree."""
    trees = sphere_trees(arms["franka_panda"])
    values, layout = _self_fields(arms["franka_panda"], True)
    rng = np.random.default_rng(1)
    for body in np.flatnonzero(layout[:, 0] >= 0):
        offset, cells, spacing = int(layout[body, 0]), int(layout[body, 1]), layout[body, 2]
        low = layout[body, 3:6]
        grid = values[offset : offset + cells**3].reshape(cells, cells, cells).astype(np.float64)
        points = low + rng.uniform(0.5, cells - 1.5, size=(3000, 3)) * spacing
        root = trees.body_start[body]
        bound = _bounds(values, layout, body, points, trees.node_centers[root],
                        trees.node_radii[root])  # fmt: skip
        index = np.rint((points - low) / spacing).astype(int)
        nearest = grid[index[:, 0], index[:, 1], index[:, 2]] - np.linalg.norm(
            points - (low + index * spacing), axis=1
        )
        assert np.all(bound >= nearest - 1e-9)
        below_cap = nearest < FIELD_CAP - 2 * spacing  # where the corners' values differ
        assert below_cap.sum() > 300 and np.mean(bound[below_cap] > nearest[below_cap] + 1e-4) > 0.5


def test_fields_are_built_for_the_bodies_asked_only(arms):
    trees = sphere_trees(arms["franka_panda"])
    values, layout = body_fields(trees, [2])
    assert np.flatnonzero(layout[:, 0] >= 0).tolist() == [2]
    assert values.dtype == np.float32 and len(values) == int(layout[2, 1]) ** 3
    assert np.all(values <= FIELD_CAP)


@pytest.mark.parametrize("robot", ROBOTS)
def test_fields_change_no_verdict(arms, robot):
    """States, states with clearance, edges short and long, and the colliding pairs named:
    the same with the fields as without, in a generated workspace and among no obstacles
    (where self-collision decides alone)."""
    arm = arms[robot]
    limits = arm.joint_limits()
    rng = np.random.default_rng(1)
    workspace = generate_arm_workspace(robot, np.random.default_rng(2))
    scenes = [(workspace.bounds, workspace.obstacle_lower, workspace.obstacle_upper),
              (limits, np.zeros((0, 3)), np.zeros((0, 3)))]  # fmt: skip
    for args in scenes:
        fields, walk = (ArmSphereChecker(arm, *args, distance_fields=use) for use in (True, False))
        states = rng.uniform(limits[0], limits[1], size=(20_000, arm.dim))
        free = fields.states_free(states)
        assert 0 < free.sum() < len(free)
        np.testing.assert_array_equal(free, walk.states_free(states))
        np.testing.assert_array_equal(fields.states_free(states, clearance=0.004),
                                      walk.states_free(states, clearance=0.004))  # fmt: skip
        for length in (0.1, 0.6):
            starts = rng.uniform(limits[0], limits[1], size=(1500, arm.dim))
            ends = motions_from(arm, starts, rng, length)
            np.testing.assert_array_equal(fields.edges_free(starts, ends),
                                          walk.edges_free(starts, ends))  # fmt: skip
    blocked = states[~free][:200]  # among no obstacles: self-collisions
    named = [fields.self_collisions(state) for state in blocked]
    assert named == [walk.self_collisions(state) for state in blocked]
    assert all(named)
