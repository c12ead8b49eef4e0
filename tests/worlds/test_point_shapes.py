"""temp_gym.worlds.collision.point_shapes: point robots among rotated boxes, cylinders, spheres.

Every verdict is compared with an independent reference: a rotated box as the convex hull of
its corners (scipy's Rotation places them, scipy's ConvexHull gives the faces), a cylinder by
the cross product with its axis, a sphere by its distance. Points within `BAND` of a surface
are left out of the comparisons (the checker counts some of them as touching, on purpose).
"""

from __future__ import annotations

import numba
import numpy as np
import pytest
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

from temp_gym import Problem, plan
from temp_gym.problem import Workspace
from temp_gym.problem.obstacles import Box, Cylinder, Sphere
from temp_gym.worlds.checkers import certify_path, make_checker
from temp_gym.worlds.collision.compiled import motion_free
from temp_gym.worlds.collision.point import PointBoxChecker
from temp_gym.worlds.collision.point_shapes import PointShapeChecker, point_checker
from temp_gym.worlds.robots import robot_spec

BAND = 1e-7
"""How close to a surface a sample may be and still be compared."""


# ---- the independent reference ---------------------------------------------------------------
def _rotation(obstacle, dim: int) -> np.ndarray:
    turn = getattr(obstacle, "orientation", None)
    if dim == 2:
        return Rotation.from_euler("z", 0.0 if turn is None else turn).as_matrix()[:2, :2]
    return np.eye(3) if turn is None else Rotation.from_quat(turn).as_matrix()


def distance_bound(obstacle, points: np.ndarray) -> np.ndarray:
    """Per point: negative inside, positive outside, and never above the true distance.

    A box's is the largest signed distance to the planes of its hull's faces; a cylinder's
    and a sphere's are their true signed distances.
    """
    dim = points.shape[1]
    center = np.asarray(obstacle.center, float)
    if isinstance(obstacle, Sphere):
        return np.linalg.norm(points - center, axis=1) - obstacle.radius
    rotation = _rotation(obstacle, dim)
    if isinstance(obstacle, Cylinder):
        axis = rotation @ np.array([0.0, 0.0, 1.0])
        offset = points - center
        radial = np.linalg.norm(np.cross(offset, axis), axis=1) - obstacle.radius
        along = np.abs(offset @ axis) - obstacle.length / 2
        outside = np.hypot(np.maximum(radial, 0.0), np.maximum(along, 0.0))
        return np.where((radial <= 0) & (along <= 0), np.maximum(radial, along), outside)
    signs = np.array(np.meshgrid(*[[-1.0, 1.0]] * dim, indexing="ij")).reshape(dim, -1).T
    corners = center + (signs * np.asarray(obstacle.half_extents)) @ rotation.T
    hull = ConvexHull(corners)
    return np.max(points @ hull.equations[:, :dim].T + hull.equations[:, dim], axis=1)


def random_obstacles(rng: np.random.Generator, dim: int, count: int) -> list:
    obstacles = []
    for i in range(count):
        center = tuple(rng.uniform(3.0, 17.0, dim))
        kind = i % 3 if dim == 3 else (0, 2)[i % 2]
        if kind == 0:
            turn = float(rng.uniform(-np.pi, np.pi)) if dim == 2 else tuple(Rotation.random(
                random_state=rng).as_quat())  # fmt: skip
            obstacles.append(Box(center, tuple(rng.uniform(0.3, 3.0, dim)), turn))
        elif kind == 1:
            turn = tuple(Rotation.random(random_state=rng).as_quat())
            obstacles.append(Cylinder(center, rng.uniform(0.3, 2.5), rng.uniform(0.5, 6.0), turn))
        else:
            obstacles.append(Sphere(center, rng.uniform(0.3, 2.5)))
    return obstacles


def world(obstacles: list, dim: int) -> Workspace:
    robot = "point2d" if dim == 2 else "point3d"
    return Workspace.from_obstacles(robot, [[0.0] * dim, [20.0] * dim], obstacles)


def segment_reference(obstacles: list, a: np.ndarray, b: np.ndarray, samples: int = 4001):
    """``True`` a hit, ``False`` a miss, None too close to call by subdividing."""
    points = a + np.linspace(0.0, 1.0, samples)[:, None] * (b - a)
    spacing = np.linalg.norm(b - a) / (samples - 1)
    least = min(distance_bound(obstacle, points).min() for obstacle in obstacles)
    if least < -BAND:
        return True
    if least > spacing / 2 + BAND:
        return False
    return None


