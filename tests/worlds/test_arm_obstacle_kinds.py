"""The arms' checkers among every obstacle kind: oriented boxes, cylinders and spheres.

Both built-in arms in a scene that mixes all kinds, turned about z and tilted: the fast checker
never frees a state the exact one refuses (random states, and states a hair's breadth from
contact on either side), fast-free motions are certified, the exact checker agrees with
pybullet on clear-cut states, and a refused start names the obstacle's kind. Worlds of
axis-aligned boxes keep the boxes' own path.
"""

from __future__ import annotations

import fcl
import numpy as np
import pytest

from temp_gym.problem import Problem, Workspace
from temp_gym.problem.obstacles import BOX, CYLINDER, KIND_NAMES, SPHERE, Box, Cylinder, Sphere
from temp_gym.worlds.arm.model import load_arm
from temp_gym.worlds.arm_world import generate_arm_task, near_surface
from temp_gym.worlds.collision.arm_enclosure import encloses, mesh_solids
from temp_gym.worlds.collision.arm_exact import (
    ArmExactChecker,
    base_collides,
    element_models,
    obstacle_objects,
    transform,
)
from temp_gym.worlds.collision.arm_fast import ArmSphereChecker
from temp_gym.worlds.collision.arm_fast_obstacles import OBSTACLE_COLUMNS, sphere_hits_shape
from temp_gym.worlds.collision.arm_obstacles import ArmObstacles, arm_obstacles
from temp_gym.worlds.collision.pybullet_reference import BULLET_MARGIN, PybulletArm
from temp_gym.worlds.robots import robot_spec

ROBOTS = ["kuka_iiwa14", "franka_panda"]


def turned(axis, angle: float) -> tuple[float, ...]:
    """The quaternion ``[x, y, z, w]`` of a turn by ``angle`` about ``axis``."""
    axis = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    return (*(np.sin(angle / 2) * axis), np.cos(angle / 2))


SCENE = [
    Box((0.0, 0.0, -0.06), (1.5, 1.5, 0.05)),  # the floor, axis-aligned
    Box((0.55, 0.1, 0.35), (0.15, 0.04, 0.3), turned((0, 0, 1), 0.6)),
    Box((-0.2, 0.6, 0.5), (0.2, 0.05, 0.12), turned((1, 1, 0), 0.7)),
    Cylinder((-0.5, -0.3, 0.4), 0.06, 0.9),
    Cylinder((0.1, -0.55, 0.55), 0.05, 0.6, turned((1, 0, 0.3), 1.1)),
    Cylinder((0.35, 0.4, 0.75), 0.04, 0.5, turned((0, 1, 0), np.pi / 2)),  # lying
    Sphere((0.4, 0.45, 0.7), 0.12),
    Sphere((-0.45, 0.2, 0.9), 0.08),
]
"""Every kind within both arms' reach: each is touched by some random states."""


@pytest.fixture(scope="module")
def scenes():
    """Per robot: the mixed workspace, its fast and exact checkers."""
    out = {}
    for robot in ROBOTS:
        spec = robot_spec(robot)
        workspace = Workspace.from_obstacles(robot, spec.joint_limits(), SCENE)
        out[robot] = (workspace, spec.make_checker(workspace),
                      spec.make_checker(workspace, exact=True))  # fmt: skip
    return out


def _uniform(workspace, count, seed):
    return np.random.default_rng(seed).uniform(*workspace.bounds, size=(count, workspace.dim))


def _touching(exact, state) -> list[int]:
    """The obstacles the exact checker finds in contact with a moving link of ``state``."""
    return [index for _, index, distance in exact.obstacle_report(state) if distance <= 0]


# ---- the sphere tests of the fast checker --------------------------------------------------------
def _random_rows(rng, count):
    """Obstacle rows (`OBSTACLE_COLUMNS`) of random kind, size and rotation about the origin."""
    rows = np.zeros((count, OBSTACLE_COLUMNS))
    kinds = rng.integers(0, 3, size=count)
    quaternions = rng.normal(size=(count, 4))
    workspace = Workspace.from_obstacles("kuka_iiwa14", robot_spec("kuka_iiwa14").joint_limits(), [
        Box((0, 0, 0), tuple(rng.uniform(0.02, 0.2, 3)), tuple(q / np.linalg.norm(q)))
        if kind == BOX else
        Cylinder((0, 0, 0), rng.uniform(0.02, 0.2), rng.uniform(0.04, 0.4),
                 tuple(q / np.linalg.norm(q)))
        if kind == CYLINDER else Sphere((0, 0, 0), rng.uniform(0.02, 0.2))
        for kind, q in zip(kinds, quaternions)
    ])  # fmt: skip
    obstacles = arm_obstacles(workspace)
    rows[:, 3:6] = obstacles.half_extents
    rows[:, 6] = obstacles.kinds
    rows[:, 7:] = obstacles.rotations.reshape(-1, 9)
    return rows, obstacles


