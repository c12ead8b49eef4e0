"""The generic arm's checkers: the fast one is conservative, the exact one certifies, and
states and motions a few millimetres from a surface are accepted."""

from __future__ import annotations

import re

import numpy as np
import pytest
from arm_fixtures import motions_from, random_configs, write_test_arm

from temp_gym.problem import Problem, Workspace
from temp_gym.worlds.arm.build import build
from temp_gym.worlds.arm.model import load_arm
from temp_gym.worlds.arm.spec import make_arm_checker, register_robot_file
from temp_gym.worlds.collision import CollisionChecker, SelfCollisionChecker
from temp_gym.worlds.collision.arm_exact import ArmExactChecker
from temp_gym.worlds.collision.arm_fast import ArmSphereChecker
from temp_gym.worlds.robots import forget_robot

BOXES = (
    np.array([[0.25, -0.4, -0.1], [-0.5, 0.3, 0.2], [-0.1, -0.6, 0.45], [-0.3, -0.3, -0.2]]),
    np.array([[0.35, 0.4, 0.5], [-0.25, 0.34, 0.6], [0.1, -0.5, 0.55], [0.3, 0.3, -0.05]]),
)


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    path = write_test_arm(tmp_path_factory.mktemp("collision"))
    build(path, log=lambda line: None)
    spec = register_robot_file(path)
    yield load_arm(path)
    forget_robot(spec.name)


@pytest.fixture(scope="module")
def checkers(arm):
    limits = arm.joint_limits()
    return ArmSphereChecker(arm, limits, *BOXES), ArmExactChecker(arm, limits, *BOXES)


def test_both_follow_the_protocols(checkers):
    for checker in checkers:
        assert isinstance(checker, CollisionChecker)
        assert isinstance(checker, SelfCollisionChecker)


def test_the_fast_checker_never_frees_what_the_exact_one_refuses(arm, checkers):
    fast, exact = checkers
    states = random_configs(arm, 3000, seed=4)
    fast_free, exact_free = fast.states_free(states), exact.states_free(states)
    assert np.all(exact_free[fast_free])
    assert 0.1 < fast_free.mean() < 0.95  # the scene is neither empty nor solid


def test_fast_free_edges_are_certified(arm, checkers):
    fast, exact = checkers
    rng = np.random.default_rng(5)
    starts = random_configs(arm, 300, seed=6)
    ends = np.clip(starts + rng.normal(0, 0.4, size=starts.shape), *arm.joint_limits())
    free = fast.edges_free(starts, ends)
    assert free.any() and not free.all()
    for start, end in zip(starts[free][:60], ends[free][:60]):
        assert exact.edge_free(start, end)


@pytest.mark.parametrize("robot", ["kuka_iiwa14", "franka_panda"])
def test_states_millimetres_from_a_box_are_accepted_and_can_be_left(robot):
    """Free states 2-6 mm from a box (by the exact checker, and by pybullet on the URDF's
    shapes) load, and short motions leave them, certified by both checkers."""
    from temp_gym.worlds.collision.pybullet_reference import PybulletArm
    from temp_gym.worlds.robots import robot_spec
    from temp_gym.worlds.splits import split_workspace

    spec = robot_spec(robot)
    arm = load_arm(spec.description)
    workspace = split_workspace(robot, "test", 0, "boxes")
    fast, exact = spec.make_checker(workspace), spec.make_checker(workspace, exact=True)
    rng = np.random.default_rng(7)
    near = []
    with PybulletArm(arm, workspace) as bullet:
        for state in rng.uniform(*workspace.bounds, size=(6000, arm.dim)):
            report = exact.obstacle_report(state) if exact.states_free(state[None])[0] else []
            if report and 0.002 <= report[0][2] <= 0.006 and bullet.states_free(state[None])[0]:
                near.append(state)
            if len(near) == 8:
                break
    assert len(near) == 8
    left = 0
    for k, state in enumerate(near):
        problem = Problem(workspace, state, near[k - 1], 0.1)  # the loader accepts both
        assert np.array_equal(problem.start, state)
        ends = np.clip(state + 0.05 * rng.normal(size=(64, arm.dim)), *arm.joint_limits())
        leaving = fast.edges_free(np.repeat(state[None], 64, axis=0), ends)
        if leaving.any():
            left += 1
            assert exact.edge_free(state, ends[np.flatnonzero(leaving)[0]])
    # The fast model is conservative: it may refuse a rare one (its self-collision model).
    assert left >= 7


