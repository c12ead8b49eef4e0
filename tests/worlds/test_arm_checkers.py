"""The built-in arms' checkers among boxes: the fast one is conservative (against the exact one
and pybullet), the exact one certifies motions, and both keep to the joint limits.

Both arms (the KUKA iiwa 14 and the Franka Panda) are checked on generated furniture workspaces
and on hand-made scenes: a thin wall that sampling steps over, a floor under the base, a
ceiling over the arm.
"""

from __future__ import annotations

import fcl
import numpy as np
import pytest

from temp_gym.worlds.arm.model import load_arm
from temp_gym.worlds.arm.spheres import hull_planes
from temp_gym.worlds.arm_world import generate_arm_workspace
from temp_gym.worlds.collision import CollisionChecker, SelfCollisionChecker
from temp_gym.worlds.collision.arm_exact import (
    EXACT_DISTANCE_BELOW,
    MESH_DISTANCE_BELOW,
    MIN_CLEARANCE,
    STEP_SAFETY,
    ArmExactChecker,
)
from temp_gym.worlds.collision.arm_exact_bounds import box_center
from temp_gym.worlds.collision.arm_fast import ArmSphereChecker, sphere_trees
from temp_gym.worlds.collision.arm_fast_kernels import COARSE_INTERVALS, first_intervals
from temp_gym.worlds.collision.arm_self import DISTANCE_TOLERANCE, SELF_COLLISION_GAP, transform
from temp_gym.worlds.collision.pybullet_reference import PybulletArm
from temp_gym.worlds.robots import robot_spec

ROBOTS = ["kuka_iiwa14", "franka_panda"]
CHECKERS = [ArmSphereChecker, ArmExactChecker]
NO_BOXES = (np.zeros((0, 3)), np.zeros((0, 3)))
THIN_WALL = (np.array([[0.6, -0.001, 0.0]]), np.array([[1.2, 0.001, 1.2]]))
"""A 2 mm wall in the plane y = 0, in front of the robot: swinging joint 1 across it collides."""
REACHING = np.array([0.0, 1.0, 0.0, -0.5, 0.0, 1.5, 0.0])
"""A pose of either arm leaning forward over the wall, its hand about 0.75 m out."""
ASIDE = np.array([0.7, 1.0, 0.0, -0.5, 0.0, 1.5, 0.0])
"""`REACHING` turned 0.7 rad about the first joint: clear of the wall, free."""


@pytest.fixture(scope="module")
def arms():
    return {robot: load_arm(robot_spec(robot).description) for robot in ROBOTS}


@pytest.fixture(scope="module")
def workspaces():
    """Per robot, three furniture workspaces."""
    return {
        robot: [generate_arm_workspace(robot, np.random.default_rng(seed)) for seed in range(3)]
        for robot in ROBOTS
    }


def _checkers(arm, workspace):
    args = (arm, workspace.bounds, workspace.obstacle_lower, workspace.obstacle_upper)
    return ArmSphereChecker(*args), ArmExactChecker(*args)


def _uniform(arm, count, seed):
    return np.random.default_rng(seed).uniform(*arm.joint_limits(), size=(count, arm.dim))


# ---- the model the checkers share ---------------------------------------------------------------
@pytest.mark.parametrize("robot", ROBOTS)
def test_joint_limits_are_the_urdfs_unless_the_description_overrides_them(arms, robot):
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    arm = arms[robot]
    limits = arm.joint_limits()
    assert limits.shape == (2, arm.dim) and np.all(limits[0] < limits[1])
    limits[0, 0] = 99.0  # a fresh copy each call
    assert arm.joint_limits()[0, 0] != 99.0
    overrides = dict(arm.description.joint_limits)
    client = BulletClient(connection_mode=pybullet.DIRECT)
    try:
        body = client.loadURDF(str(arm.chain.urdf), useFixedBase=True)
        urdf = {}
        for j in range(client.getNumJoints(body)):
            info = client.getJointInfo(body, j)
            urdf[info[1].decode()] = (info[8], info[9])
    finally:
        client.disconnect()
    for k, name in enumerate(arm.joint_names):
        expected = overrides.get(name, urdf[name])
        np.testing.assert_allclose(arm.joint_limits()[:, k], expected, err_msg=name)


