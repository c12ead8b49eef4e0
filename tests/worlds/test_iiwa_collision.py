"""Fast (sphere) versus exact (fcl) iiwa collision checking, and pybullet as a third opinion."""

from __future__ import annotations

import numpy as np
import pytest

from temp_gym.worlds import iiwa_world
from temp_gym.worlds.collision import CollisionChecker
from temp_gym.worlds.collision.iiwa_exact import IiwaExactChecker
from temp_gym.worlds.collision.iiwa_fast import IiwaSphereChecker
from temp_gym.worlds.collision.pybullet_reference import PybulletIiwa
from temp_gym.worlds.iiwa14.kinematics import joint_limits


def generate_iiwa_workspace(rng):
    return iiwa_world.generate_iiwa_workspace("kuka_iiwa14", rng)


LIMITS = joint_limits()
# A 2 mm wall in the plane y = 0, in front of the robot: swinging joint 1 across it collides.
THIN_WALL = (np.array([[0.6, -0.001, 0.0]]), np.array([[1.2, 0.001, 1.2]]))
REACHING = np.array([0.0, 1.0, 0.0, -0.5, 0.0, 0.5, 0.0])


def _checkers(workspace):
    args = (workspace.bounds, workspace.obstacle_lower, workspace.obstacle_upper)
    return IiwaSphereChecker(*args), IiwaExactChecker(*args)


@pytest.fixture(scope="module")
def workspaces():
    return [generate_iiwa_workspace(np.random.default_rng(seed)) for seed in range(5)]


def test_checkers_follow_protocol():
    fast = IiwaSphereChecker(LIMITS, *THIN_WALL)
    exact = IiwaExactChecker(LIMITS, *THIN_WALL)
    for checker in (fast, exact):
        assert isinstance(checker, CollisionChecker)
        assert checker.dim == 7 and checker.description


def test_fast_never_frees_what_exact_rejects(workspaces):
    rng = np.random.default_rng(10)
    false_collisions, exact_free_total, total = 0, 0, 0
    for workspace in workspaces:
        fast, exact = _checkers(workspace)
        states = rng.uniform(LIMITS[0], LIMITS[1], size=(4000, 7))
        fast_free, exact_free = fast.states_free(states), exact.states_free(states)
        assert not np.any(fast_free & ~exact_free), "fast called a colliding state free"
        false_collisions += int(np.sum(~fast_free & exact_free))
        exact_free_total += int(exact_free.sum())
        total += len(states)
    rate = false_collisions / exact_free_total
    print(f"\nfast false-collision rate: {rate:.2%} of {exact_free_total} exact-free states")
    assert total >= 20_000
    assert rate < 0.15


def test_pybullet_free_implies_exact_free(workspaces):
    workspace = workspaces[0]
    exact = _checkers(workspace)[1]
    states = np.random.default_rng(11).uniform(LIMITS[0], LIMITS[1], size=(300, 7))
    with PybulletIiwa(workspace) as bullet:
        bullet_free = bullet.states_free(states)
    exact_free = exact.states_free(states)
    # pybullet uses the meshes' convex hulls, which contain the meshes (boxes), and the same
    # padded hulls as the exact checker for self-collision.
    assert not np.any(bullet_free & ~exact_free)
    assert np.mean(bullet_free == exact_free) > 0.85


def test_exact_edge_catches_thin_wall_that_sampling_misses():
    exact = IiwaExactChecker(LIMITS, *THIN_WALL)
    fast = IiwaSphereChecker(LIMITS, *THIN_WALL)
    start, end = REACHING.copy(), REACHING.copy()
    start[0], end[0] = -0.8, 0.8
    assert exact.states_free(np.stack([start, end])).all()
    # Sampling the motion at a few states steps right over the 2 mm wall...
    samples = np.linspace(start, end, 4)
    assert exact.states_free(samples).all()
    # ...the certified checks do not.
    assert not exact.edge_free(start, end)
    assert not fast.edge_free(start, end)
    assert not exact.path_free(np.stack([start, end]))


def test_free_edges_are_certified(workspaces):
    fast, exact = _checkers(workspaces[1])
    rng = np.random.default_rng(12)
    starts = rng.uniform(LIMITS[0], LIMITS[1], size=(400, 7))
    ends = np.clip(starts + rng.normal(0, 0.15, size=starts.shape), LIMITS[0], LIMITS[1])
    fast_free = fast.edges_free(starts, ends)
    chosen = np.flatnonzero(fast_free)[:15]
    assert len(chosen) >= 10
    assert exact.edges_free(starts[chosen], ends[chosen]).all()
    start, end = REACHING.copy(), REACHING.copy()
    start[0], end[0] = 0.5, 0.9  # on one side of the wall
    assert IiwaExactChecker(LIMITS, *THIN_WALL).edge_free(start, end)
    assert IiwaSphereChecker(LIMITS, *THIN_WALL).path_free(np.stack([start, end, start]))