def test_a_refused_state_names_the_link_the_box_and_the_depth(arm, checkers):
    _, exact = checkers
    workspace = Workspace(arm.name, arm.joint_limits(), (BOXES[0] + BOXES[1]) / 2,
                          (BOXES[1] - BOXES[0]) / 2)  # fmt: skip
    for state in random_configs(arm, 2000, seed=9):
        if exact.states_free(state[None])[0] or exact.self_collisions(state):
            continue
        with pytest.raises(ValueError) as caught:
            Problem(workspace, state, np.zeros(arm.dim), 0.1)
        message = str(caught.value)
        assert message.startswith("start:") and "touches box" in message
        assert "penetration" in message and "\n" not in message
        return
    pytest.fail("no state in collision with a box in the draws")


def test_invalid_states_are_not_free(arm, checkers):
    for checker in checkers:
        bad = np.zeros((3, arm.dim))
        bad[0, 0] = np.nan
        bad[1, 0] = arm.joint_limits()[1, 0] + 0.1
        bad[2, 1] = np.inf
        assert not checker.states_free(bad).any()
    with pytest.raises(ValueError, match="expected shape"):
        checkers[0].states_free(np.zeros((2, arm.dim + 1)))


def test_body_clearances_skip_only_elements_that_cannot_lower_them(arm, checkers):
    """Near an obstacle the exact checker measures a body's elements (fcl's mesh distance)
    nearest convex piece first and skips those whose piece is farther than the nearest element
    measured: every clearance equals the one that measures every element."""
    import fcl

    from temp_gym.worlds.collision.arm_exact import MESH_DISTANCE_BELOW

    _, exact = checkers
    reference = ArmExactChecker(arm, arm.joint_limits(), *BOXES)
    measured = {"skipping": 0, "every": 0}

    def every_element(j, b, piece_distances, best):
        measured["every"] += len(reference._elements[j])
        return min(
            fcl.distance(obj, reference._obstacles[b], fcl.DistanceRequest(), fcl.DistanceResult())
            for obj, _ in reference._elements[j]
        )

    skipping = exact._element_distance

    def counted(j, b, piece_distances, best):
        before = fcl.distance
        calls = [0]

        def counting(*args):
            calls[0] += 1
            return before(*args)

        fcl.distance = counting
        try:
            return skipping(j, b, piece_distances, best)
        finally:
            fcl.distance = before
            measured["skipping"] += calls[0]

    reference._element_distance = every_element
    exact._element_distance = counted
    several = [j for j in range(1, arm.num_bodies) if len(exact._elements[j]) > 1]
    assert several  # the fixture's arm has bodies of several elements
    compared = 0
    try:
        for poses in arm.forward_kinematics(random_configs(arm, 3000, seed=8)):
            gaps = exact._aabb_gaps(poses)
            for j in several:
                if gaps[j].min() < MESH_DISTANCE_BELOW:
                    got = exact._body_clearance(poses, j, gaps[j])
                    assert got == reference._body_clearance(poses, j, gaps[j])
                    compared += 1
    finally:
        del exact._element_distance
    assert compared > 100
    assert 0 < measured["skipping"] < measured["every"]