def test_sphere_tests_agree_with_fcl_for_every_kind():
    """Sphere against oriented box, cylinder and sphere, by fcl's own collision test, for
    spheres from 5 cm inside to 5 cm outside (a 10 micrometre band at contact skipped)."""
    rng = np.random.default_rng(0)
    rows, obstacles = _random_rows(rng, 300)
    objects = obstacle_objects(obstacles)
    request = fcl.CollisionRequest()
    compared = np.zeros(3, dtype=int)
    for s, obstacle in enumerate(objects):
        for _ in range(20):
            center = rng.uniform(-0.4, 0.4, size=3)
            radius = rng.uniform(0.005, 0.1)
            ball = fcl.CollisionObject(fcl.Sphere(radius), fcl.Transform(center))
            distance = fcl.distance(ball, obstacle, fcl.DistanceRequest(), fcl.DistanceResult())
            if 0 <= distance < 1e-5:
                continue
            touching = fcl.collide(ball, obstacle, request, fcl.CollisionResult()) > 0
            assert touching == (distance < 0)
            assert sphere_hits_shape(*center, radius, rows, s) == touching, (s, center, radius)
            compared[int(obstacles.kinds[s])] += 1
    assert np.all(compared > 500), compared


def test_sphere_tests_are_closed():
    """Touching counts, for each kind: a sphere resting on a face, a cap, a side."""
    rows = np.zeros((3, OBSTACLE_COLUMNS))
    rows[:, 7:] = np.eye(3).reshape(9)
    rows[:, 3:6] = [[1.0, 2.0, 3.0], [1.0, 1.0, 2.0], [1.0, 1.0, 1.0]]
    rows[:, 6] = [BOX, CYLINDER, SPHERE]
    assert sphere_hits_shape(1.5, 0.0, 0.0, 0.5, rows, 0)
    assert not sphere_hits_shape(1.5, 0.0, 0.0, 0.25, rows, 0)
    assert sphere_hits_shape(0.0, 0.0, 2.5, 0.5, rows, 1)  # on the cap
    assert sphere_hits_shape(0.0, 1.5, 0.0, 0.5, rows, 1)  # on the side
    assert not sphere_hits_shape(1.0, 1.0, 2.5, 0.5, rows, 1)  # beyond the rim: 0.5 away
    assert sphere_hits_shape(0.0, 3.0, 0.0, 2.0, rows, 2)
    assert not sphere_hits_shape(0.0, 3.0, 0.0, 1.75, rows, 2)


# ---- axis-aligned boxes keep their path --------------------------------------------------------
def test_axis_aligned_boxes_are_read_from_their_corners_and_kept_on_the_box_list():
    spec = robot_spec("kuka_iiwa14")
    boxes = [obstacle for obstacle in SCENE if isinstance(obstacle, Box)]
    aligned = [Box(b.center, b.half_extents) for b in boxes]
    workspace = Workspace.from_obstacles(spec.name, spec.joint_limits(), aligned)
    ours = arm_obstacles(workspace)
    corners = ArmObstacles.from_corners(workspace.obstacle_lower, workspace.obstacle_upper)
    for name in ("centers", "half_extents", "kinds", "rotations", "lower", "upper"):
        assert np.array_equal(getattr(ours, name), getattr(corners, name)), name
    counts = spec.make_checker(workspace)._obstacle_arrays[2]
    assert counts[1:, 0].max() == len(boxes) and counts[:, 1].max() == 0
    mixed = spec.make_checker(Workspace.from_obstacles(spec.name, spec.joint_limits(), SCENE))
    # The floor is the one axis-aligned box; an upright cylinder is not a box.
    counts = mixed._obstacle_arrays[2]
    assert counts[1:, 0].max() == 1 and counts[1:, 1].max() == len(SCENE) - 1