@pytest.mark.parametrize("cls", [IiwaSphereChecker, IiwaExactChecker])
def test_invalid_states_are_not_free(cls):
    checker = cls(LIMITS, *THIN_WALL)
    states = np.stack([np.zeros(7), np.full(7, np.nan), LIMITS[1] + 0.1, np.full(7, np.inf)])
    assert checker.states_free(states).tolist() == [True, False, False, False]
    assert not checker.edge_free(np.zeros(7), np.full(7, np.nan))
    assert not checker.edge_free(np.zeros(7), LIMITS[1] + 0.1)
    assert checker.path_free(np.zeros((1, 7)))
    assert checker.states_free(np.zeros(7)).shape == (1,)


@pytest.mark.parametrize("cls", [IiwaSphereChecker, IiwaExactChecker])
def test_bad_inputs_raise(cls):
    checker = cls(LIMITS, *THIN_WALL)
    with pytest.raises(ValueError, match="states"):
        checker.states_free(np.zeros((3, 6)))
    with pytest.raises(ValueError, match="start"):
        checker.edge_free(np.zeros(6), np.zeros(7))
    with pytest.raises(ValueError, match="starts, ends"):
        checker.edges_free(np.zeros((3, 7)), np.zeros((2, 7)))
    with pytest.raises(ValueError, match="path"):
        checker.path_free(np.zeros((0, 7)))
    with pytest.raises(ValueError, match="bounds"):
        cls(np.zeros((2, 6)), *THIN_WALL)
    with pytest.raises(ValueError, match="box_lower"):
        cls(LIMITS, THIN_WALL[1], THIN_WALL[0])
    with pytest.raises(ValueError, match="box_lower"):
        cls(LIMITS, np.zeros((2, 2)), np.ones((2, 2)))


def test_fast_resolution_validated():
    with pytest.raises(ValueError, match="resolution"):
        IiwaSphereChecker(LIMITS, *THIN_WALL, resolution=0.0)


def test_base_link_against_floor_is_exact():
    floor = (np.array([[-1.5, -1.5, -0.1]]), np.array([[1.5, 1.5, -1e-4]]))
    assert IiwaSphereChecker(LIMITS, *floor).base_free
    assert IiwaExactChecker(LIMITS, *floor).base_free
    touching = (np.array([[-1.5, -1.5, -0.1]]), np.array([[1.5, 1.5, 0.01]]))
    fast = IiwaSphereChecker(LIMITS, *touching)
    assert not fast.base_free and not fast.states_free(np.zeros(7))[0]
    assert not IiwaExactChecker(LIMITS, *touching).states_free(np.zeros(7))[0]


def test_base_link_suspects_are_the_boxes_a_base_sphere_touches(monkeypatch):
    """`_base_free`'s array test picks exactly the boxes `sphere_hits_box` picks, in order."""
    from temp_gym.worlds.collision import iiwa_exact, iiwa_fast
    from temp_gym.worlds.collision.iiwa_fast_kernels import sphere_hits_box

    centers, radii = iiwa_fast._robot_geometry()[2][0]  # link_0's spheres
    rng = np.random.default_rng(8)
    lower = rng.uniform(-0.6, 0.5, size=(400, 3))
    boxes = np.hstack([lower + rng.uniform(0.01, 0.3, size=(400, 3)) / 2,
                       rng.uniform(0.005, 0.15, size=(400, 3))])  # fmt: skip
    expected = [
        b for b in range(len(boxes))
        if any(sphere_hits_box(*c, r, boxes, b) for c, r in zip(centers, radii))
    ]  # fmt: skip
    assert 0 < len(expected) < len(boxes)
    seen = []
    monkeypatch.setattr(iiwa_exact, "base_link_collides", lambda s: seen.append(s) or False)
    assert iiwa_fast._base_free(boxes, centers, radii)
    np.testing.assert_array_equal(seen[0], boxes[expected])
    assert iiwa_fast._base_free(boxes[[b for b in range(400) if b not in expected]], centers,
                                radii) and len(seen) == 1  # fmt: skip