def test_element_distance_is_the_nearest_element_whatever_the_bounds_given(arm, checkers):
    """`_element_distance` returns the least of every element's fcl distance when its piece
    distances are any lower bounds, so that the order it measures in never changes the answer.
    """
    import fcl

    _, exact = checkers
    rng = np.random.default_rng(9)
    several = [j for j in range(1, arm.num_bodies) if len(exact._elements[j]) > 1]
    compared = 0
    for poses in arm.forward_kinematics(random_configs(arm, 400, seed=10)):
        for j in several:
            exact._pose_body(poses, j)
            for b in range(len(exact._obstacles)):
                each = np.array([
                    fcl.distance(obj, exact._obstacles[b], fcl.DistanceRequest(),
                                 fcl.DistanceResult())
                    for obj, _ in exact._elements[j]
                ])  # fmt: skip
                for bounds in (np.zeros(len(each)), rng.uniform(0, 1, len(each)) * each):
                    assert exact._element_distance(j, b, list(bounds), np.inf) == each.min()
                    compared += 1
    assert compared > 500


def test_compiled_pose_bounds_are_the_checkers_own(arm):
    """`pose_bounds` gives, for one pose of a motion, the poses `forward_kinematics` gives, the
    bodies' AABB gaps `_aabb_gaps` gives on them, and the pairs' bounding-sphere gaps
    `BodyHulls.sphere_gaps` gives (numpy, up to the order of roundings); `box_center` places
    the bodies' bounding boxes where numpy does, up to the same."""
    from temp_gym.worlds.arm.kinematics import identity_poses
    from temp_gym.worlds.collision.arm_exact_bounds import box_center, pose_bounds

    exact = ArmExactChecker(arm, arm.joint_limits(), *BOXES)
    poses = identity_poses(arm.num_bodies)
    gaps = np.empty((arm.num_bodies, len(exact._obstacles)))
    spheres = np.empty(len(exact._hulls.pairs))
    touching = 0
    rng = np.random.default_rng(18)
    for start in random_configs(arm, 200, seed=17):
        # The pose at t along a motion, as the certifier measures it.
        delta, t = rng.normal(0, 0.3, arm.dim), float(rng.uniform())
        pose_bounds(start, delta, t, *exact._kinematics, exact._local_center,
                    exact._local_half, exact._aabb_center, exact._aabb_half,
                    exact._sphere_centers, exact._sphere_radii, exact._hulls.pairs, poses, gaps,
                    spheres)  # fmt: skip
        full = arm.forward_kinematics(start + t * delta)[0]
        np.testing.assert_array_equal(poses, full[:, :3, :])
        for j in range(arm.num_bodies):
            expected = full[j, :3, :3] @ exact._local_center[j] + full[j, :3, 3]
            np.testing.assert_allclose(box_center(poses, j, exact._local_center), expected,
                                       rtol=0, atol=1e-15)  # fmt: skip
        np.testing.assert_array_equal(gaps, exact._aabb_gaps(full))
        np.testing.assert_allclose(spheres, exact._hulls.sphere_gaps(full), rtol=0, atol=1e-12)
        touching += int(np.sum(gaps == 0.0))
    assert len(exact._hulls.pairs) and touching  # pairs and overlapping boxes were compared