@pytest.mark.parametrize("robot", ROBOTS)
def test_the_shipped_spheres_hold_every_convex_piece(arms, robot):
    """Every point of every body's solid pieces lies in one of the body's derived spheres:
    what makes the fast checker conservative against boxes."""
    arm = arms[robot]
    rng = np.random.default_rng(1)
    bodies = arm.derived_data()["spheres"]["bodies"]
    assert [b["body"] for b in bodies] == list(arm.body_names)
    for j, (geometry, body) in enumerate(zip(arm.geometry, bodies)):
        centers = np.array(body["centers"], dtype=np.float64).reshape(-1, 3)
        radii = np.array(body["radii"], dtype=np.float64)
        assert len(radii) > 0 or not geometry.pieces
        for piece in geometry.pieces:
            corners = hull_planes(piece)[0]
            weights = rng.dirichlet(np.full(len(corners), 0.3), size=600)
            points = np.concatenate([corners, weights @ corners])
            outside = np.full(len(points), np.inf)
            for start in range(0, len(radii), 2000):
                reach = np.linalg.norm(points[:, None] - centers[None, start : start + 2000],
                                       axis=2) - radii[start : start + 2000]  # fmt: skip
                outside = np.minimum(outside, reach.min(axis=1))
            assert outside.max() <= 1e-12, (arm.body_names[j], float(outside.max()))


@pytest.mark.parametrize("robot", ROBOTS)
def test_no_checker_can_change_what_another_sees(arms, robot):
    """The robot's part of a fast checker (sphere trees, kinematics, self-collision model,
    motion bounds) is computed once per process and shared: every array of it is read-only,
    or else a checker's own copy."""
    arm = arms[robot]
    assert sphere_trees(arm) is sphere_trees(arm)
    first, second = (ArmSphereChecker(arm, arm.joint_limits(), *THIN_WALL) for _ in range(2))

    def robot_arrays(checker):
        return {
            **{f"_trees[{k}]": a for k, a in enumerate(checker._trees)},
            **{f"_kinematics[{k}]": a for k, a in enumerate(checker._kinematics)},
            **{f"_self_model[{k}]": a for k, a in enumerate(checker._self_model)},
            "_motion_radii": checker._motion_radii,
        }

    theirs = robot_arrays(second)
    shared_and_writeable = [
        name for name, mine in robot_arrays(first).items()
        if mine.flags.writeable and np.shares_memory(mine, theirs[name])
    ]  # fmt: skip
    assert shared_and_writeable == []
    with pytest.raises(ValueError, match="read-only"):
        first._trees[7][0] += 0.3  # a leaf sphere's radius
    states = _uniform(arm, 300, seed=0)
    expected = second.states_free(states)
    assert 0 < expected.sum() < len(states)
    np.testing.assert_array_equal(first.states_free(states), expected)


# ---- the fast checker is conservative ----------------------------------------------------------
@pytest.mark.parametrize("robot", ROBOTS)
def test_fast_never_frees_what_exact_refuses(arms, workspaces, robot):
    arm = arms[robot]
    false_collisions, exact_free_total = 0, 0
    for k, workspace in enumerate(workspaces[robot]):
        fast, exact = _checkers(arm, workspace)
        for checker in (fast, exact):
            assert isinstance(checker, CollisionChecker)
            assert isinstance(checker, SelfCollisionChecker)
            assert checker.dim == arm.dim and robot in checker.description
        states = _uniform(arm, 2000, seed=10 + k)
        fast_free, exact_free = fast.states_free(states), exact.states_free(states)
        assert not np.any(fast_free & ~exact_free), "fast called a colliding state free"
        false_collisions += int(np.sum(~fast_free & exact_free))
        exact_free_total += int(exact_free.sum())
    rate = false_collisions / exact_free_total
    print(
        f"\n{robot}: fast false-collision rate {rate:.2%} of {exact_free_total} exact-free states"
    )
    assert exact_free_total > 1000
    assert rate < 0.15


@pytest.mark.parametrize("robot", ROBOTS)
def test_pybullet_free_implies_exact_free_and_fast_free_implies_both(arms, workspaces, robot):
    """pybullet collides the meshes' convex hulls, which contain the meshes, and the same
    padded pieces as the exact checker for self-collision; the fast checker's spheres hold the
    pieces."""
    arm = arms[robot]
    workspace = workspaces[robot][0]
    fast, exact = _checkers(arm, workspace)
    states = _uniform(arm, 300, seed=11)
    with PybulletArm(arm, workspace) as bullet:
        bullet_free = bullet.states_free(states)
    exact_free, fast_free = exact.states_free(states), fast.states_free(states)
    assert 0.2 < bullet_free.mean() < 0.9
    assert not np.any(bullet_free & ~exact_free)
    assert not np.any(fast_free & ~bullet_free)
    assert np.mean(bullet_free == exact_free) > 0.85


