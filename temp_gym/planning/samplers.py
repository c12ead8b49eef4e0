"""Samplers: where the tree's samples come from. All draw from an explicit generator.

* `UniformSampler`: uniform in the bounds.
* `InformedSampler`: uniform until a solution exists, then uniform in the informed set, the
  prolate hyperspheroid of the best cost (direct sampling, Gammell et al. 2014, "Informed
  RRT*", Alg. 2), any dimension; samples outside the bounds are rejected.
* `GoalBiasedSampler`: the goal with probability ``p``, otherwise another sampler.

Samplers draw in batches and serve them one by one (a numpy call per sample would dominate
the planner's time). A batch belongs to the generator that drew it: passing a different
generator, or calling `reset`, discards it, so "same seed, same samples" holds.

Examples:
    >>> rng = np.random.default_rng(0)
    >>> sampler = GoalBiasedSampler(UniformSampler(problem.bounds), problem.goal, 0.05)
    >>> sampler.sample(rng).shape
    (2,)
"""

from __future__ import annotations

import functools
import math

import numpy as np

_BATCH = 128
_MAX_REJECTION_BATCHES = 64


class _BufferedSampler:
    """Serves rows of a batch drawn by `_draw_batch` from the caller's generator."""

    dim: int

    def __init__(self) -> None:
        self._buffer = np.empty((0, 0))
        self._next = 0
        self._rng: np.random.Generator | None = None

    def reset(self) -> None:
        """Discard buffered samples (call when re-seeding)."""
        self._buffer = np.empty((0, 0))
        self._next = 0
        self._rng = None

    def _draw_batch(self, rng: np.random.Generator) -> np.ndarray:
        raise NotImplementedError

    def draw_batch(self, rng: np.random.Generator) -> np.ndarray:
        """The next batch ``(rows, d)`` that `sample` would serve row by row, drawn now.

        For loops that serve the rows themselves (the compiled anytime loop); it leaves the
        sampler's own buffer alone.
        """
        return np.ascontiguousarray(self._draw_batch(rng), dtype=np.float64)

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        """Return one state of shape ``(d,)`` (a fresh array)."""
        if rng is not self._rng or self._next >= len(self._buffer):
            self._rng = rng
            self._buffer = self._draw_batch(rng)
            self._next = 0
        row = self._buffer[self._next].copy()
        self._next += 1
        return row


class UniformSampler(_BufferedSampler):
    """Uniform samples in the box ``bounds = [lower, upper]`` of shape ``(2, d)``."""

    def __init__(self, bounds: np.ndarray) -> None:
        super().__init__()
        bounds = np.asarray(bounds, dtype=np.float64)
        if bounds.ndim != 2 or bounds.shape[0] != 2 or np.any(bounds[0] >= bounds[1]):
            raise ValueError(f"bounds: expected (2, d) with lower < upper, got {bounds.tolist()}")
        self.low, self.high = bounds[0].copy(), bounds[1].copy()
        self.dim = bounds.shape[1]

    def _draw_batch(self, rng: np.random.Generator) -> np.ndarray:
        return rng.uniform(self.low, self.high, size=(_BATCH, self.dim))


def sample_unit_ball(rng: np.random.Generator, count: int, dim: int) -> np.ndarray:
    """``count`` points uniform in the unit ``dim``-ball (Gaussian direction, ``u^(1/d)`` norm)."""
    directions = rng.standard_normal((count, dim))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    radii = rng.random(count) ** (1.0 / dim)
    return directions * radii[:, None]


