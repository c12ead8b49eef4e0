import numpy as np
import pytest

from temp_gym import Problem, plan
from temp_gym.worlds.checkers import make_checker
from temp_gym.worlds.collision.point import PointBoxChecker
from temp_gym.worlds.generators import generate_problem

BOUNDS = np.array([[0.0, 0.0], [20.0, 20.0]])


def checker_with(lower, upper, bounds=BOUNDS):
    return PointBoxChecker(bounds, np.array(lower, float), np.array(upper, float))


def brute_force_segment_hits(a, b, lower, upper, samples=20001):
    t = np.linspace(0.0, 1.0, samples)[:, None]
    points = a + t * (b - a)
    return bool(np.any(np.all((points >= lower) & (points <= upper), axis=1)))


def test_states_inside_boxes_and_out_of_bounds_are_not_free():
    checker = checker_with([[9, 7]], [[11, 13]])
    states = np.array([[2, 2], [10, 10], [9, 7], [11, 13], [8.999, 10], [-0.1, 5], [5, 20.1]])
    assert checker.states_free(states).tolist() == [True, False, False, False, True, False, False]


def test_thin_box_caught_where_a_resolution_check_would_step_over_it():
    # A wall 1e-6 thick: interpolating the edge at any practical resolution misses it.
    checker = checker_with([[10 - 5e-7, 0]], [[10 + 5e-7, 20]])
    a, b = np.array([2.0, 5.0]), np.array([18.0, 6.0])
    interpolated = a + np.linspace(0, 1, 1000)[:, None] * (b - a)
    assert checker.states_free(interpolated).all()  # a resolution-based check would pass
    assert not checker.edge_free(a, b)
    assert not checker.path_free(np.stack([a, b]))


def test_corner_clipping_is_caught():
    checker = checker_with([[9, 9]], [[11, 11]])
    # The segment passes 1e-9 inside the corner (9, 11).
    a = np.array([8.0, 10.0 - 1e-9])
    b = np.array([10.0 - 1e-9, 12.0])
    assert not checker.edge_free(a, b)
    # Just outside the corner it is free.
    assert checker.edge_free(np.array([8.0, 10.0 + 1e-6]), np.array([10.0 - 1e-6, 12.0]))


def test_axis_parallel_segments():
    checker = checker_with([[9, 9]], [[11, 11]])
    assert not checker.edge_free(np.array([5.0, 10.0]), np.array([15.0, 10.0]))
    assert checker.edge_free(np.array([5.0, 8.0]), np.array([15.0, 8.0]))
    assert not checker.edge_free(np.array([10.0, 1.0]), np.array([10.0, 19.0]))


@pytest.mark.parametrize("dim", [2, 3])
def test_segment_test_agrees_with_dense_sampling(dim):
    rng = np.random.default_rng(7)
    bounds = np.array([np.zeros(dim), np.full(dim, 20.0)])
    centers = rng.uniform(0, 20, size=(6, dim))
    halves = rng.uniform(0.5, 3, size=(6, dim))
    checker = PointBoxChecker(bounds, centers - halves, centers + halves)
    starts = rng.uniform(0, 20, size=(400, dim))
    ends = starts + rng.normal(scale=4.0, size=(400, dim))
    ends = np.clip(ends, 0, 20)
    fast = checker.edges_free(starts, ends)
    disagreements = 0
    for a, b, free in zip(starts, ends, fast):
        hit = any(
            brute_force_segment_hits(a, b, lo, hi)
            for lo, hi in zip(centers - halves, centers + halves)
        )
        # Dense sampling can only miss hits, never invent them.
        assert not (free and hit)
        disagreements += (not free) and (not hit)
    assert disagreements <= 2  # grazing hits that 20,001 samples can miss


def test_batched_edges_match_single_edges_and_paths():
    checker = checker_with([[9, 0]], [[11, 15]])
    starts = np.array([[2.0, 2.0], [2.0, 18.0], [2.0, 17.0]])
    ends = np.array([[18.0, 2.0], [18.0, 18.0], [18.0, 10.0]])
    batch = checker.edges_free(starts, ends)
    assert batch.tolist() == [checker.edge_free(a, b) for a, b in zip(starts, ends)]
    assert batch.tolist() == [False, True, False]
    assert checker.path_free(np.array([[2.0, 2.0], [2.0, 18.0], [18.0, 18.0], [18.0, 2.0]]))
    assert not checker.path_free(np.array([[2.0, 2.0], [18.0, 2.0]]))


def test_shape_errors():
    checker = checker_with([[9, 9]], [[11, 11]])
    with pytest.raises(ValueError, match="states"):
        checker.states_free(np.zeros((4, 3)))