def test_compiled_cover_bounds_are_numpys_arithmetic():
    """`carried_bounds` and `cover_bounds` give, bit for bit, what the numpy formulas give:
    the bounds carried from the last poses, each item's cheap bound, the new frontier where
    each span meets the old one, and a stable order of it (ties in index order)."""
    from temp_gym.worlds.collision.arm_exact import STEP_SAFETY
    from temp_gym.worlds.collision.arm_exact_bounds import carried_bounds, cover_bounds
    from temp_gym.worlds.collision.arm_self import DISTANCE_TOLERANCE, SELF_COLLISION_GAP

    rng = np.random.default_rng(23)
    met = fell_short = 0
    for _ in range(300):
        # Up to 40 items: a short sort may be stable by chance.
        bodies, obstacles, pairs = rng.integers(0, 21), rng.integers(1, 5), rng.integers(0, 21)
        moving = np.sort(rng.choice(24, bodies, replace=False))
        moving_pairs = np.sort(rng.choice(24, pairs, replace=False))
        if bodies + pairs == 0:
            continue
        gaps = rng.uniform(0, 0.3, (24, obstacles)) * (rng.random((24, obstacles)) < 0.8)
        sphere_gaps = rng.uniform(-0.1, 0.3, 24)
        rates = rng.uniform(0.05, 3.0, bodies + pairs)
        # Frontiers with ties (equal entries), behind and ahead of t.
        frontier = rng.choice([0.0, 0.2, 0.35, 0.5], bodies + pairs)
        t = float(rng.choice([0.0, 0.3, 0.6]))
        history_t = rng.uniform(0, 1, 2)
        history = rng.uniform(-0.05, 0.3, (2, bodies + pairs))
        count = int(rng.integers(0, 3))

        carried = None
        for when, known in list(zip(history_t, history))[:count]:
            brought = known - rates * abs(t - when)
            carried = brought if carried is None else np.maximum(carried, brought)
        if count:
            before = history[1] if count == 2 else np.empty(0)
            got = carried_bounds(t, rates, history_t[0], history[0], history_t[1], before)
            np.testing.assert_array_equal(got, carried)

        spheres = sphere_gaps[moving_pairs] - SELF_COLLISION_GAP
        bounds = np.concatenate([gaps[moving].min(axis=1) - DISTANCE_TOLERANCE,
                                 spheres - DISTANCE_TOLERANCE])  # fmt: skip
        if carried is not None:
            bounds = np.maximum(bounds, carried)
        reach = STEP_SAFETY * bounds / rates
        expected = np.where(t - reach <= frontier, np.maximum(frontier, t + reach), frontier)
        got = cover_bounds(t, frontier, rates, np.empty(0) if carried is None else carried,
                           moving, moving_pairs, gaps, sphere_gaps, DISTANCE_TOLERANCE,
                           SELF_COLLISION_GAP, STEP_SAFETY)  # fmt: skip
        np.testing.assert_array_equal(got[0], bounds)
        np.testing.assert_array_equal(got[1], spheres)
        np.testing.assert_array_equal(got[2], expected)
        np.testing.assert_array_equal(got[3], np.argsort(expected, kind="stable"))
        met += int(np.sum(t - reach <= frontier))
        fell_short += int(np.sum(t - reach > frontier))
    assert met > 100 and fell_short > 100  # both cases of the frontier update were compared


def test_fcl_distance_is_fcls_and_leaves_its_result_alone(arm):
    """`fcl_distance` returns what `fcl.distance` returns with a fresh result (-1 for shapes
    that intersect), for meshes, convex pieces and boxes, and its shared result is never
    written."""
    import fcl

    from temp_gym.worlds.collision import arm_self

    exact = ArmExactChecker(arm, arm.joint_limits(), *BOXES)
    request = fcl.DistanceRequest()
    compared = touching = 0
    for q in random_configs(arm, 40, seed=29):
        poses = arm.forward_kinematics(q)[0]
        for j in range(1, arm.num_bodies):
            exact._pose_body(poses, j)
            posed = arm_self.transform(poses[j])
            for piece in exact._pieces[j]:
                piece.setTransform(posed)
            objects = [obj for obj, _ in exact._elements[j]] + exact._pieces[j]
            for obj in objects:
                for obstacle in exact._obstacles:
                    expected = fcl.distance(obj, obstacle, request, fcl.DistanceResult())
                    assert arm_self.fcl_distance(obj, obstacle, request) == expected
                    compared += 1
                    touching += expected < 0
    assert compared > 1000 and touching > 10
    assert arm_self._UNWRITTEN.min_distance == -np.inf
    assert arm_self._UNWRITTEN.nearest_points == [None, None]