def _fast_boundary(fast, free, blocked, steps=30):
    """Bisect each segment ``free[i] -> blocked[i]`` to the last state the fast checker calls
    free: states a hair's breadth from what the fast model touches."""
    low, high = free.copy(), blocked.copy()
    for _ in range(steps):
        middle = (low + high) / 2
        ok = fast.states_free(middle)
        low[ok], high[~ok] = middle[ok], middle[~ok]
    return low


@pytest.mark.parametrize("robot", ROBOTS)
def test_fast_is_conservative_on_states_touching_its_own_model(arms, workspaces, robot):
    """On the fast model's boundary (states a few nanoradians of joint motion from its first
    contact), where a piece poking out of its spheres would already touch, exact and pybullet
    agree that the state is free."""
    arm = arms[robot]
    workspace = workspaces[robot][1]
    fast, exact = _checkers(arm, workspace)
    states = _uniform(arm, 800, seed=12)
    ok = fast.states_free(states)
    count = min(int(ok.sum()), int((~ok).sum()), 150)
    boundary = _fast_boundary(fast, states[ok][:count], states[~ok][:count])
    assert fast.states_free(boundary).all()
    assert exact.states_free(boundary).all(), "fast freed a state exact refuses"
    with PybulletArm(arm, workspace) as bullet:
        assert bullet.states_free(boundary).all(), "fast freed a state pybullet refuses"
    # Many are near a box (within 1 cm by the exact checker); the others are at the boundary
    # of a self-collision pair's spheres.
    near_box = np.array([bool(exact.obstacle_report(state)) for state in boundary])
    assert near_box.sum() > count / 4, (int(near_box.sum()), count)


# ---- motions -------------------------------------------------------------------------------------
@pytest.mark.parametrize("robot", ROBOTS)
def test_exact_edge_catches_a_thin_wall_that_sampling_misses(arms, robot):
    arm = arms[robot]
    limits = arm.joint_limits()
    exact = ArmExactChecker(arm, limits, *THIN_WALL)
    fast = ArmSphereChecker(arm, limits, *THIN_WALL)
    start, end = REACHING.copy(), REACHING.copy()
    start[0], end[0] = -0.8, 0.8
    assert exact.states_free(np.stack([start, end])).all()
    # Sampling the motion at a few states steps right over the 2 mm wall...
    assert exact.states_free(np.linspace(start, end, 4)).all()
    # ...the certified checks do not.
    assert not exact.edge_free(start, end)
    assert not fast.edge_free(start, end)
    assert not exact.path_free(np.stack([start, end]))
    # A motion on one side of the wall is certified by both.
    start[0], end[0] = 0.5, 0.9
    assert exact.edge_free(start, end)
    assert fast.path_free(np.stack([start, end, start]))


@pytest.mark.parametrize("robot", ROBOTS)
def test_fast_free_edges_are_certified(arms, workspaces, robot):
    arm = arms[robot]
    limits = arm.joint_limits()
    fast, exact = _checkers(arm, workspaces[robot][1])
    rng = np.random.default_rng(12)
    starts = _uniform(arm, 400, seed=13)
    ends = np.clip(starts + rng.normal(0, 0.15, size=starts.shape), *limits)
    chosen = np.flatnonzero(fast.edges_free(starts, ends))[:15]
    assert len(chosen) >= 10
    assert exact.edges_free(starts[chosen], ends[chosen]).all()


@pytest.mark.parametrize("robot", ROBOTS)
@pytest.mark.parametrize("cls", CHECKERS)
def test_invalid_states_are_not_free(arms, robot, cls):
    arm = arms[robot]
    limits = arm.joint_limits()
    checker = cls(arm, limits, *THIN_WALL)
    beyond = ASIDE.copy()
    beyond[1] = limits[1, 1] + 0.1
    states = np.stack([ASIDE, np.full(7, np.nan), beyond, np.full(7, np.inf)])
    assert checker.states_free(states).tolist() == [True, False, False, False]
    assert not checker.edge_free(ASIDE, np.full(7, np.nan))
    assert not checker.edge_free(ASIDE, beyond)
    assert checker.path_free(ASIDE[None])
    assert checker.states_free(ASIDE).shape == (1,)