# ---- states and segments against the reference ----------------------------------------------
@pytest.mark.parametrize("dim", [2, 3])
def test_states_agree_with_the_reference(dim):
    rng = np.random.default_rng(dim)
    obstacles = random_obstacles(rng, dim, 9)
    checker = point_checker(world(obstacles, dim))
    assert isinstance(checker, PointShapeChecker)
    states = rng.uniform(0.0, 20.0, (30_000, dim))
    inside = np.zeros(len(states), bool)
    near = np.zeros(len(states), bool)
    for obstacle in obstacles:
        bound = distance_bound(obstacle, states)
        inside |= bound <= 0
        near |= np.abs(bound) <= BAND
    free = checker.states_free(states)
    assert inside.sum() > 1000 and (~inside).sum() > 1000  # both sides are exercised
    np.testing.assert_array_equal(free[~near], ~inside[~near])


@pytest.mark.parametrize("dim", [2, 3])
def test_segments_agree_with_fine_subdivision(dim):
    rng = np.random.default_rng(10 + dim)
    obstacles = random_obstacles(rng, dim, 6 if dim == 2 else 15)
    checker = point_checker(world(obstacles, dim))
    starts = rng.uniform(0.0, 20.0, (300, dim))
    ends = np.clip(starts + rng.normal(scale=4.0, size=starts.shape), 0.0, 20.0)
    free = checker.edges_free(starts, ends)
    verdicts = [segment_reference(obstacles, a, b) for a, b in zip(starts, ends)]
    called = [(f, v) for f, v in zip(free, verdicts) if v is not None]
    assert len(called) > 250
    assert all(f == (not v) for f, v in called)
    assert 40 < sum(v for _, v in called) < len(called) - 40  # hits and misses both


def _surface_point(obstacle, direction: np.ndarray) -> np.ndarray:
    """Where the ray from the obstacle's center along ``direction`` leaves it (bisection)."""
    center = np.asarray(obstacle.center, float)
    inside, outside = 0.0, 20.0
    for _ in range(60):
        middle = 0.5 * (inside + outside)
        if distance_bound(obstacle, (center + middle * direction)[None])[0] <= 0:
            inside = middle
        else:
            outside = middle
    return center + inside * direction


def test_chords_just_inside_each_kind_hit_and_those_just_outside_agree_with_the_reference():
    turn = tuple(Rotation.from_euler("xyz", [0.3, 0.5, 0.7]).as_quat())
    rng = np.random.default_rng(0)
    for obstacle in (Box((10.0, 10.0, 10.0), (1.0, 2.0, 3.0), turn),
                     Cylinder((10.0, 10.0, 10.0), 2.0, 5.0, turn),
                     Sphere((10.0, 10.0, 10.0), 2.0)):  # fmt: skip
        checker = point_checker(world([obstacle], 3))
        called = 0
        for _ in range(30):
            direction = rng.normal(size=3)
            direction /= np.linalg.norm(direction)
            surface = _surface_point(obstacle, direction)
            tangent = np.cross(direction, rng.normal(size=3))
            tangent /= np.linalg.norm(tangent)
            inward, outward = surface - 1e-4 * direction, surface + 1e-3 * direction
            assert not checker.edge_free(inward - 3.0 * tangent, inward + 3.0 * tangent)
            a, b = outward - 3.0 * tangent, outward + 3.0 * tangent
            verdict = segment_reference([obstacle], a, b, 20_001)
            if verdict is not None:
                called += 1
                assert checker.edge_free(a, b) == (not verdict), (obstacle, outward)
        assert called >= 20


# ---- touching, zero length, parallel segments -------------------------------------------------
def test_touching_counts_as_collision():
    turn = tuple(Rotation.from_euler("z", 0.4).as_quat())
    box = Box((10.0, 10.0, 10.0), (1.0, 2.0, 3.0), turn)
    cylinder = Cylinder((5.0, 5.0, 5.0), 1.5, 4.0, turn)
    sphere = Sphere((15.0, 15.0, 15.0), 2.0)
    checker = point_checker(world([box, cylinder, sphere], 3))
    rotation = Rotation.from_quat(turn)
    corner = np.array(box.center) + rotation.apply([1.0, 2.0, 3.0])
    rim = np.array(cylinder.center) + rotation.apply([1.5, 0.0, 2.0])
    pole = np.array([15.0, 15.0, 17.0])
    outwards = (rotation.apply([1.0, 1.0, 1.0]), rotation.apply([1.0, 0.0, 1.0]), [0, 0, 1.0])
    for point, outward in zip((corner, rim, pole), outwards):
        assert not checker.states_free(point)[0]
        assert checker.states_free(point + 1e-6 * np.asarray(outward))[0]
        # a segment that only touches, along the surface's outside
        assert not checker.edge_free(point + np.asarray(outward), point)
    flat = point_checker(world([Sphere((10.0, 10.0), 2.0)], 2))
    assert not flat.edge_free(np.array([8.0, 5.0]), np.array([8.0, 15.0]))  # tangent at (8, 10)
    assert flat.edge_free(np.array([7.999999, 5.0]), np.array([7.999999, 15.0]))