def test_union_volume_counts_overlaps_once_and_clips_to_the_bounds():
    from temp_gym.worlds.collision.point import union_volume

    bounds = np.array([[0.0, 0.0], [10.0, 10.0]])
    lower = np.array([[1.0, 1.0], [2.0, 2.0], [8.0, -5.0], [3.0, 3.0]])
    upper = np.array([[3.0, 3.0], [4.0, 4.0], [12.0, 1.0], [3.0, 9.0]])
    # 4 + 4 - 1 (overlap) + 2 * 1 (clipped at x = 10, y = 0) + 0 (a flat box)
    assert union_volume(lower, upper, *bounds) == pytest.approx(9.0)
    assert union_volume(lower[:0], upper[:0], *bounds) == 0.0
    outside = union_volume(np.array([[11.0, 11.0]]), np.array([[12.0, 12.0]]), *bounds)
    assert outside == 0.0
    cube = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    nested = union_volume(
        np.array([[0.0] * 3, [0.25] * 3]), np.array([[0.5] * 3, [1.0] * 3]), *cube
    )
    assert nested == pytest.approx(0.125 + 0.75**3 - 0.25**3)


def test_union_volume_estimates_when_the_exact_grid_would_be_too_big(monkeypatch):
    from temp_gym.worlds.collision import point

    rng = np.random.default_rng(1)
    centers = rng.uniform(4.0, 16.0, (60, 3))
    lower, upper = centers - 1.5, centers + 1.5
    bounds = np.array([[0.0] * 3, [20.0] * 3])
    exact = point.union_volume(lower, upper, *bounds)  # 120^3 cells: within the limit
    monkeypatch.setattr(point, "MAX_UNION_CELLS", 1000)
    estimate = point.union_volume(lower, upper, *bounds)
    assert estimate != exact  # the estimate ran ...
    assert estimate == pytest.approx(exact, rel=0.03)  # ... and agrees within its noise
    assert point.union_volume(lower, upper, *bounds) == estimate  # seeded: the same each call


def test_many_overlapping_3d_boxes_plan_without_exhausting_memory():
    # 1000 boxes cut each axis into ~2000 intervals: the exact grid would need 8e9 cells
    rng = np.random.default_rng(0)
    centers = rng.uniform(6.0, 14.0, (1000, 3))
    problem = Problem.from_dict({
        "robot": "point3d", "bounds": [[0.0] * 3, [20.0] * 3], "start": [1.0] * 3,
        "goal": [19.0] * 3, "goal_radius": 0.5,
        "obstacles": [{"center": c.tolist(), "half_extents": [1.0] * 3} for c in centers],
    })  # fmt: skip
    checker = make_checker(problem)
    assert 0.0 < checker.free_volume() < 8000.0
    result = plan(problem, planner="rrt_star", max_nodes=2000, stop_at_first=True)
    assert result.success


@pytest.mark.parametrize("robot", ["point2d", "point3d"])
def test_exact_free_volume_agrees_with_sampling(robot):
    problem = generate_problem(robot, np.random.default_rng(3), "challenging")
    checker = make_checker(problem)
    low, high = problem.bounds
    states = np.random.default_rng(0).uniform(low, high, size=(200_000, problem.dim))
    sampled = checker.states_free(states).mean() * np.prod(high - low)
    # 200k samples: the sampled volume's standard error is under 0.12% of the bounds' volume
    assert checker.free_volume() == pytest.approx(sampled, abs=0.005 * np.prod(high - low))


@pytest.mark.parametrize("robot", ["point2d", "point3d"])
def test_the_free_volume_floor_is_a_lower_bound(robot):
    rng = np.random.default_rng(8)
    for index in range(40):  # generated scenes, overlapping boxes among them
        problem = generate_problem(robot, rng, "challenging" if index % 2 else "easy")
        checker = make_checker(problem)
        assert checker.free_volume_floor() <= checker.free_volume()
    lower = np.array([[2.0, 2.0], [3.0, 3.0], [-4.0, 8.0]])  # an overlap, a box half outside
    upper = np.array([[4.0, 4.0], [5.0, 5.0], [1.0, 9.0]])
    checker = checker_with(lower, upper, bounds=np.array([[0.0, 0.0], [10.0, 10.0]]))
    assert checker.free_volume() == pytest.approx(100.0 - 7.0 - 1.0)
    assert checker.free_volume_floor() == pytest.approx(100.0 - 8.0 - 1.0)  # overlap twice


def _numpy_floor(checker: PointBoxChecker) -> float:
    """The floor's formula in numpy, as `PointBoxChecker` computed it before it was compiled."""
    low, high = checker._lower_bounds, checker._upper_bounds
    lower = np.clip(checker._box_lower, low, high)
    upper = np.clip(checker._box_upper, low, high)
    boxes = float(np.sum(np.prod(np.maximum(upper - lower, 0.0), axis=1)))
    total = float(np.prod(high - low))
    return total - boxes - 1e-9 * total


