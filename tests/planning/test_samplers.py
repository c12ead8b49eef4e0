import math

import numpy as np
import pytest
from scipy import stats

from temp_gym.planning import GoalBiasedSampler, InformedSampler, UniformSampler
from temp_gym.planning.samplers import rotation_to_world


def draw(sampler, rng, count):
    return np.array([sampler.sample(rng) for _ in range(count)])


@pytest.mark.parametrize("dim", [2, 3, 7])
def test_informed_samples_fill_the_hyperspheroid_uniformly(dim):
    rng = np.random.default_rng(dim)
    start = rng.uniform(-3, 3, dim)
    goal = rng.uniform(-3, 3, dim)
    bounds = np.array([np.full(dim, -100.0), np.full(dim, 100.0)])  # no rejection
    sampler = InformedSampler(bounds, start, goal, goal_radius=0.3)
    best_cost = 1.4 * np.linalg.norm(goal - start)
    sampler.set_best_cost(best_cost)
    samples = draw(sampler, rng, 4000)
    # inside the ellipsoid: focal distances sum to at most the transverse diameter
    focal = np.linalg.norm(samples - start, axis=1) + np.linalg.norm(samples - goal, axis=1)
    assert np.all(focal <= best_cost + 0.3 + 1e-9)
    ball = sampler.to_unit_ball(samples)
    radii = np.linalg.norm(ball, axis=1)
    assert np.all(radii <= 1 + 1e-9)
    # uniform in the ball: radius^d is uniform on [0, 1] and the orthants are equally likely
    assert stats.kstest(radii**dim, "uniform").pvalue > 1e-3
    axes = min(dim, 3)
    orthant = ((ball[:, :axes] > 0) * (1 << np.arange(axes))).sum(axis=1)
    counts = np.bincount(orthant, minlength=2**axes)
    assert stats.chisquare(counts).pvalue > 1e-3


def test_rotation_maps_first_axis_to_the_goal_direction():
    rng = np.random.default_rng(0)
    for dim in (2, 3, 7):
        start, goal = rng.normal(size=dim), rng.normal(size=dim)
        c = rotation_to_world(start, goal)
        np.testing.assert_allclose(c @ c.T, np.eye(dim), atol=1e-12)
        assert np.linalg.det(c) == pytest.approx(1.0)
        direction = (goal - start) / np.linalg.norm(goal - start)
        np.testing.assert_allclose(c[:, 0], direction, atol=1e-12)


def test_informed_samples_respect_the_bounds_and_fall_back_to_uniform_without_a_cost():
    bounds = np.array([[0.0, 0.0], [20.0, 20.0]])
    sampler = InformedSampler(bounds, np.array([1.0, 1.0]), np.array([19.0, 19.0]), 0.5)
    rng = np.random.default_rng(0)
    uniform = draw(sampler, rng, 2000)
    assert stats.kstest(uniform[:, 0] / 20.0, "uniform").pvalue > 1e-3
    sampler.set_best_cost(30.0)
    informed = draw(sampler, rng, 2000)
    assert np.all((informed >= 0) & (informed <= 20))
    start, goal = sampler.start, sampler.goal
    focal = np.linalg.norm(informed - start, axis=1) + np.linalg.norm(informed - goal, axis=1)
    assert np.all(focal <= 30.5 + 1e-9)


def test_uniform_and_goal_bias():
    bounds = np.array([[0.0, -1.0, 5.0], [1.0, 1.0, 6.0]])
    rng = np.random.default_rng(1)
    goal = np.array([0.5, 0.5, 5.5])
    sampler = GoalBiasedSampler(UniformSampler(bounds), goal, 0.2)
    samples = draw(sampler, rng, 5000)
    assert np.all((samples >= bounds[0]) & (samples <= bounds[1]))
    fraction = np.mean(np.all(samples == goal, axis=1))
    assert abs(fraction - 0.2) < 0.03
    with pytest.raises(ValueError, match="goal_bias"):
        GoalBiasedSampler(UniformSampler(bounds), goal, 1.5)


def test_same_generator_seed_same_samples():
    bounds = np.array([[0.0, 0.0], [20.0, 20.0]])
    a, b = UniformSampler(bounds), UniformSampler(bounds)
    first = draw(a, np.random.default_rng(7), 300)
    second = draw(b, np.random.default_rng(7), 300)
    np.testing.assert_array_equal(first, second)
    # a new generator discards the old batch, so re-seeding reproduces the stream
    again = draw(a, np.random.default_rng(7), 300)
    np.testing.assert_array_equal(first, again)
    assert not math.isnan(first.sum())


def test_a_first_solution_run_never_computes_the_informed_rotation(monkeypatch):
    from temp_gym import Problem, plan
    from temp_gym.planning import samplers

    def refuse(*args):
        raise AssertionError("rotation_to_world was computed")

    problem = Problem.load("examples/point2d.json")
    plan(problem, planner="informed_rrt_star", max_nodes=50)  # the process's warm-up runs first
    monkeypatch.setattr(samplers, "rotation_to_world", refuse)
    assert plan(problem, planner="informed_rrt_star", stop_at_first=True).success
    with pytest.raises(AssertionError, match="rotation_to_world"):  # the anytime run needs it
        plan(problem, planner="informed_rrt_star", max_nodes=300)
