"""Self-collision of the built-in arms: the allowed-collision matrix and pair tables they ship,
and the fast checker (spheres, tables) against the exact one (padded pieces) against pybullet.
"""

from __future__ import annotations

import numpy as np
import pytest

from temp_gym.worlds.arm import acm
from temp_gym.worlds.arm.bullet import load_bullet_arm, set_configuration
from temp_gym.worlds.arm.model import COLLISION_PADDING, load_arm
from temp_gym.worlds.arm.pair_tables import (
    REFINE,
    UNIT,
    decode_bounds,
    encode_bounds,
    table_arrays,
    tabulated_pairs,
)
from temp_gym.worlds.collision.arm_exact import ArmExactChecker
from temp_gym.worlds.collision.arm_fast import ArmSphereChecker
from temp_gym.worlds.collision.arm_self import SELF_COLLISION_GAP, BodyHulls
from temp_gym.worlds.collision.pybullet_reference import PybulletArm, densify
from temp_gym.worlds.robots import robot_spec

ROBOTS = ["kuka_iiwa14", "franka_panda"]
NO_BOXES = (np.zeros((0, 3)), np.zeros((0, 3)))
ENABLED = {
    "kuka_iiwa14": [[0, 5], [0, 6], [0, 7], [5, 7]],
    "franka_panda": [[0, 5], [0, 6], [0, 7], [1, 5], [1, 6], [1, 7], [2, 5], [2, 6], [2, 7],
                     [5, 7]],
}  # fmt: skip
"""The body pairs each shipped allowed-collision matrix enables: the wrist against the base
(and, on the Panda, against the shoulder) and the flange against the forearm."""
FOLDED = {
    # Joint 6 near its limit swings link 7 into the cut-out of link 5.
    "kuka_iiwa14": (np.array([0.0, 0.0, 0.0, 0.0, 0.0, 2.08, 0.0]), 5, 7),
    # The zero configuration folds the Panda's hand onto link 5.
    "franka_panda": (np.zeros(7), 5, 7),
}
"""Per robot: a configuration in self-collision, and the one pair of bodies that touch."""
FOLDING_JOINT = 5
"""The joint (0-based) that folds either arm's flange onto its forearm (bodies 7 and 5)."""
THROUGH_SELF_COLLISION = {
    # The straight motion folds the forearm into the base: link 0 - link 5 and link 6 touch
    # half-way.
    "kuka_iiwa14": (np.array([-0.66, 1.91, 2.44, -2.08, 2.06, 0.86, -0.22]),
                    np.array([0.58, 1.92, -2.07, -1.95, -1.02, 0.14, 2.89])),
    # The shoulder at its limit, the elbow folded: link 6 sweeps through the base.
    "franka_panda": (np.array([-1.27, 1.83, 0.64, -2.97, 1.53, 2.08, 0.64]),
                     np.array([-1.95, 0.72, 0.69, -2.97, 1.69, 1.79, 1.24])),
}  # fmt: skip
"""Per robot: a start and a goal, both free with half the edge resolution of clearance, whose
straight motion passes through a self-collision."""
UPRIGHT = {
    "kuka_iiwa14": np.zeros(7),
    "franka_panda": np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]),  # "ready"
}
"""Per robot: a configuration free of self-collision."""


@pytest.fixture(scope="module")
def arms():
    return {robot: load_arm(robot_spec(robot).description) for robot in ROBOTS}


@pytest.fixture(scope="module")
def checkers(arms):
    """Per robot, the fast and the exact checker with no boxes: only self-collision blocks."""
    return {
        robot: (ArmSphereChecker(arm, arm.joint_limits(), *NO_BOXES),
                ArmExactChecker(arm, arm.joint_limits(), *NO_BOXES))
        for robot, arm in arms.items()
    }  # fmt: skip


def _uniform(arm, count, seed):
    return np.random.default_rng(seed).uniform(*arm.joint_limits(), size=(count, arm.dim))