def test_without_boxes_only_self_collision_blocks():
    empty = (np.zeros((0, 3)), np.zeros((0, 3)))
    # In the middle half of every joint's range the arm cannot fold into itself.
    states = np.random.default_rng(13).uniform(LIMITS[0] / 2, LIMITS[1] / 2, size=(50, 7))
    wrist_folded = np.zeros(7)
    wrist_folded[5] = 2.08  # link_7 against link_5
    for checker in (IiwaSphereChecker(LIMITS, *empty), IiwaExactChecker(LIMITS, *empty)):
        assert checker.states_free(states).all()
        assert checker.edge_free(states[0], states[1])
        assert not checker.states_free(wrist_folded)[0]


def _ceiling_height_where_upright_arm_collides(clearance):
    """Bisect the bottom height of a ceiling slab at which the upright arm starts to touch it."""
    low, high = 0.5, 3.0  # touching at 0.5 m, clear at 3 m
    for _ in range(50):
        middle = (low + high) / 2
        ceiling = (np.array([[-2.0, -2.0, middle]]), np.array([[2.0, 2.0, middle + 0.1]]))
        free = IiwaSphereChecker(LIMITS, *ceiling).states_free(np.zeros((1, 7)), clearance)[0]
        low, high = (low, middle) if free else (middle, high)
    return high


def test_clearance_grows_every_sphere_by_that_much():
    resolution = IiwaSphereChecker(LIMITS, *THIN_WALL).resolution
    bare = _ceiling_height_where_upright_arm_collides(0.0)
    grown = _ceiling_height_where_upright_arm_collides(resolution / 2)
    assert grown - bare == pytest.approx(resolution / 2, abs=1e-6)
    # Monotone: a state free with clearance is free without it, and clearance frees fewer.
    checker = IiwaSphereChecker(LIMITS, *THIN_WALL)
    states = np.random.default_rng(3).uniform(LIMITS[0], LIMITS[1], size=(2000, 7))
    loose, strict = checker.states_free(states), checker.states_free(states, resolution / 2)
    assert not (strict & ~loose).any() and strict.sum() < loose.sum()


def test_a_state_with_half_resolution_clearance_can_be_left():
    # An edge check grows its end states' spheres by up to resolution / 2 (half the largest link
    # motion W of a one-step edge), so a free state nearer a box than that can be a trap. With
    # that clearance, every edge with W <= resolution / 3 out of it is free: its start passes
    # and its end has moved by at most W. Without it, such edges fail.
    workspace = generate_iiwa_workspace(np.random.default_rng(0))
    checker, _ = _checkers(workspace)
    resolution = checker.resolution
    rng = np.random.default_rng(4)
    states = rng.uniform(LIMITS[0] + 0.1, LIMITS[1] - 0.1, size=(6000, 7))
    directions = rng.normal(size=states.shape)
    largest_motion = (np.abs(directions) @ checker._motion_radii).max(axis=1)
    steps = directions * (resolution / 3 / largest_motion)[:, None]
    free = checker.states_free(states)
    clear = checker.states_free(states, resolution / 2)
    assert clear.sum() > 100 and (free & ~clear).sum() > 10
    assert checker.edges_free(states[clear], states[clear] + steps[clear]).all()
    near = free & ~clear
    assert not checker.edges_free(states[near], states[near] + steps[near]).all()


@pytest.mark.parametrize("clearance", [-0.001, 0.011, float("nan"), "0.01"])
def test_bad_clearance_raises(clearance):
    with pytest.raises(ValueError, match="clearance"):
        IiwaSphereChecker(LIMITS, *THIN_WALL).states_free(np.zeros((1, 7)), clearance)


def test_checkers_share_the_robot_geometry_but_not_its_arrays():
    # The robot's part of a checker is computed once per process; each checker works on its
    # own copies, so no checker can change what a later one sees.
    boxes = ([[0.4, -0.5, 0.0]], [[0.6, 0.5, 1.2]])
    first, second = (
        IiwaSphereChecker(joint_limits(), *boxes),
        IiwaSphereChecker(joint_limits(), *boxes),
    )
    for mine, theirs in zip(first._spheres, second._spheres):
        np.testing.assert_array_equal(mine, theirs)
        assert not np.shares_memory(mine, theirs)
    states = np.random.default_rng(0).uniform(*joint_limits(), size=(500, 7))
    expected = second.states_free(states)
    assert 0 < expected.sum() < len(states)
    first._spheres[1][:] += 0.3  # every sphere of this checker grows by 30 cm
    first._spheres[4][:] += 0.3
    assert first.states_free(states).sum() < expected.sum()
    np.testing.assert_array_equal(
        IiwaSphereChecker(joint_limits(), *boxes).states_free(states), expected
    )