@pytest.mark.parametrize("robot", ROBOTS)
@pytest.mark.parametrize("cls", CHECKERS)
def test_joint_limits_hold_whatever_the_bounds(arms, robot, cls):
    arm = arms[robot]
    limits = arm.joint_limits()
    checker = cls(arm, limits + np.array([[-0.5], [0.5]]), *NO_BOXES)
    beyond = ASIDE.copy()
    beyond[6] = limits[1, 6] + 0.2  # inside the bounds, outside the URDF's limit
    assert checker.states_free(np.stack([ASIDE, beyond])).tolist() == [True, False]
    assert not checker.path_free(np.stack([ASIDE, beyond, ASIDE]))
    assert not checker.edge_free(ASIDE, beyond)


@pytest.mark.parametrize("cls", CHECKERS)
def test_bad_inputs_raise(arms, cls):
    arm = arms["kuka_iiwa14"]
    limits = arm.joint_limits()
    checker = cls(arm, limits, *THIN_WALL)
    with pytest.raises(ValueError, match="states: expected shape"):
        checker.states_free(np.zeros((3, 6)))
    with pytest.raises(ValueError, match="start: expected shape"):
        checker.edge_free(np.zeros(6), np.zeros(7))
    with pytest.raises(ValueError, match="starts, ends"):
        checker.edges_free(np.zeros((3, 7)), np.zeros((2, 7)))
    with pytest.raises(ValueError, match="^path: expected at least one state$"):
        checker.path_free(np.zeros((0, 7)))
    with pytest.raises(ValueError, match="^states: expected real numbers"):
        checker.states_free("abc")
    with pytest.raises(ValueError, match="^states: expected real numbers"):
        checker.states_free(np.zeros((1, 7), dtype=complex))
    # One state on either side is shared by every edge, in both checkers.
    assert checker.edges_free(np.zeros((1, 7)), np.zeros((3, 7))).shape == (3,)
    with pytest.raises(ValueError, match="bounds"):
        cls(arm, np.zeros((2, 6)), *THIN_WALL)
    with pytest.raises(ValueError, match="box_lower"):
        cls(arm, limits, THIN_WALL[1], THIN_WALL[0])
    with pytest.raises(ValueError, match="box_lower"):
        cls(arm, limits, np.zeros((2, 2)), np.ones((2, 2)))


@pytest.mark.parametrize("resolution", [0.0, -0.01, float("nan"), "0.02"])
def test_fast_resolution_validated(arms, resolution):
    arm = arms["kuka_iiwa14"]
    with pytest.raises(ValueError, match="resolution"):
        ArmSphereChecker(arm, arm.joint_limits(), *THIN_WALL, resolution=resolution)


@pytest.mark.parametrize("robot", ROBOTS)
def test_the_base_against_a_floor_is_exact(arms, robot):
    """The base never moves: both checkers test it once, exactly, so a floor a tenth of a
    millimetre below it leaves every state free and one reaching 1 cm into it none."""
    arm = arms[robot]
    limits = arm.joint_limits()
    bottom = min(float(piece[:, 2].min()) for piece in arm.geometry[0].pieces)
    floor = (np.array([[-1.5, -1.5, bottom - 0.1]]), np.array([[1.5, 1.5, bottom - 1e-4]]))
    touching = (floor[0], np.array([[1.5, 1.5, bottom + 0.01]]))
    for cls in CHECKERS:
        assert cls(arm, limits, *floor).base_free
        assert cls(arm, limits, *floor).states_free(REACHING)[0]
        checker = cls(arm, limits, *touching)
        assert not checker.base_free and not checker.states_free(REACHING)[0]
        assert "base link in collision" in checker.description


# ---- clearance ---------------------------------------------------------------------------------
def _ceiling_height_where_the_arm_collides(arm, state, clearance):
    """Bisect the bottom height of a ceiling slab at which the arm in ``state`` touches it."""
    low, high = 0.0, 3.0  # touching the base at 0 m, clear at 3 m
    for _ in range(50):
        middle = (low + high) / 2
        ceiling = (np.array([[-2.0, -2.0, middle]]), np.array([[2.0, 2.0, middle + 0.1]]))
        checker = ArmSphereChecker(arm, arm.joint_limits(), *ceiling)
        free = checker.states_free(state[None], clearance)[0]
        low, high = (low, middle) if free else (middle, high)
    return high


