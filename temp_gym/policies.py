"""Sampling policies: observation in, normalized sample out.

A policy is what drives `temp_gym.envs.PlanningEnv`: ``reset(problem)`` once per episode, then
``policy(observation)`` once per step. The classical samplers are policies too, so RRT* is
literally the env stepped with `UniformPolicy`, and Informed RRT* with `InformedPolicy`:

    >>> env = gymnasium.make("TEMP-2D-v0", fallback="none")
    >>> policy = UniformPolicy(seed=0)
    >>> observation, info = env.reset(seed=0)
    >>> policy.reset(env.unwrapped.problem)
    >>> observation, reward, terminated, truncated, info = env.step(policy(observation))

With the same seed, ``fallback="none"`` and the default goal bias, this grows the same tree as
``plan(problem, planner="rrt_star", seed=seed)``.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from temp_gym.planning.result import PlanSettings
from temp_gym.planning.samplers import GoalBiasedSampler, InformedSampler, UniformSampler
from temp_gym.problem import Problem
from temp_gym.worlds.normalization import normalize

DEFAULT_GOAL_BIAS = PlanSettings().goal_bias


@runtime_checkable
class SamplingPolicy(Protocol):
    """Anything that proposes the next sample for a planning episode."""

    def reset(self, problem: Problem) -> None:
        """Prepare for a new problem (the learned policy encodes the environment here).

        A stochastic policy may also accept ``seed=``; the planners pass theirs, so the same
        seed gives the same plan.
        """
        ...

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """Return the next sample, normalized to [-1, 1]^d."""
        ...


class UniformPolicy:
    """Goal-biased uniform samples: RRT*'s sampler as a policy.

    Args:
        seed: seed of the policy's own generator (the same one `plan` uses for its sampler).
        goal_bias: probability of proposing the goal itself.
    """

    def __init__(self, seed: int | None = None, goal_bias: float = DEFAULT_GOAL_BIAS) -> None:
        self.seed = seed
        self.goal_bias = goal_bias
        self.problem: Problem | None = None

    def _base_sampler(self, problem: Problem):
        return UniformSampler(problem.bounds)

    def reset(self, problem: Problem, seed: int | None = None) -> None:
        """Start a new episode; ``seed`` (or the constructor's) re-seeds the generator."""
        self.problem = problem
        self.rng = np.random.default_rng(self.seed if seed is None else seed)
        self.base = self._base_sampler(problem)
        self.sampler = GoalBiasedSampler(self.base, problem.goal, self.goal_bias)

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """Return a normalized sample (the observation is not needed)."""
        if self.problem is None:
            raise RuntimeError("call policy.reset(problem) before sampling")
        return normalize(self.sampler.sample(self.rng), self.problem.bounds)


class InformedPolicy(UniformPolicy):
    """Informed RRT*'s sampler as a policy: uniform until a solution, then the informed set.

    It reads the best cost from the observation (``best_cost`` is relative to the start-goal
    distance), so it needs nothing but the problem and the observation.
    """

    def _base_sampler(self, problem: Problem):
        return InformedSampler(problem.bounds, problem.start, problem.goal, problem.goal_radius)

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """Return a normalized sample from the current informed set."""
        if self.problem is None:
            raise RuntimeError("call policy.reset(problem) before sampling")
        if observation["solved"][0] > 0:
            distance = float(np.linalg.norm(self.problem.goal - self.problem.start))
            # The observation holds the cost in float32: round up so the set never shrinks
            # below the true informed set.
            cost = float(observation["best_cost"][0]) * distance * (1.0 + 1e-6)
            self.base.set_best_cost(cost)
        return normalize(self.sampler.sample(self.rng), self.problem.bounds)