def _box_distances(checker, poses, j):
    """fcl distances of link j's oriented box, hull and mesh to every box, no pruning."""
    import fcl

    from temp_gym.worlds.collision.iiwa_exact import _transform

    request = fcl.DistanceRequest()
    hull_pose = poses[j].copy()
    hull_pose[:3, 3] += hull_pose[:3, :3] @ checker._local_center[j]
    checker._link_boxes[j].setTransform(_transform(hull_pose))
    checker._link_hulls[j].setTransform(_transform(poses[j]))
    checker._links[j].setTransform(_transform(poses[j]))
    return np.array(
        [
            [max(fcl.distance(shape, box, request, fcl.DistanceResult()), 0.0) for box in
             checker._boxes]
            for shape in (checker._link_boxes[j], checker._link_hulls[j], checker._links[j])
        ]
    )  # fmt: skip


def test_box_clearances_are_the_tiered_minimum_over_every_box_and_bound_the_meshes(workspaces):
    from temp_gym.worlds.collision.iiwa_exact import (
        DISTANCE_TOLERANCE,
        EXACT_DISTANCE_BELOW,
        MESH_DISTANCE_BELOW,
    )
    from temp_gym.worlds.iiwa14.kinematics import forward_kinematics

    rng = np.random.default_rng(3)
    links = np.arange(1, 8)
    tiers = np.zeros(3, dtype=int)
    for workspace in workspaces:
        _, exact = _checkers(workspace)
        for state in rng.uniform(LIMITS[0], LIMITS[1], size=(40, 7)):
            poses = forward_kinematics(state)[0]
            pruned = exact._clearances(poses, links)
            gaps = exact._aabb_gaps(poses)
            for j in links:
                box, hull, mesh = _box_distances(exact, poses, j)
                hull = np.maximum(hull - DISTANCE_TOLERANCE, 0.0)
                tiered = np.where(
                    box >= EXACT_DISTANCE_BELOW,
                    box,
                    np.where(hull >= MESH_DISTANCE_BELOW, hull, mesh),
                )
                assert pruned[j] == tiered.min()  # pruning leaves out no box that matters
                assert pruned[j] <= mesh.min()  # a lower bound on the mesh's distance
                assert np.all(gaps[j] <= box + 1e-12)  # the pruning bound is a lower bound
                which = np.argmin(tiered)
                tiers[0 if box[which] >= EXACT_DISTANCE_BELOW else
                      1 if hull[which] >= MESH_DISTANCE_BELOW else 2] += 1  # fmt: skip
    assert np.all(tiers > 20), tiers  # every tier decided some clearances


def test_lazy_step_equals_measuring_every_link_and_pair(workspaces):
    """`_advance` measures few links and pairs but returns what measuring all of them gives."""
    from temp_gym.worlds.collision.iiwa_exact import EXACT_DISTANCE_BELOW, MIN_CLEARANCE
    from temp_gym.worlds.iiwa14.kinematics import forward_kinematics

    rng = np.random.default_rng(8)
    checked = blocked = 0
    for workspace in workspaces:
        _, exact = _checkers(workspace)
        for _ in range(60):
            start = rng.uniform(LIMITS[0], LIMITS[1])
            delta = rng.normal(0, 0.3, size=7) * (rng.random(7) < 0.7)  # some joints still
            sweep = np.abs(delta) @ exact._motion_radii
            moving = np.flatnonzero(sweep > 0)
            pair_sweep = exact._pair_motion @ np.abs(delta)
            moving_pairs = np.flatnonzero(pair_sweep > 0)
            if len(moving) + len(moving_pairs) == 0:
                continue
            poses = forward_kinematics(start)[0]
            advance, closest = exact._advance(poses, moving, sweep, moving_pairs, pair_sweep)
            links = exact._clearances(poses, moving)[moving]
            pairs = exact._hulls.clearances(poses, EXACT_DISTANCE_BELOW)[moving_pairs]
            every = min(links.min(initial=np.inf), pairs.min(initial=np.inf))
            assert (closest <= MIN_CLEARANCE) == (every <= MIN_CLEARANCE)
            if every <= MIN_CLEARANCE:
                blocked += 1
                continue
            assert advance == min(
                np.min(links / sweep[moving], initial=np.inf),
                np.min(pairs / pair_sweep[moving_pairs], initial=np.inf),
            )
            checked += 1
    assert checked > 150 and blocked > 20, (checked, blocked)