@pytest.mark.parametrize("robot", ROBOTS)
def test_clearance_grows_every_sphere_by_that_much(arms, robot):
    arm = arms[robot]
    checker = ArmSphereChecker(arm, arm.joint_limits(), *THIN_WALL)
    resolution = checker.resolution
    alone = ArmSphereChecker(arm, arm.joint_limits(), *NO_BOXES)
    assert alone.states_free(REACHING[None], resolution / 2)[0]  # no self-collision binds
    bare = _ceiling_height_where_the_arm_collides(arm, REACHING, 0.0)
    grown = _ceiling_height_where_the_arm_collides(arm, REACHING, resolution / 2)
    assert grown - bare == pytest.approx(resolution / 2, abs=1e-6)
    # Monotone: a state free with clearance is free without it, and clearance frees fewer.
    states = _uniform(arm, 2000, seed=3)
    loose, strict = checker.states_free(states), checker.states_free(states, resolution / 2)
    assert not (strict & ~loose).any() and strict.sum() < loose.sum()


@pytest.mark.parametrize("robot", ROBOTS)
def test_a_state_with_half_resolution_clearance_can_be_left_every_way(arms, workspaces, robot):
    """An edge check grows its middle state's spheres by half the largest body motion W of a
    one-interval edge, so every edge with W <= resolution / 3 out of a state with
    resolution / 2 of clearance is free: its middle has moved by at most W / 2."""
    arm = arms[robot]
    fast, _ = _checkers(arm, workspaces[robot][0])
    resolution = fast.resolution
    rng = np.random.default_rng(4)
    limits = arm.joint_limits()
    states = rng.uniform(limits[0] + 0.1, limits[1] - 0.1, size=(3000, arm.dim))
    directions = rng.normal(size=states.shape)
    largest_motion = (np.abs(directions) @ arm.motion_radii()).max(axis=1)
    steps = directions * (resolution / 3 / largest_motion)[:, None]
    clear = fast.states_free(states, resolution / 2)
    assert clear.sum() > 100
    assert fast.edges_free(states[clear], states[clear] + steps[clear]).all()


@pytest.mark.parametrize("clearance", [-0.001, 0.011, float("nan"), "0.01"])
def test_bad_clearance_raises(arms, clearance):
    arm = arms["kuka_iiwa14"]
    with pytest.raises(ValueError, match="clearance"):
        ArmSphereChecker(arm, arm.joint_limits(), *THIN_WALL).states_free(REACHING[None],
                                                                          clearance)  # fmt: skip


# ---- how the exact checker measures ------------------------------------------------------------
def _tier_distances(exact, poses, j):
    """Body ``j``'s distance to every box from its bounding box, its pieces (less fcl's
    tolerance) and its elements, fcl on each, no pruning: ``(3, M)``."""
    request = fcl.DistanceRequest()
    box_pose = poses[j].copy()
    box_pose[:3, 3] = box_center(poses, j, exact._local_center)  # as the checker places it
    exact._body_boxes[j].setTransform(transform(box_pose))
    for obj in exact._pieces[j]:
        obj.setTransform(transform(poses[j]))
    exact._pose_body(poses, j)
    tiers = ([exact._body_boxes[j]], exact._pieces[j], [obj for obj, _ in exact._elements[j]])
    tolerances = (0.0, DISTANCE_TOLERANCE, 0.0)
    return np.array([
        [max(min(fcl.distance(obj, box, request, fcl.DistanceResult()) for obj in objects)
             - tolerance, 0.0) for box in exact._obstacles]
        for objects, tolerance in zip(tiers, tolerances)
    ])  # fmt: skip