@pytest.mark.parametrize("dim", [2, 3])
def test_zero_length_segments_are_their_state(dim):
    rng = np.random.default_rng(20 + dim)
    obstacles = random_obstacles(rng, dim, 9)
    checker = point_checker(world(obstacles, dim))
    states = rng.uniform(0.0, 20.0, (3000, dim))
    np.testing.assert_array_equal(checker.edges_free(states, states), checker.states_free(states))
    assert [checker.path_free(s[None]) for s in states[:200]] == list(
        checker.states_free(states[:200])
    )


def test_segments_parallel_to_the_world_and_to_a_cylinder_axis():
    up = tuple(Rotation.from_euler("x", 0.0).as_quat())  # identity: the axis is world z
    checker = point_checker(world([Cylinder((10.0, 10.0, 10.0), 2.0, 4.0, up)], 3))
    along = np.array([[10.0, 11.9, 1.0], [10.0, 11.9, 19.0]])  # parallel to the axis, inside
    assert not checker.edge_free(*along)
    assert checker.edge_free(along[0] + [0, 0.2, 0], along[1] + [0, 0.2, 0])  # outside the rim
    across = np.array([[1.0, 10.0, 11.99], [19.0, 10.0, 11.99]])  # under the top cap
    assert not checker.edge_free(*across)
    assert checker.edge_free(across[0] + [0, 0, 0.02], across[1] + [0, 0, 0.02])  # above it
    tilted = point_checker(world([Box((10.0, 10.0), (1.0, 1.0), np.pi / 4)], 2))
    reach = np.sqrt(2.0)  # a diamond: its corners on the axes through the center
    assert not tilted.edge_free(np.array([1.0, 10.0 + reach]), np.array([19.0, 10.0 + reach]))
    assert tilted.edge_free(np.array([1.0, 10.0 + reach + 1e-6]), np.array([19.0, 11.5]))
    assert not tilted.edge_free(np.array([10.0, 1.0]), np.array([10.0, 19.0]))


def test_rotating_the_world_rotates_the_answers():
    rng = np.random.default_rng(4)
    obstacles = random_obstacles(rng, 3, 9)
    turn = Rotation.from_euler("xyz", [0.4, -0.9, 1.3])
    middle = np.full(3, 10.0)

    def turned(obstacle):
        center = tuple(middle + turn.apply(np.asarray(obstacle.center) - middle))
        if isinstance(obstacle, Sphere):
            return Sphere(center, obstacle.radius)
        own = Rotation.from_quat(obstacle.orientation)
        quat = tuple((turn * own).as_quat())
        if isinstance(obstacle, Box):
            return Box(center, obstacle.half_extents, quat)
        return Cylinder(center, obstacle.radius, obstacle.length, quat)

    bounds = [[-20.0] * 3, [40.0] * 3]
    first = PointShapeChecker(Workspace.from_obstacles("point3d", bounds, obstacles))
    second = PointShapeChecker(
        Workspace.from_obstacles("point3d", bounds, [turned(o) for o in obstacles])
    )
    states = rng.uniform(0.0, 20.0, (20_000, 3))
    moved = middle + turn.apply(states - middle)
    agree = first.states_free(states) == second.states_free(moved)
    assert agree.all() and not first.states_free(states).all()
    ends = np.clip(states[:2000] + rng.normal(scale=4.0, size=(2000, 3)), 0.0, 20.0)
    moved_ends = middle + turn.apply(ends - middle)
    np.testing.assert_array_equal(
        first.edges_free(states[:2000], ends), second.edges_free(moved[:2000], moved_ends)
    )


# ---- the compiled path, volumes, the spec ------------------------------------------------------
@numba.njit(cache=False)
def _motions_free(context, starts, ends):
    out = np.empty(starts.shape[0], np.bool_)
    for i in range(starts.shape[0]):
        out[i] = motion_free(context, starts[i], ends[i])
    return out


@pytest.mark.parametrize("dim", [2, 3])
def test_the_compiled_motion_kernel_is_the_python_check(dim):
    rng = np.random.default_rng(30 + dim)
    checker = point_checker(world(random_obstacles(rng, dim, 9), dim))
    starts = rng.uniform(-1.0, 21.0, (3000, dim))
    ends = np.clip(starts + rng.normal(scale=4.0, size=starts.shape), -1.0, 21.0)
    compiled = _motions_free(checker.compiled_context(), starts, ends)
    np.testing.assert_array_equal(compiled, checker.edges_free(starts, ends))
    assert 0 < compiled.sum() < len(compiled)