@pytest.mark.parametrize("robot", ROBOTS)
def test_the_base_screen_keeps_every_obstacle_fcl_finds_touching_the_base(robot):
    """`base_collides` asks fcl only about obstacles whose bounding box meets the base's: the
    same answers as fcl, and the enclosure test fcl's surfaces need, on every obstacle, for
    small obstacles of each kind around the base (many of them touching it, a few inside it)."""
    arm = load_arm(robot_spec(robot).description)
    bodies = [fcl.CollisionObject(shape, transform(pose)) for shape, pose in element_models(arm)[0]]
    solids = mesh_solids(arm)[0]
    rng = np.random.default_rng(8)
    touching = 0
    for _ in range(300):
        center = rng.uniform([-0.25, -0.25, -0.1], [0.25, 0.25, 0.35])
        size = rng.uniform(0.005, 0.05)
        axis = rng.normal(size=3)
        obstacle = [Box(center, (size, size / 2, size), turned(axis, rng.uniform(0, 3))),
                    Cylinder(center, size, 3 * size, turned(axis, rng.uniform(0, 3))),
                    Sphere(center, size)][rng.integers(3)]  # fmt: skip
        workspace = Workspace.from_obstacles(robot, arm.joint_limits(), [obstacle])
        obstacles = arm_obstacles(workspace)
        (shape,) = obstacle_objects(obstacles)
        expected = any(fcl.collide(body, shape, fcl.CollisionRequest(), fcl.CollisionResult())
                       for body in bodies) or encloses(solids, np.eye(4), center)  # fmt: skip
        assert base_collides(arm, obstacles) == expected, obstacle
        touching += expected
    assert 20 < touching < 280  # both answers, many times


@pytest.mark.parametrize("robot", ROBOTS)
def test_each_body_lists_exactly_the_obstacles_within_its_reach(robot):
    """The broad phase, against a reference written per body and obstacle: body j lists the
    obstacles whose bounding box lies within its reach of the first joint (the joint offsets
    before it plus its root sphere) and half the resolution, boxes first, each by its row."""
    spec = robot_spec(robot)
    far = [Box((3.0, 0.0, 0.5), (0.1, 0.1, 0.1)), Sphere((0.0, -2.5, 0.3), 0.2),
           Cylinder((0.0, 0.0, 2.4), 0.1, 0.3, turned((1, 0, 0), 0.4))]  # fmt: skip
    rng = np.random.default_rng(3)
    for scene in (SCENE, far + SCENE[::-1], [SCENE[k] for k in rng.permutation(len(SCENE))]):
        workspace = Workspace.from_obstacles(robot, spec.joint_limits(), scene)
        checker = spec.make_checker(workspace)
        lists, counts, lowers, uppers = checker._obstacle_arrays[1:5]
        obstacles, trees = checker.obstacles, checker._trees
        node_centers, node_radii, body_start = trees[0], trees[1], trees[5]
        origins = checker.arm.chain.joint_origins[:, :3, 3]
        aligned = obstacles.axis_aligned
        for j in range(checker.arm.num_bodies):
            root = body_start[j]
            expected = {True: [], False: []}
            if j > 0 and root < body_start[j + 1]:
                reach = sum(np.linalg.norm(origins[k]) for k in range(1, j))
                reach += np.linalg.norm(node_centers[root]) + node_radii[root]
                for b in range(len(obstacles)):
                    nearest = np.clip(origins[0], obstacles.lower[b], obstacles.upper[b])
                    if np.linalg.norm(nearest - origins[0]) <= reach + checker.resolution / 2:
                        expected[bool(aligned[b])].append(b)
            chosen = expected[True] + expected[False]
            assert list(counts[j]) == [len(expected[True]), len(expected[False])], (j, scene)
            rows = [int(aligned[:b].sum()) if aligned[b] else int((~aligned[:b]).sum())
                    for b in chosen]  # fmt: skip
            assert list(lists[j, : len(chosen)]) == rows
            np.testing.assert_array_equal(lowers[j, :, : len(chosen)], obstacles.lower[chosen].T)
            np.testing.assert_array_equal(uppers[j, :, : len(chosen)], obstacles.upper[chosen].T)
        assert counts.sum(axis=1).max() == len(SCENE)  # the hand reaches it all, not `far`