# ---- the shipped data ---------------------------------------------------------------------------
@pytest.mark.parametrize("robot", ROBOTS)
def test_the_shipped_acm_is_consistent_and_the_checkers_test_its_enabled_pairs(
    arms, checkers, robot
):
    arm = arms[robot]
    data = arm.derived_data()["acm"]
    pairs = [tuple(entry["bodies"]) for entry in data["pairs"]]
    bodies = arm.num_bodies
    assert len(pairs) == len(set(pairs)) == bodies * (bodies - 1) // 2  # every pair, once
    for entry in data["pairs"]:
        a, b = entry["bodies"]
        assert entry["links"] == [arm.body_names[a], arm.body_names[b]]
        assert entry["reason"] in ("adjacent", "srdf", "always", "never", "enabled")
        assert (entry["reason"] == "adjacent") == (b == a + 1)
        if entry["reason"] == "never" and "colliding_samples" in entry:
            assert entry["colliding_samples"] == 0
            assert entry["closest_approach"] > acm.NEVER_CLEARANCE
        if entry["reason"] == "enabled":
            assert entry["closest_approach"] <= acm.NEVER_CLEARANCE
    assert data["reported"] == [e["links"] for e in data["pairs"] if e["reason"] == "always"]
    np.testing.assert_array_equal(arm.enabled_pairs(), ENABLED[robot])
    fast, exact = checkers[robot]
    assert fast.num_self_pairs == len(ENABLED[robot])
    for checker in (fast, exact):
        assert f"self-collision of {len(ENABLED[robot])} body pairs" in checker.description
    # The pair tables are those of the enabled pairs two joints apart that come close.
    tables = [tuple(t["bodies"]) for t in arm.derived_data()["pair_tables"]]
    assert tables == tabulated_pairs(data)


@pytest.mark.parametrize("robot", ROBOTS)
def test_the_acm_is_reproducible_from_its_seed(arms, robot, monkeypatch):
    monkeypatch.setattr(acm, "SEARCH_STARTS", 1)
    monkeypatch.setattr(acm, "SEARCH_STEPS", 20)
    arm = arms[robot]
    first = acm.compute_acm(arm, samples=100, seed=3)
    assert first == acm.compute_acm(arm, samples=100, seed=3)
    shipped = {tuple(e["bodies"]): e for e in arm.derived_data()["acm"]["pairs"]}
    compared = 0
    for entry in first["pairs"]:
        if "zero_configuration_distance" in entry:  # the zero configuration needs no samples
            expected = shipped[tuple(entry["bodies"])]["zero_configuration_distance"]
            assert entry["zero_configuration_distance"] == expected
            compared += 1
    assert compared > 10


def _entry(grid_row, bounds_row, state) -> float:
    """A table's bound for ``state``, located as the kernels do (independently written)."""
    joint, lower, width, cells, second_lower, second_width, second_cells = grid_row
    joint = int(joint)
    first = min(max(int((state[joint] - lower) / width), 0), int(cells) - 1)
    second = min(max(int((state[joint + 1] - second_lower) / second_width), 0),
                 int(second_cells) - 1)  # fmt: skip
    return float(bounds_row[first * int(second_cells) + second])