@pytest.mark.parametrize("dim", [2, 3])
def test_free_volume_is_close_and_its_floor_is_below_it(dim):
    rng = np.random.default_rng(40 + dim)
    for count in (3, 9, 30):
        workspace = world(random_obstacles(rng, dim, count), dim)
        checker = point_checker(workspace)
        states = np.random.default_rng(1).uniform(0.0, 20.0, (200_000, dim))
        sampled = checker.states_free(states).mean() * 20.0**dim
        assert checker.free_volume() == pytest.approx(sampled, abs=0.02 * 20.0**dim)
        assert checker.free_volume() == checker.free_volume()  # seeded
        assert checker.free_volume_floor() <= checker.free_volume()
    covered = point_checker(world([Sphere((10.0,) * dim, 30.0)], dim))  # all of the bounds
    assert covered.free_volume_floor() < covered.free_volume() == 0.0


def test_axis_aligned_worlds_keep_the_box_checker():
    boxes = world([Box((5.0, 5.0), (1.0, 1.0)), Box((9.0, 9.0), (2.0, 1.0))], 2)
    assert type(make_checker(boxes)) is PointBoxChecker
    assert type(make_checker(boxes, exact=True)) is PointBoxChecker
    mixed = world([Box((5.0, 5.0), (1.0, 1.0)), Sphere((9.0, 9.0), 1.0)], 2)
    assert type(make_checker(mixed)) is PointShapeChecker


def test_unrotated_boxes_in_a_mixed_world_answer_as_the_box_checker_does():
    rng = np.random.default_rng(50)
    centers = rng.uniform(3.0, 17.0, (8, 3))
    halves = rng.uniform(0.3, 3.0, (8, 3))
    boxes = [Box(tuple(c), tuple(h)) for c, h in zip(centers, halves)]
    far = Sphere((100.0, 100.0, 100.0), 1.0)  # out of bounds: only makes the world mixed
    bounds = [[0.0] * 3, [20.0] * 3]
    mixed = PointShapeChecker(Workspace.from_obstacles("point3d", bounds, [*boxes, far]))
    alone = PointBoxChecker(np.array(bounds), centers - halves, centers + halves)
    states = rng.uniform(0.0, 20.0, (20_000, 3))
    states[:1000] = np.round(states[:1000] * 4) / 4  # on faces and corners often
    np.testing.assert_array_equal(mixed.states_free(states), alone.states_free(states))
    ends = np.round(rng.uniform(0.0, 20.0, (20_000, 3)) * 4) / 4
    np.testing.assert_array_equal(mixed.edges_free(states, ends), alone.edges_free(states, ends))


def test_a_start_inside_an_obstacle_names_it():
    data = {"version": 2, "robot": "point3d", "bounds": [[0.0] * 3, [20.0] * 3],
            "start": [10.0, 10.0, 12.0], "goal": [1.0, 1.0, 1.0], "goal_radius": 0.5,
            "obstacles": [{"type": "sphere", "center": [3.0, 17.0, 3.0], "radius": 1.0},
                          {"type": "cylinder", "center": [10.0, 10.0, 10.0], "radius": 1.0,
                           "length": 4.0, "orientation": [0.0, 0.0, 0.0, 1.0]}]}  # fmt: skip
    with pytest.raises(ValueError, match=r"^start: .* is in collision with obstacle 1 \(a "
                       r"cylinder\) \(analytic point test, 1 cylinder, 1 sphere\)$"):  # fmt: skip
        Problem.from_dict(data)
    data["start"] = [10.0, 10.0, 12.01]  # just above the cap
    assert Problem.from_dict(data).start[2] == 12.01


def test_a_plan_among_every_kind_is_certified():
    turn = tuple(Rotation.from_euler("z", 0.3).as_quat())
    obstacles = [
        Box((10.0, 10.0, 10.0), (1.0, 8.0, 8.0), turn),
        Cylinder((5.0, 5.0, 10.0), 2.0, 18.0),
        Sphere((15.0, 15.0, 10.0), 3.0),
    ]
    workspace = world(obstacles, 3)
    problem = Problem(workspace, [2.0, 10.0, 10.0], [18.0, 10.0, 10.0], 0.5)
    assert not make_checker(problem).edge_free(problem.start, problem.goal)
    for planner in ("rrt_star", "informed_rrt_star"):
        result = plan(problem, planner=planner, max_nodes=3000, seed=0, stop_at_first=True)
        assert result.success and certify_path(problem, result.path)
    assert robot_spec("point3d").make_checker(workspace).path_free(result.path)