@pytest.mark.parametrize("robot", ROBOTS)
def test_body_clearances_are_the_tiered_minimum_over_every_box_and_bound_the_meshes(
    arms, workspaces, robot
):
    """`_body_clearance` visits few boxes and tiers but returns the tiered minimum over all of
    them, which is a lower bound on the elements' distance; the world-AABB gaps it prunes
    with are lower bounds too."""
    arm = arms[robot]
    rng = np.random.default_rng(3)
    bodies = [j for j in range(1, arm.num_bodies) if arm.geometry[j].pieces]
    tiers = np.zeros(3, dtype=int)
    for workspace in workspaces[robot][:2]:
        _, exact = _checkers(arm, workspace)
        for state in rng.uniform(*arm.joint_limits(), size=(25, arm.dim)):
            poses = arm.forward_kinematics(state)[0]
            gaps = exact._aabb_gaps(poses)
            for j in bodies:
                pruned = exact._body_clearance(poses, j, gaps[j])
                box, hull, mesh = _tier_distances(exact, poses, j)
                tiered = np.where(box >= EXACT_DISTANCE_BELOW, box,
                                  np.where(hull >= MESH_DISTANCE_BELOW, hull, mesh))  # fmt: skip
                assert pruned == tiered.min()  # pruning leaves out no box that matters
                # A lower bound on the elements' distance (up to fcl's rounding: a body's box
                # is its pieces' bounding box, which an element touches).
                assert pruned <= mesh.min() + 1e-12
                assert np.all(gaps[j] <= box + 1e-12)  # the pruning bound is a lower bound
                which = np.argmin(tiered)
                tiers[0 if box[which] >= EXACT_DISTANCE_BELOW else
                      1 if hull[which] >= MESH_DISTANCE_BELOW else 2] += 1  # fmt: skip
    assert np.all(tiers > 10), tiers  # every tier decided some clearances


@pytest.mark.parametrize("robot", ROBOTS)
def test_lazy_cover_equals_measuring_every_body_and_pair(arms, workspaces, robot):
    """`_cover` measures few bodies and pairs but certifies a motion as far as measuring all
    of them does, from a motion's start and from a pose ahead of what is certified, and finds
    the same contacts and the same spans that fall short."""
    arm = arms[robot]
    rng = np.random.default_rng(8)
    checked = blocked = short = 0
    for workspace in workspaces[robot][:2]:
        _, exact = _checkers(arm, workspace)
        for _ in range(40):
            start = rng.uniform(*arm.joint_limits())
            delta = rng.normal(0, 0.3, size=arm.dim) * (rng.random(arm.dim) < 0.7)
            sweep, pair_sweep = exact._motion_rates(start, start + delta)
            moving = np.flatnonzero((sweep > 0) & exact._has_geometry)
            moving_pairs = np.flatnonzero(pair_sweep > 0)
            if len(moving) + len(moving_pairs) == 0:
                continue
            rates = np.concatenate([sweep[moving], pair_sweep[moving_pairs]])
            poses = arm.forward_kinematics(start)[0]
            gaps = exact._aabb_gaps(poses)
            all_spheres = exact._hulls.sphere_gaps(poses)
            spheres = all_spheres - SELF_COLLISION_GAP
            measured = np.concatenate([
                [exact._body_clearance(poses, j, gaps[j]) for j in moving],
                [exact._hulls.pair_clearance(poses, p, spheres[p], EXACT_DISTANCE_BELOW)
                 for p in moving_pairs],
            ])  # fmt: skip
            cheap = np.concatenate([gaps[moving].min(axis=1), spheres[moving_pairs]])
            every = np.maximum(cheap - DISTANCE_TOLERANCE, measured)
            # A motion's start, then a pose ahead of where some items are certified (rates
            # scaled up so that some spans fall short of them).
            scenes = [(0.0, np.zeros(len(rates)), rates)]
            scenes.append((0.5, rng.uniform(0.2, 0.7, len(rates)), rates * 10))
            for t, frontier, scaled in scenes:
                span = STEP_SAFETY * every / scaled
                got, closest, _, joined = exact._cover(poses, t, frontier, scaled, None, moving,
                                                       moving_pairs, gaps, all_spheres)  # fmt: skip
                if t == 0.0:
                    assert (closest <= MIN_CLEARANCE) == (measured.min() <= MIN_CLEARANCE)
                if measured.min() <= MIN_CLEARANCE:
                    blocked += t == 0.0
                    continue
                meets = t - span <= frontier
                assert joined == meets.all()
                if joined:
                    whole = np.where(meets, np.maximum(frontier, t + span), frontier)
                    assert got.min() == whole.min()
                    checked += 1
                else:
                    short += 1
    assert checked > 20 and blocked > 10 and short > 5, (checked, blocked, short)