@pytest.mark.parametrize("robot", ROBOTS)
def test_verdicts_do_not_depend_on_the_order_of_the_obstacles(robot):
    """Boxes and the other kinds live in two tables: an obstacle list that interleaves them
    (axis-aligned boxes among the rest) finds each obstacle's own row."""
    spec = robot_spec(robot)
    aligned = [Box((0.5, 0.1, 0.35), (0.15, 0.04, 0.3)), Box((-0.2, 0.55, 0.5), (0.2, 0.05, 0.2))]
    scene = SCENE + aligned
    order = np.random.default_rng(3).permutation(len(scene))
    shuffled = [scene[i] for i in order]
    assert not all(isinstance(o, Box) and o.orientation is None for o in shuffled[:3])
    first = spec.make_checker(Workspace.from_obstacles(robot, spec.joint_limits(), scene))
    second = spec.make_checker(Workspace.from_obstacles(robot, spec.joint_limits(), shuffled))
    limits = spec.joint_limits()
    states = np.random.default_rng(4).uniform(*limits, size=(4000, limits.shape[1]))
    free = first.states_free(states)
    assert 0.1 < free.mean() < 0.9
    assert np.array_equal(second.states_free(states), free)
    assert np.array_equal(second.states_free(states, 0.005), first.states_free(states, 0.005))


@pytest.mark.parametrize("robot", ROBOTS)
def test_a_box_turned_half_a_turn_is_checked_alike_on_the_general_path(robot):
    """A turn by pi about z maps ``(x, y, z)`` to ``(-x, -y, z)`` exactly: the same boxes,
    tested in their frames, get the box path's verdicts bit for bit."""
    spec = robot_spec(robot)
    arm = load_arm(spec.description)
    boxes = [Box((0.5, 0.1, 0.35), (0.15, 0.04, 0.3)), Box((-0.2, 0.55, 0.5), (0.2, 0.05, 0.2)),
             Box((0.0, -0.5, 0.6), (0.3, 0.05, 0.05))]  # fmt: skip
    half_turn = [Box(b.center, b.half_extents, (0.0, 0.0, 1.0, 0.0)) for b in boxes]
    plain = spec.make_checker(Workspace.from_obstacles(robot, arm.joint_limits(), boxes))
    general = spec.make_checker(Workspace.from_obstacles(robot, arm.joint_limits(), half_turn))
    assert general._obstacle_arrays[2][:, 0].max() == 0  # all on the general list
    states = np.random.default_rng(1).uniform(*arm.joint_limits(), size=(4000, arm.dim))
    free = plain.states_free(states)
    assert 0.1 < free.mean() < 0.95
    assert np.array_equal(general.states_free(states), free)
    assert np.array_equal(general.states_free(states, 0.005), plain.states_free(states, 0.005))
    ends = np.clip(states[:400] + np.random.default_rng(2).normal(0, 0.3, (400, arm.dim)),
                   *arm.joint_limits())  # fmt: skip
    edges = (states[:400], ends)
    assert np.array_equal(general.edges_free(*edges), plain.edges_free(*edges))


# ---- conservative against the exact checker ---------------------------------------------------
@pytest.mark.parametrize("robot", ROBOTS)
def test_the_fast_checker_never_frees_what_the_exact_one_refuses(scenes, robot):
    workspace, fast, exact = scenes[robot]
    states = _uniform(workspace, 4000, seed=3)
    fast_free, exact_free = fast.states_free(states), exact.states_free(states)
    assert not np.any(fast_free & ~exact_free)
    assert 0.2 < fast_free.mean() < 0.9
    assert (exact_free & ~fast_free).sum() < 0.1 * exact_free.sum()  # and close to it
    # Every obstacle of every kind is touched by some of the refused states.
    touched = set()
    for state in states[~exact_free][:400]:
        touched.update(_touching(exact, state))
    assert touched >= set(range(1, len(SCENE))), sorted(touched)


def _bisect(states_free, free, blocked, steps):
    """Bisect each segment ``free[i] -> blocked[i]`` by ``states_free``: ``(last free, first
    blocked)`` states, a hair's breadth apart."""
    low, high = free.copy(), blocked.copy()
    for _ in range(steps):
        middle = (low + high) / 2
        ok = states_free(middle)
        low[ok], high[~ok] = middle[ok], middle[~ok]
    return low, high