@pytest.mark.parametrize("robot", ROBOTS)
def test_pair_tables_bound_the_piece_distance_from_below_and_tightly(arms, robot):
    """A table entry is a lower bound on the padded piece distance over its whole cell of the
    two joints, and at the cell's center it is below the distance by at least the table's own
    slack (the pair's relative motion over half a sub-cell of each joint) and at most three
    times it (the worst sub-cell's center is within two slacks of the cell's), up to rounding."""
    arm = arms[robot]
    limits = arm.joint_limits()
    shipped = arm.derived_data()["pair_tables"]
    pairs, grid, bounds = table_arrays(shipped)
    assert len(pairs) > 0
    hulls = BodyHulls(arm, pairs)
    radii = arm.motion_radii()
    for p, ((a, b), table) in enumerate(zip(pairs, shipped)):
        joint = int(grid[p, 0])
        assert (joint, joint + 2) == (a, b) and table["joints"] == [a, a + 1]
        states = _uniform(arm, 600, seed=6)
        states[:300, joint] = np.linspace(limits[0, joint], limits[1, joint], 300)  # densely
        states[300:, joint + 1] = np.linspace(limits[0, joint + 1], limits[1, joint + 1], 300)
        margins = []
        for state, poses in zip(states, arm.forward_kinematics(states)):
            distance = hulls.distance(poses, a, b) - SELF_COLLISION_GAP
            assert _entry(grid[p], bounds[p], state) <= distance
            margins.append(distance - _entry(grid[p], bounds[p], state))
        slack = (radii[a, b] * table["cell"][0] + radii[a + 1, b] * table["cell"][1]) / (2 * REFINE)
        print(f"\n{robot} {a}-{b}: cells {table['shape']}, slack {slack * 1000:.2f} mm, median "
              f"margin on random poses {np.median(margins) * 1000:.2f} mm")  # fmt: skip
        # At cell centers the bound is the distance less the slack, rounded down.
        rng = np.random.default_rng(8)
        centers = _uniform(arm, 40, seed=9)
        for state in centers:
            i, k = rng.integers(table["shape"][0]), rng.integers(table["shape"][1])
            state[joint] = grid[p, 1] + (i + 0.5) * grid[p, 2]
            state[joint + 1] = grid[p, 4] + (k + 0.5) * grid[p, 5]
        for state, poses in zip(centers, arm.forward_kinematics(centers)):
            distance = hulls.distance(poses, a, b) - SELF_COLLISION_GAP
            margin = distance - _entry(grid[p], bounds[p], state)
            assert slack - 1e-6 <= margin <= 3 * slack + UNIT + 1e-6, (margin, slack)


def test_the_iiwa_flange_table_is_tight_on_the_typical_pose(arms):
    """On random poses the iiwa's wrist table is below the true distance by at most about two
    of its slacks (under a millimetre each) at the median, and never above it."""
    arm = arms["kuka_iiwa14"]
    shipped = arm.derived_data()["pair_tables"]
    pairs, grid, bounds = table_arrays(shipped)
    np.testing.assert_array_equal(pairs, [[5, 7]])
    radii = arm.motion_radii()
    slack = (radii[5, 7] * shipped[0]["cell"][0] + radii[6, 7] * shipped[0]["cell"][1]) / (
        2 * REFINE
    )
    assert slack < 0.001
    hulls = BodyHulls(arm, pairs)
    states = _uniform(arm, 300, seed=7)
    margins = [hulls.distance(poses, 5, 7) - SELF_COLLISION_GAP - _entry(grid[0], bounds[0], state)
               for state, poses in zip(states, arm.forward_kinematics(states))]  # fmt: skip
    assert min(margins) >= 0 and np.median(margins) < 2 * slack + UNIT


def test_table_bounds_round_down_and_refuse_bad_data():
    values = np.array([[0.01234, -0.5], [5.0, -7.0]])
    decoded = decode_bounds(encode_bounds(values), (2, 2))
    assert np.all(decoded[0] <= values[0]) and np.all(decoded[0] > values[0] - UNIT - 1e-12)
    assert decoded[1, 0] == pytest.approx(32767 * UNIT)  # clipped down: still a lower bound
    assert decoded[1, 1] < 0  # clipped up, but a negative bound refuses the pose anyway
    with pytest.raises(ValueError, match="bytes of bounds"):
        decode_bounds(encode_bounds(values), (3, 2))


# ---- the checkers -------------------------------------------------------------------------------
@pytest.mark.parametrize("robot", ROBOTS)
def test_both_checkers_name_the_colliding_pair(arms, checkers, robot):
    arm = arms[robot]
    folded, a, b = FOLDED[robot]
    for checker in checkers[robot]:
        assert checker.self_collisions(folded) == [arm.pair_name(a, b)]
        assert checker.self_collisions(UPRIGHT[robot]) == []
        assert not checker.states_free(folded)[0] and checker.states_free(UPRIGHT[robot])[0]