@pytest.mark.parametrize("robot", ROBOTS)
def test_a_motions_rates_bound_how_fast_its_bodies_move(arms, robot):
    """Along a motion, no point of a body's pieces moves faster than the exact checker's rate
    for it, nor a point of a pair's second body relative to the first faster than the pair's
    rate; and the rates, from the motion's lever arms, are often below the arm's bound."""
    arm = arms[robot]
    exact = ArmExactChecker(arm, arm.joint_limits(), *NO_BOXES)
    pairs = exact._hulls.pairs
    points = [np.concatenate(g.pieces) if g.pieces else np.zeros((0, 3)) for g in arm.geometry]
    rng = np.random.default_rng(21)
    starts = _uniform(arm, 25, seed=22)
    ends = np.clip(starts + rng.normal(0, 0.4, size=starts.shape), *arm.joint_limits())
    t = np.linspace(0.0, 1.0, 201)
    slower = 0
    for start, end in zip(starts, ends):
        sweep, pair_sweep = exact._motion_rates(start, end)
        bound = np.abs(end - start) @ arm.motion_radii()
        assert (sweep <= bound + 1e-12).all()
        slower += int((sweep < 0.9 * bound).sum())
        poses = arm.forward_kinematics(start + t[:, None] * (end - start))
        world = [p @ poses[:, j, :3, :3].transpose(0, 2, 1) + poses[:, j, None, :3, 3]
                 for j, p in enumerate(points)]  # fmt: skip
        for j, body in enumerate(world):
            if len(points[j]):
                step = np.linalg.norm(np.diff(body, axis=0), axis=2).max()
                assert step <= sweep[j] * (t[1] - t[0]) + 1e-9, (start, end, j)
        for p, (a, b) in enumerate(pairs):
            # Body b's points in body a's frame.
            relative = np.einsum("tji,tkj->tki", poses[:, a, :3, :3],
                                 world[b] - poses[:, a, None, :3, 3])  # fmt: skip
            step = np.linalg.norm(np.diff(relative, axis=0), axis=2).max()
            assert step <= pair_sweep[p] * (t[1] - t[0]) + 1e-9, (start, end, a, b)
    assert slower > 0


@pytest.mark.parametrize("steps", [1, 2, 3, 4, 5, 6, 7, 10, 31, 100])
def test_an_edges_first_intervals_tile_it_end_first_then_start(steps):
    low, high = np.full(steps + 2, np.nan), np.full(steps + 2, np.nan)
    count = first_intervals(steps, low, high)
    order = list(zip(low[:count][::-1], high[:count][::-1]))  # as they come off the stack
    assert order[0] == ((steps - 1) / steps, 1.0)
    if steps > 1:
        assert order[1] == (0.0, 1.0 / steps)
    middle = order[2:]
    assert middle == sorted(middle)  # left to right
    spans = sorted(order)
    assert spans[0][0] == 0.0 and spans[-1][1] == 1.0
    assert all(a[1] == b[0] for a, b in zip(spans, spans[1:]))  # no gap, no overlap
    assert all(0 < b - a <= COARSE_INTERVALS / steps * (1 + 1e-12) for a, b in spans)
    assert len(middle) == -(-max(steps - 2, 0) // COARSE_INTERVALS)


@pytest.mark.parametrize("robot", ROBOTS)
def test_a_reported_penetration_is_no_deeper_than_the_link_and_obstacle_allow(arms, robot):
    # fcl's contact depth of a link mesh in a box reached 0.8-1.4 m for a 10 cm floor slab
    # and a hand 0.1-0.25 m across, and `Problem.load` printed it. No translation longer than
    # the link's size plus the slab's thickness is needed to separate them.
    from temp_gym.problem import Workspace

    arm = arms[robot]
    workspace = generate_arm_workspace(robot, np.random.default_rng(0))
    floor = Workspace(robot, workspace.bounds, workspace.obstacle_centers[:1],
                      workspace.obstacle_half_extents[:1])  # fmt: skip
    exact = ArmExactChecker(arm, floor.bounds, floor.obstacle_lower, floor.obstacle_upper)
    thickness = 2 * floor.obstacle_half_extents[0, 2]
    deep = 0
    for state in _uniform(arm, 300, seed=1):
        report = exact.obstacle_report(state)
        if report and report[0][2] < 0:
            link, _, distance = report[0]
            points = np.concatenate(arm.geometry[arm.body_names.index(link)].pieces)
            size = np.linalg.norm(points.max(axis=0) - points.min(axis=0))
            assert -distance <= size + thickness + 0.01, (link, distance, size)
            deep += 1
    assert deep > 10