@pytest.mark.parametrize("dim", [2, 3])
def test_the_compiled_floor_is_numpys_formula_to_the_bit(dim):
    """Box counts across numpy's summation regimes (< 8, <= 128, split), boxes past the bounds."""
    rng = np.random.default_rng(dim)
    for count in [0, 1, 7, 8, 9, 15, 16, 17, 64, 127, 128, 129, 300, 1000]:
        for _ in range(5):
            lower = rng.uniform(-5.0, 22.0, (count, dim))
            upper = lower + rng.uniform(0.0, 6.0, (count, dim))
            bounds = np.array([[0.0] * dim, [20.0] * dim])
            checker = PointBoxChecker(bounds, lower, upper)
            assert checker.free_volume_floor() == _numpy_floor(checker)


def test_numpy_sum_written_out_equals_numpys_sum():
    from temp_gym.worlds.collision.point import _numpy_sum

    rng = np.random.default_rng(0)
    for count in list(range(300)) + [1000, 4099]:
        values = rng.standard_normal(count) * rng.uniform(0.1, 100.0, count)
        assert _numpy_sum(values, 0, count) == float(np.sum(values))


def _one_obstacle(kind: str) -> Problem:
    """A 2D problem with one obstacle at (10, 10): a box (``boxes``) or a disc (``shapes``)."""
    data = {"robot": "point2d", "bounds": [[0, 0], [20, 20]], "start": [2, 2],
            "goal": [18, 18], "goal_radius": 0.5,
            "obstacles": [{"center": [10, 10], "half_extents": [1, 1]}]}  # fmt: skip
    if kind == "shapes":
        data = {**data, "version": 2, "obstacles": [{"type": "sphere", "center": [10, 10],
                                                     "radius": 1}]}  # fmt: skip
    return Problem.from_dict(data)


@pytest.mark.parametrize("kind", ["boxes", "shapes"])
def test_a_nan_state_is_never_free_and_a_wrong_shape_is_named(kind):
    from temp_gym.worlds.checkers import certify_path

    problem = _one_obstacle(kind)
    nan = np.nan
    for exact in (False, True):
        checker = make_checker(problem.workspace, exact=exact)
        # NaN beside a coordinate outside every obstacle's range used to pass as free.
        free = checker.states_free([[nan, 0.5], [nan, nan], [1, 1]])
        assert free.tolist() == [False, False, True]
        assert not checker.edge_free([2, 2], [nan, nan])
        assert checker.edges_free([[2, 2], [2, 2]], [[nan, 2], [3, 2]]).tolist() == [False, True]
        assert not checker.path_free([[2, 2], [nan, nan], [3, 3]])
        with pytest.raises(ValueError, match=r"start: expected shape \(2,\), got \(1,\)"):
            checker.edge_free([2.0], [2.5])
        with pytest.raises(ValueError, match=r"end: expected shape \(2,\), got \(3,\)"):
            checker.edge_free([2, 2], [2.5, 2.5, 99])
    assert not certify_path(problem, [[2, 2], [nan, nan], [18, 18]])


@pytest.mark.parametrize("kind", ["boxes", "shapes"])
@pytest.mark.parametrize("exact", [False, True])
def test_malformed_inputs_are_refused_in_one_line(kind, exact):
    from temp_gym.worlds.checkers import certify_path

    problem = _one_obstacle(kind)
    checker = make_checker(problem.workspace, exact=exact)
    with pytest.raises(ValueError, match=r"^path: expected at least one state$"):
        checker.path_free(np.zeros((0, 2)))
    with pytest.raises(ValueError, match=r"^path: expected at least one state$"):
        certify_path(problem, [])
    with pytest.raises(ValueError, match=r"^path: expected real numbers"):
        certify_path(problem, "abc")
    with pytest.raises(ValueError, match=r"^path: expected an array of numbers, got None"):
        certify_path(problem, None)
    assert checker.states_free([]).shape == (0,)  # no states at all
    with pytest.raises(ValueError, match=r"^starts, ends: expected as many rows"):
        checker.edges_free(np.ones((3, 2)), np.ones((2, 2)))
    with pytest.raises(ValueError, match=r"^states: expected real numbers, got .*<U3"):
        checker.states_free("abc")
    with pytest.raises(ValueError, match=r"^states: expected real numbers, got .*complex128"):
        checker.states_free(np.array([[2, 2]], dtype=complex))
    with pytest.raises(ValueError, match=r"^start: expected real numbers, got .*bool"):
        checker.edge_free([True, True], [2, 2])
    with pytest.raises(ValueError, match=r"^path: expected an array of numbers, got ragged"):
        checker.path_free([[2, 2], [3]])
    # One state on either side is shared by every edge.
    assert checker.edges_free([[2, 2]], [[3, 3], [10, 10]]).tolist() == [True, False]