@pytest.mark.parametrize("robot", ROBOTS)
def test_fast_never_frees_a_self_collision(arms, checkers, robot):
    fast, exact = checkers[robot]
    states = _uniform(arms[robot], 20_000, seed=20)
    fast_free, exact_free = fast.states_free(states), exact.states_free(states)
    assert not np.any(fast_free & ~exact_free), "fast called a self-colliding state free"
    wrongly_rejected = np.sum(~fast_free & exact_free) / exact_free.sum()
    print(f"\n{robot}: fast rejects {wrongly_rejected:.2%} of {exact_free.sum()} "
          f"self-collision-free states; {1 - exact_free.mean():.2%} self-collide")  # fmt: skip
    assert 0.02 < 1 - exact_free.mean() < 0.2  # the arm does fold into itself
    assert wrongly_rejected < 0.05


@pytest.mark.parametrize("robot", ROBOTS)
def test_checkers_agree_with_pybullet(arms, checkers, robot):
    """pybullet collides every pair of links two or more joints apart (not only the enabled
    ones) on its own shapes: each mesh's convex hull with a 1 mm margin, which the exact
    checker's padded pieces reproduce."""
    fast, exact = checkers[robot]
    states = _uniform(arms[robot], 1000, seed=21)
    with PybulletArm(arms[robot]) as bullet:
        bullet_free = bullet.self_collision_free(states)
    exact_free, fast_free = exact.states_free(states), fast.states_free(states)
    assert 20 < np.sum(~bullet_free) < 300
    np.testing.assert_array_equal(exact_free, bullet_free)
    assert not np.any(fast_free & ~bullet_free)
    wrongly_rejected = np.sum(~fast_free & bullet_free) / bullet_free.sum()
    print(f"\n{robot}: fast rejects {wrongly_rejected:.2%} of pybullet's free states")
    assert wrongly_rejected < 0.05


def _bullet_body_distance(client, loaded, arm, a, b):
    """pybullet's closest distance between any link of body ``a`` and any of body ``b``
    (``inf`` beyond 5 cm)."""
    links = {body: [loaded.links[link] for link, k in arm.chain.link_bodies.items()
                    if k == body and any(e.link == link for e in arm.chain.elements[k])]
             for body in (a, b)}  # fmt: skip
    return min(
        (point[8] for la in links[a] for lb in links[b]
         for point in client.getClosestPoints(loaded.body, loaded.body, 0.05, la, lb)),
        default=np.inf,
    )  # fmt: skip


@pytest.mark.parametrize("robot", ROBOTS)
def test_pybullet_collides_pieces_grown_by_its_margin(arms, robot):
    """Why the self-collision geometry is the padded pieces: pybullet's distance between the
    folding pair is the piece distance less twice the padding, over the whole range of the
    joint that folds it."""
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    from temp_gym.quiet import native_output_silenced

    arm = arms[robot]
    folded, a, b = FOLDED[robot]
    limits = arm.joint_limits()
    hulls = BodyHulls(arm, np.array([[a, b]]))
    joint = FOLDING_JOINT
    states = np.tile(folded, (60, 1))
    states[:, joint] = np.linspace(limits[0, joint], limits[1, joint], 60)
    with native_output_silenced():
        client = BulletClient(connection_mode=pybullet.DIRECT)
        loaded = load_bullet_arm(client, arm)
    compared = touching = 0
    try:
        for state, poses in zip(states, arm.forward_kinematics(states)):
            set_configuration(client, loaded, state)
            client.performCollisionDetection()
            ours = hulls.distance(poses, a, b)
            theirs = _bullet_body_distance(client, loaded, arm, a, b)
            assert (theirs <= 0) == (ours <= SELF_COLLISION_GAP), (state[joint], ours, theirs)
            if 1e-4 < ours < 0.04:
                assert theirs == pytest.approx(ours - 2 * COLLISION_PADDING, abs=1e-4)
                compared += 1
            touching += ours <= SELF_COLLISION_GAP
    finally:
        client.disconnect()
    assert compared >= 3 and touching >= 1, (compared, touching)