def test_carried_bounds_give_the_verdicts_of_measuring_at_every_pose(arm, checkers):
    """A motion's certification carries each body's and pair's clearance bound from the poses
    measured before, less its rate times the distance in ``t``, and measures only what could
    limit how far the motion is certified: the same verdicts as a certifier that starts every
    pose from the cheap bounds alone."""
    _, exact = checkers
    reference = ArmExactChecker(arm, arm.joint_limits(), *BOXES)
    cover = reference._cover
    reference._cover = lambda poses, t, frontier, rates, carried, *args: cover(
        poses, t, frontier, rates, None, *args
    )
    rng = np.random.default_rng(11)
    starts = random_configs(arm, 600, seed=12)
    starts = starts[exact.states_free(starts)][:150]
    ends = motions_from(arm, starts, rng, rng.uniform(0.1, 0.8, len(starts)))
    verdicts = exact.edges_free(starts, ends)
    assert 0.1 < verdicts.mean() < 0.9
    np.testing.assert_array_equal(verdicts, reference.edges_free(starts, ends))


def _fresh_clearances(exact, poses, moving, moving_pairs):
    """fcl's clearance of each moving body (to the nearest obstacle, 0 if touching) and each
    moving pair (padded, less the gap), measured afresh and in full at one pose."""
    import fcl

    from temp_gym.worlds.collision.arm_self import SELF_COLLISION_GAP

    fresh = []
    for j in moving:
        exact._pose_body(poses, j)
        nearest = min(
            fcl.distance(obj, obstacle, fcl.DistanceRequest(), fcl.DistanceResult())
            for obj, _ in exact._elements[j]
            for obstacle in exact._obstacles
        )
        fresh.append(max(nearest, 0.0))
    fresh += [exact._hulls.distance(poses, *exact._hulls.pairs[p]) - SELF_COLLISION_GAP
              for p in moving_pairs]  # fmt: skip
    return np.asarray(fresh)


def test_bounds_carried_to_a_pose_are_lower_bounds_on_its_clearances(arm, checkers):
    """Every bound a motion's certification carries to a pose is at most the clearance measured
    there afresh, for each moving body (to the obstacles) and each moving pair."""
    exact = ArmExactChecker(arm, arm.joint_limits(), *BOXES)
    cover = exact._cover
    checked = [0, 0]

    def checking(poses, t, frontier, rates, carried, moving, moving_pairs, *cheap):
        if carried is not None:
            fresh = _fresh_clearances(exact, poses, moving, moving_pairs)
            assert np.all(carried <= fresh + 1e-9)
            checked[0] += len(fresh)
            checked[1] += int(np.sum(carried > 0))
        return cover(poses, t, frontier, rates, carried, moving, moving_pairs, *cheap)

    exact._cover = checking
    rng = np.random.default_rng(13)
    starts = random_configs(arm, 400, seed=14)
    starts = starts[exact.states_free(starts)][:60]
    ends = motions_from(arm, starts, rng, 0.6)
    exact.edges_free(starts, ends)
    assert checked[0] > 1000 and checked[1] > 500


def test_a_certified_motion_is_covered_by_the_spans_of_the_poses_measured(arm, checkers):
    """Recorded independently of the certifier's own bookkeeping: for every motion it calls
    free, each moving body and pair has, at every ``t`` in [0, 1], a measured pose whose
    clearance bound (at most fcl's fresh clearance there) over its rate keeps it clear, with
    `STEP_SAFETY` to spare; and the poses measured past what was certified are used."""
    from temp_gym.worlds.collision.arm_exact import STEP_SAFETY

    exact = ArmExactChecker(arm, arm.joint_limits(), *BOXES)
    cover = exact._cover
    records = []

    def recording(poses, t, frontier, rates, carried, moving, moving_pairs, *cheap):
        answer = cover(poses, t, frontier, rates, carried, moving, moving_pairs, *cheap)
        fresh = _fresh_clearances(exact, poses, moving, moving_pairs)
        assert np.all(answer[2] <= fresh + 1e-9)  # the bounds kept are lower bounds
        records.append((t, answer[2].copy(), rates, frontier.min()))
        return answer

    exact._cover = recording
    rng = np.random.default_rng(15)
    starts = random_configs(arm, 400, seed=16)
    starts = starts[exact.states_free(starts)][:60]
    ends = motions_from(arm, starts, rng, 0.6)
    certified = ahead = measured = 0
    assert exact.poses_measured == 0
    for start, end in zip(starts, ends):
        measured += len(records)
        records.clear()
        if not exact.edge_free(start, end) or not records:
            continue
        certified += 1
        ahead += sum(t > behind for t, _, _, behind in records)
        spans = np.array([STEP_SAFETY * known / rates for _, known, rates, _ in records])
        times = np.array([t for t, _, _, _ in records])
        for item in range(spans.shape[1]):
            low, high = times - spans[:, item], times + spans[:, item]
            reached = 0.0  # [0, reached] is covered: extend it with any span that meets it
            for k in np.argsort(low):
                if low[k] > reached:
                    break
                reached = max(reached, high[k])
            assert reached >= 1.0, (item, reached)
    assert certified > 20 and ahead > certified, (certified, ahead)
    assert exact.poses_measured == measured + len(records)  # the diagnostic counts every pose