@pytest.mark.parametrize("robot", ROBOTS)
def test_near_contact_states_keep_the_fast_checker_conservative(scenes, robot):
    """States a few nanoradians from contact: those the exact checker has just entered, the
    fast one refuses; those at the edge of the fast model's contact, the exact one frees."""
    workspace, fast, exact = scenes[robot]
    states = _uniform(workspace, 600, seed=4)
    ok = exact.states_free(states)
    count = min(int(ok.sum()), int((~ok).sum()), 120)
    _, entered = _bisect(exact.states_free, states[ok][:count], states[~ok][:count], 28)
    touching = np.array([bool(_touching(exact, state)) for state in entered])
    assert touching.sum() > count / 2  # most met an obstacle, not the arm itself
    assert not fast.states_free(entered).any(), "fast freed a state exact refuses"
    ok = fast.states_free(states)
    count = min(int(ok.sum()), int((~ok).sum()), 120)
    edge, _ = _bisect(fast.states_free, states[ok][:count], states[~ok][:count], 28)
    assert fast.states_free(edge).all()
    assert exact.states_free(edge).all(), "fast freed a state exact refuses"
    kinds = {int(workspace.obstacle_kinds[report[0][1]])
             for report in map(exact.obstacle_report, edge) if report}  # fmt: skip
    assert kinds == {BOX, CYLINDER, SPHERE}, kinds


@pytest.mark.parametrize("robot", ROBOTS)
def test_fast_free_motions_are_certified(scenes, robot):
    workspace, fast, exact = scenes[robot]
    rng = np.random.default_rng(5)
    starts = _uniform(workspace, 300, seed=6)
    ends = np.clip(starts + rng.normal(0, 0.3, size=starts.shape), *workspace.bounds)
    free = fast.edges_free(starts, ends)
    assert free.any() and not free.all()
    for start, end in zip(starts[free][:12], ends[free][:12]):
        assert exact.edge_free(start, end)
    # Motions that end with the fast model 2 mm from contact, most near an obstacle.
    ok = fast.states_free(starts)
    count = min(int(ok.sum()), int((~ok).sum()), 40)
    grazing, _ = _bisect(lambda states: fast.states_free(states, 0.002), starts[ok][:count],
                         starts[~ok][:count], 28)  # fmt: skip
    free = fast.edges_free(starts[ok][:count], grazing)
    assert free.sum() >= 8  # not all: the straight motion may cross an obstacle on its way
    for start, end in zip(starts[ok][:count][free][:8], grazing[free][:8]):
        assert exact.edge_free(start, end)


# ---- the exact checker against pybullet, and its messages -------------------------------------
@pytest.mark.parametrize("robot", ROBOTS)
def test_the_exact_checker_agrees_with_pybullet_on_clear_cut_states(scenes, robot):
    """pybullet's boxes, cylinders and spheres, posed by their quaternions, against the links'
    convex hulls (which hold fcl's meshes): where pybullet puts the links 5 mm or more from an
    obstacle, fcl finds no contact with it, and every contact fcl finds, pybullet finds."""
    workspace, _, exact = scenes[robot]
    states = _uniform(workspace, 300, seed=7)
    clear = 0
    kinds = set()
    with PybulletArm(exact.arm, workspace) as bullet:
        for state in states:
            distances = np.array(bullet.obstacle_distances(state, moving_only=True))
            touching = _touching(exact, state)
            clear += int(np.sum(distances >= 0.005))
            assert not np.any(distances[touching] >= 0.005), (state, touching)
            assert np.all(distances[touching] <= BULLET_MARGIN), (state, touching)
            kinds.update(int(workspace.obstacle_kinds[b]) for b in touching)
    assert clear > 300
    assert kinds == {BOX, CYLINDER, SPHERE}


@pytest.mark.parametrize("kind", [BOX, CYLINDER, SPHERE])
def test_a_refused_start_names_the_obstacle_by_kind_and_index(scenes, kind):
    workspace, fast, exact = scenes["kuka_iiwa14"]
    states = _uniform(workspace, 3000, seed=8)
    goal = states[fast.states_free(states)][0]
    for state in states[~exact.states_free(states)]:
        report = exact.obstacle_report(state)
        index = report[0][1] if report else -1
        if index < 0 or report[0][2] > 0 or exact.self_collisions(state):
            continue
        if workspace.obstacle_kinds[index] != kind:
            continue
        assert exact.obstacle_name(index) == f"{KIND_NAMES[kind]} {index}"
        with pytest.raises(ValueError) as caught:
            Problem(workspace, state, goal, 0.1)
        message = str(caught.value)
        assert message.startswith("start:") and f"touches {KIND_NAMES[kind]} {index}" in message
        assert "\n" not in message
        return
    pytest.fail(f"no state touching a {KIND_NAMES[kind]} in the draws")


def test_tasks_near_a_surface_are_drawn_among_every_kind(scenes):
    workspace, _, exact = scenes["kuka_iiwa14"]
    problem = generate_arm_task(workspace, np.random.default_rng(9), "any", 0.1, near="both")
    ends = np.stack([problem.start, problem.goal])
    assert exact.states_free(ends).all()
    assert near_surface(exact, ends).all()