def rotation_to_world(start: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """Rotation ``C`` taking the first axis to the start-goal direction (Gammell et al. 2014).

    ``C = U diag(1, ..., 1, det U det V) V^T`` from the SVD ``U S V^T`` of ``a1 e1^T``.
    """
    dim = len(start)
    difference = np.asarray(goal, dtype=np.float64) - np.asarray(start, dtype=np.float64)
    distance = float(np.linalg.norm(difference))
    if distance == 0.0:  # no absolute floor: worlds may be 1e-30 across
        return np.eye(dim)
    a1 = difference / distance
    m = np.outer(a1, np.eye(dim)[0])
    u, _, vt = np.linalg.svd(m)
    middle = np.ones(dim)
    middle[-1] = np.linalg.det(u) * np.linalg.det(vt)
    return u @ np.diag(middle) @ vt


class InformedSampler(_BufferedSampler):
    """Uniform in the bounds until `set_best_cost`, then uniform in the informed set.

    With the goal a ball of radius ``r`` around ``goal``, a path of cost ``c`` ending in it
    can only be improved through states with ``|x - start| + |x - goal| <= c + r``, so the
    hyperspheroid has foci ``start`` and ``goal`` and transverse diameter ``c + r``.

    Args:
        bounds: ``(2, d)`` bounds; informed samples outside them are rejected.
        start: The tree root.
        goal: Centre of the goal region.
        goal_radius: Radius of the goal region.
    """

    def __init__(
        self, bounds: np.ndarray, start: np.ndarray, goal: np.ndarray, goal_radius: float
    ) -> None:
        super().__init__()
        self.uniform = UniformSampler(bounds)
        self.dim = self.uniform.dim
        self.start = np.asarray(start, dtype=np.float64).copy()
        self.goal = np.asarray(goal, dtype=np.float64).copy()
        self.goal_radius = float(goal_radius)
        self.centre = (self.start + self.goal) / 2.0
        self.c_min = float(np.linalg.norm(self.goal - self.start))
        self.best_cost = math.inf
        self._scales = np.full(self.dim, math.inf)

    @functools.cached_property
    def rotation(self) -> np.ndarray:
        """`rotation_to_world` of start and goal, computed on first use.

        A planner that stops at its first solution never samples the informed set, so it never
        pays for the SVD.
        """
        return rotation_to_world(self.start, self.goal)

    def set_best_cost(self, cost: float) -> None:
        """Shrink the informed set to the solution cost ``cost`` (inf = sample uniformly)."""
        cost = float(cost)
        if cost == self.best_cost:
            return
        self.best_cost = cost
        self.reset()
        if math.isfinite(cost):
            diameter = max(cost + self.goal_radius, self.c_min)
            self._scales = np.full(self.dim, math.sqrt(diameter**2 - self.c_min**2) / 2.0)
            self._scales[0] = diameter / 2.0

    def to_unit_ball(self, states: np.ndarray) -> np.ndarray:
        """Map states of the current informed set back to the unit ball (inverse transform)."""
        return ((np.asarray(states) - self.centre) @ self.rotation) / self._scales

    def _draw_batch(self, rng: np.random.Generator) -> np.ndarray:
        if not math.isfinite(self.best_cost):
            return self.uniform._draw_batch(rng)
        low, high = self.uniform.low, self.uniform.high
        for _ in range(_MAX_REJECTION_BATCHES):
            ball = sample_unit_ball(rng, _BATCH, self.dim)
            states = (ball * self._scales) @ self.rotation.T + self.centre
            inside = np.all((states >= low) & (states <= high), axis=1)
            if np.any(inside):
                return states[inside]
        # The informed set barely meets the bounds: uniform samples are as good as any.
        return self.uniform._draw_batch(rng)


class GoalBiasedSampler:
    """The goal with probability ``probability``, otherwise a sample of ``inner``."""

    def __init__(self, inner: _BufferedSampler, goal: np.ndarray, probability: float) -> None:
        if not 0.0 <= probability <= 1.0:
            raise ValueError(f"goal_bias: must be in [0, 1], got {probability}")
        self.inner = inner
        self.goal = np.asarray(goal, dtype=np.float64).copy()
        self.probability = float(probability)
        self.dim = len(self.goal)

    def reset(self) -> None:
        """Discard the inner sampler's buffered samples."""
        self.inner.reset()

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        """Return one state of shape ``(d,)``."""
        if self.probability > 0.0 and rng.random() < self.probability:
            return self.goal.copy()
        return self.inner.sample(rng)