def test_self_collisions_are_found_by_both_and_named(arm, checkers):
    fast, exact = checkers
    found = 0
    for state in random_configs(arm, 3000, seed=10):
        pairs = exact.self_collisions(state)
        if pairs:
            found += 1
            assert not fast.states_free(state[None])[0]
            assert fast.self_collisions(state)
    assert found > 0


def test_the_spec_makes_both_checkers(arm):
    workspace = Workspace(arm.name, arm.joint_limits(), np.zeros((0, 3)), np.zeros((0, 3)))
    assert isinstance(make_arm_checker(arm, workspace), ArmSphereChecker)
    assert isinstance(make_arm_checker(arm, workspace, exact=True), ArmExactChecker)


def test_a_description_edited_after_registration_is_refused_not_half_read(arm):
    from temp_gym.worlds.arm.description import DescriptionError

    path = arm.description.path
    text = path.read_text()
    assert register_robot_file(path).name == arm.name  # the same file: the registered spec
    try:
        path.write_text(text + "# a comment changes nothing\n")
        assert register_robot_file(path).name == arm.name
        path.write_text(text + "planning: {goal_radius: 0.3}\n")
        with pytest.raises(DescriptionError, match=r"changed since robot .* was registered"):
            register_robot_file(path)
    finally:
        path.write_text(text)


def test_an_arms_spec_reads_its_description_again_only_when_the_file_changes(arm, monkeypatch):
    """Every part of the spec checks the file is unchanged (a checker per plan, the joint
    limits per problem); parsing its YAML each time cost about a millisecond a call."""
    from temp_gym.worlds.arm import spec as spec_module
    from temp_gym.worlds.robots import robot_spec

    spec = robot_spec(arm.name)
    spec.joint_limits()
    read = []
    real = spec_module.load_description
    monkeypatch.setattr(
        spec_module, "load_description", lambda path: read.append(path) or real(path)
    )
    for _ in range(3):
        spec.joint_limits()
        workspace = Workspace(arm.name, spec.joint_limits(), np.zeros((0, 3)), np.zeros((0, 3)))
        spec.make_checker(workspace)
    assert read == []
    path = arm.description.path
    text = path.read_text()
    try:
        path.write_text(text + "# a comment changes nothing\n")
        spec.joint_limits()
        assert len(read) == 1  # the edit is seen, and read once
    finally:
        path.write_text(text)


def test_a_second_file_of_a_registered_name_is_told_where_the_name_is(arm, tmp_path):
    import shutil

    from temp_gym.worlds.robots import robot_spec

    folder = arm.description.path.parent
    copy = tmp_path / "copy"
    shutil.copytree(folder, copy)
    registered = robot_spec(arm.name).description
    with pytest.raises(ValueError, match=rf"is taken by the registered robot '{arm.name}' "
                                         rf"\(from {re.escape(str(registered))}\)"):  # fmt: skip
        register_robot_file(copy / arm.description.path.name)