BASE_CUTTERS = [Cylinder((0.0, 0.0, 0.05), 0.3, 0.02, turned((1, 0, 0), 0.3)),
                Sphere((0.0, 0.0, 0.05), 0.15)]  # fmt: skip
"""A tilted disc and a ball through the iiwa's base, both crossing its surface."""


@pytest.mark.parametrize("obstacle", BASE_CUTTERS)
def test_an_obstacle_in_the_base_leaves_nothing_free(obstacle):
    """The base never moves: both checkers test it against every kind once, when built."""
    spec = robot_spec("kuka_iiwa14")
    workspace = Workspace.from_obstacles(spec.name, spec.joint_limits(), [obstacle])
    for checker in (spec.make_checker(workspace), spec.make_checker(workspace, exact=True)):
        assert not checker.base_free and "base link in collision" in checker.description
        assert not checker.states_free(_uniform(workspace, 20, seed=10)).any()
    away = Workspace.from_obstacles(spec.name, spec.joint_limits(), [
        Sphere((0.0, 0.0, -0.3), 0.02)])  # fmt: skip
    assert spec.make_checker(away).base_free and spec.make_checker(away, exact=True).base_free


def test_a_checker_takes_box_corners_or_obstacles_not_both():
    spec = robot_spec("kuka_iiwa14")
    arm = load_arm(spec.description)
    limits = arm.joint_limits()
    obstacles = arm_obstacles(Workspace.from_obstacles(spec.name, limits, SCENE))
    corners = (obstacles.lower, obstacles.upper)
    for checker in (ArmSphereChecker, ArmExactChecker):
        with pytest.raises(ValueError, match="^obstacles: give box_lower and box_upper"):
            checker(arm, limits, *corners, obstacles=obstacles)
        with pytest.raises(ValueError, match="^box_lower, box_upper: expected both"):
            checker(arm, limits)
        with pytest.raises(ValueError, match="^obstacles: expected ArmObstacles"):
            checker(arm, limits, obstacles=corners)
        assert (
            "3 boxes, 3 cylinders, 2 spheres"
            in checker(arm, limits, obstacles=obstacles).description
        )


ENCLOSED = [
    ("kuka_iiwa14", [0.0] * 7, Sphere((0.0, 0.0, 0.08), 0.01)),  # inside the base
    ("franka_panda", [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785], Box((0.0, 0.0, 0.08),
                                                                        (0.01, 0.01, 0.01))),
    ("kuka_iiwa14", [1.430598, -0.37844, -1.379407, 1.090258, -1.958088, -0.983826, 1.988579],
     Sphere((-0.028371723, -0.095068286, 0.762843844), 0.0271119)),  # inside link 3
    ("franka_panda", [-1.351467, 0.9124, 0.200139, -0.174474, -2.519122, 1.628964, -1.045913],
     Cylinder((0.096733343, -0.331628178, 0.524148338), 0.0054125, 0.0243695,
              (-0.7071068, 0.0, 0.0, -0.7071068))),  # inside link 4
]  # fmt: skip
"""Obstacles wholly inside a link's mesh, touching none of its triangles, and a pose."""


@pytest.mark.parametrize("robot, state, obstacle", ENCLOSED)
def test_an_obstacle_wholly_inside_a_link_is_a_collision(robot, state, obstacle):
    """fcl sees a mesh's surface only: the solid is tested where it finds no contact."""
    spec = robot_spec(robot)
    workspace = Workspace.from_obstacles(robot, spec.joint_limits(), [obstacle])
    fast, exact = spec.make_checker(workspace), spec.make_checker(workspace, exact=True)
    state = np.array(state)
    assert not exact.states_free(state[None])[0] and not fast.states_free(state[None])[0]
    report = exact.obstacle_report(state)
    with PybulletArm(exact.arm, workspace) as bullet:  # the independent referee agrees
        assert bullet.obstacle_distances(state)[0] < -0.02
    if not exact.base_free:
        assert "base link in collision" in fast.description
        return
    assert report and report[0][1] == 0 and report[0][2] < 0  # named, with a depth
    kind = {Box: "box", Cylinder: "cylinder", Sphere: "sphere"}[type(obstacle)]
    with pytest.raises(ValueError, match=f"^start: .*{report[0][0]}.*touches {kind} 0"):
        Problem(workspace, state, state, 0.1)