@pytest.mark.parametrize("robot", ROBOTS)
def test_a_motion_through_self_collision_is_caught(arms, checkers, robot):
    arm = arms[robot]
    fast, exact = checkers[robot]
    start, goal = THROUGH_SELF_COLLISION[robot]
    assert fast.states_free(np.stack([start, goal]), fast.resolution / 2).all()
    assert exact.states_free(np.stack([start, goal])).all()
    assert not exact.edge_free(start, goal)
    assert not fast.edge_free(start, goal)
    with PybulletArm(arm) as bullet:
        assert not bullet.self_collision_free(densify(np.stack([start, goal]), 0.01)).all()
    # A motion that only swings the first joint keeps the arm's shape: certified by both.
    turned = start.copy()
    turned[0] += 0.5 if turned[0] + 0.5 <= arm.joint_limits()[1, 0] else -0.5
    assert exact.edge_free(start, turned) and fast.edge_free(start, turned)


@pytest.mark.parametrize("robot", ROBOTS)
def test_fast_free_edges_are_certified_free_of_self_collision(arms, checkers, robot):
    """Edges out of states with the folding joint near its limits, where many fold the
    wrist into itself: what the fast checker frees, the exact one certifies."""
    arm = arms[robot]
    fast, exact = checkers[robot]
    limits = arm.joint_limits()
    joint = FOLDING_JOINT
    rng = np.random.default_rng(22)
    starts = _uniform(arm, 300, seed=25)
    near_limit = rng.uniform(0.0, 0.4, size=300)
    starts[:, joint] = np.where(rng.random(300) < 0.5, limits[0, joint] + near_limit,
                                limits[1, joint] - near_limit)  # fmt: skip
    ends = np.clip(starts + rng.normal(0, 0.3, size=starts.shape), *limits)
    fast_free = fast.edges_free(starts, ends)
    assert 30 < fast_free.sum() < 290, fast_free.sum()  # many edges fold the wrist
    assert exact.edges_free(starts[fast_free], ends[fast_free]).all()


def _pair_contact_states(arm, fast, count, seed):
    """States a micrometre (in joint space) from the fast checker's self-collision boundary of
    a sphere pair between two moving bodies, found by bisection on the joints between them."""
    pairs = {tuple(p) for p in fast._self_model[0].tolist() if p[0] >= 1}
    limits = arm.joint_limits()
    rng = np.random.default_rng(seed)
    found = []
    while len(found) < count:
        hit = rng.uniform(*limits)
        named = fast.self_collisions(hit)
        if len(named) != 1:
            continue
        a, b = (arm.body_names.index(name) for name in named[0])
        if (a, b) not in pairs:
            continue
        away = hit.copy()
        away[a:] = rng.uniform(limits[0, a:], limits[1, a:])  # the joints after body a
        if not fast.states_free(away[None])[0]:
            continue
        free = away
        for _ in range(60):
            middle = (free + hit) / 2
            if fast.states_free(middle[None])[0]:
                free = middle
            else:
                hit = middle
        found.append(free + (away - free) * (1e-6 / np.linalg.norm(away - free)))
    return np.array(found)


def test_a_pair_is_certified_by_its_relative_motion(arms, checkers):
    """The Panda's wrist a micrometre from its shoulder, the whole arm turned about the base:
    the two bodies do not move relative to each other, so the motion is free of their
    self-collision however close they are. Grown by each body's own sweep, the pair would
    touch in every interval down to the growth floor and the motion would be refused. What
    the fast checker frees, the exact one certifies, here and on random motions from there."""
    arm = arms["franka_panda"]
    fast, exact = checkers["franka_panda"]
    limits = arm.joint_limits()
    starts = _pair_contact_states(arm, fast, 4, seed=3)
    turned = starts.copy()
    turned[:, 0] += np.where(starts[:, 0] + 0.3 <= limits[1, 0], 0.3, -0.3)
    assert fast.edges_free(starts, turned).all()
    assert exact.edges_free(starts, turned).all()
    rng = np.random.default_rng(4)
    ends = np.clip(np.repeat(starts, 10, axis=0) + rng.normal(0, 0.2, (40, arm.dim)), *limits)
    fast_free = fast.edges_free(np.repeat(starts, 10, axis=0), ends)
    assert exact.edges_free(np.repeat(starts, 10, axis=0)[fast_free], ends[fast_free]).all()
