"""Self-collision of the iiwa: fast (spheres, tables) against exact (hulls) against pybullet."""

from __future__ import annotations

import numpy as np
import pytest

from temp_gym.worlds.collision import SelfCollisionChecker
from temp_gym.worlds.collision.iiwa_exact import IiwaExactChecker
from temp_gym.worlds.collision.iiwa_fast import IiwaSphereChecker
from temp_gym.worlds.collision.iiwa_self import SELF_COLLISION_GAP, LinkHulls
from temp_gym.worlds.collision.pybullet_reference import PybulletIiwa, densify
from temp_gym.worlds.iiwa14.convex_hulls import SELF_COLLISION_PADDING
from temp_gym.worlds.iiwa14.kinematics import forward_kinematics, joint_limits

LIMITS = joint_limits()
NO_BOXES = (np.zeros((0, 3)), np.zeros((0, 3)))
# Both ends free (with 1 cm of clearance, as generated tasks), but the straight motion folds
# the forearm into the base: link_0 - link_5 touch half-way.
FOLDED_START = np.array([-0.66, 1.91, 2.44, -2.08, 2.06, 0.86, -0.22])
FOLDED_GOAL = np.array([0.58, 1.92, -2.07, -1.95, -1.02, 0.14, 2.89])
# Joint 6 near its limit swings link_7 into the cut-out of link_5's mesh: the hulls touch.
WRIST_FOLDED = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 2.08, 0.0])


@pytest.fixture(scope="module")
def checkers():
    return IiwaSphereChecker(LIMITS, *NO_BOXES), IiwaExactChecker(LIMITS, *NO_BOXES)


def test_both_checkers_name_the_colliding_pair(checkers):
    for checker in checkers:
        assert isinstance(checker, SelfCollisionChecker)
        assert checker.self_collisions(WRIST_FOLDED) == [("link_5", "link_7")]
        assert checker.self_collisions(np.zeros(7)) == []
        assert not checker.states_free(WRIST_FOLDED)[0] and checker.states_free(np.zeros(7))[0]
        assert "self-collision of 4 link pairs" in checker.description


def test_fast_never_frees_a_self_collision(checkers):
    fast, exact = checkers
    states = np.random.default_rng(20).uniform(LIMITS[0], LIMITS[1], size=(20_000, 7))
    fast_free, exact_free = fast.states_free(states), exact.states_free(states)
    assert not np.any(fast_free & ~exact_free), "fast called a self-colliding state free"
    wrongly_rejected = np.sum(~fast_free & exact_free) / exact_free.sum()
    print(f"\nfast rejects {wrongly_rejected:.2%} of {exact_free.sum()} self-collision-free states")
    assert 0.02 < 1 - exact_free.mean() < 0.2  # the arm does fold into itself
    assert wrongly_rejected < 0.05


def test_checkers_agree_with_pybullet(checkers):
    # pybullet collides every pair two or more links apart (not only the enabled ones) on its
    # own shapes: each mesh's convex hull with a 1 mm margin, which our hulls reproduce.
    fast, exact = checkers
    states = np.random.default_rng(21).uniform(LIMITS[0], LIMITS[1], size=(1000, 7))
    with PybulletIiwa() as bullet:
        bullet_free = bullet.self_collision_free(states)
    exact_free, fast_free = exact.states_free(states), fast.states_free(states)
    assert 20 < np.sum(~bullet_free) < 300
    np.testing.assert_array_equal(exact_free, bullet_free)
    assert not np.any(fast_free & ~bullet_free)
    assert np.sum(~fast_free & bullet_free) < 0.05 * bullet_free.sum()


def test_pybullet_collides_hulls_grown_by_its_margin():
    # The reason our self-collision geometry is the padded hull: pybullet's distance between
    # link_5 and link_7 is the hull distance less 2 mm, over the whole range of joint 6.
    hulls = LinkHulls(np.array([[5, 7]]))
    states = np.zeros((40, 7))
    states[:, 5] = np.linspace(1.85, 2.09, 40)
    with PybulletIiwa() as bullet:
        for state, poses in zip(states, forward_kinematics(states)):
            ours = hulls.distance(poses, 5, 7)
            theirs = bullet.distance(state, 5, 7)
            if ours > 1e-4:
                assert theirs == pytest.approx(ours - 2 * SELF_COLLISION_PADDING, abs=1e-4)
            assert (theirs <= 0) == (ours <= SELF_COLLISION_GAP)


def test_a_motion_through_self_collision_is_caught(checkers):
    fast, exact = checkers
    ends = np.stack([FOLDED_START, FOLDED_GOAL])
    assert fast.states_free(ends, fast.resolution / 2).all() and exact.states_free(ends).all()
    assert not exact.edge_free(FOLDED_START, FOLDED_GOAL)
    assert not fast.edge_free(FOLDED_START, FOLDED_GOAL)
    with PybulletIiwa() as bullet:
        assert not bullet.self_collision_free(densify(ends, 0.01)).all()
    # A motion that only swings joint 1 keeps the folded arm's shape: certified by both.
    turned = FOLDED_START.copy()
    turned[0] += 0.5
    assert exact.edge_free(FOLDED_START, turned) and fast.edge_free(FOLDED_START, turned)


def test_fast_free_edges_are_certified_free_of_self_collision(checkers):
    fast, exact = checkers
    rng = np.random.default_rng(22)
    starts = rng.uniform(LIMITS[0], LIMITS[1], size=(400, 7))
    starts[:, 5] = rng.uniform(1.7, LIMITS[1, 5], size=400) * rng.choice([-1, 1], size=400)
    ends = np.clip(starts + rng.normal(0, 0.3, size=starts.shape), LIMITS[0], LIMITS[1])
    fast_free = fast.edges_free(starts, ends)
    exact_free = exact.edges_free(starts, ends)
    assert 50 < fast_free.sum() < 390  # near joint 6's limits: many edges fold the wrist
    assert not np.any(fast_free & ~exact_free)


@pytest.mark.parametrize("cls", [IiwaSphereChecker, IiwaExactChecker])
def test_joint_limits_hold_whatever_the_bounds(cls):
    wide = LIMITS + np.array([[-0.5], [0.5]])
    checker = cls(wide, *NO_BOXES)
    beyond = np.zeros(7)
    beyond[6] = LIMITS[1, 6] + 0.2  # inside the bounds, outside the URDF's limit
    assert checker.states_free(np.stack([np.zeros(7), beyond])).tolist() == [True, False]
    assert not checker.path_free(np.stack([np.zeros(7), beyond, np.zeros(7)]))
    assert not checker.edge_free(np.zeros(7), beyond)
