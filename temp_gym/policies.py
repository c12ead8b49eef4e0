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

A policy never goes stale silently. The observation carries the task (normalized start and
goal, goal radius, occupancy grid), and a policy compares it with the task it was reset for:
`UniformPolicy` (and the learned `temp_gym.models.policy.TEMPPolicy`) follow a new task by
themselves, which is what a vector env's automatic reset needs; `InformedPolicy`, which needs
the bounds in world units that the observation does not carry, raises a ``ValueError`` that
says to call ``reset``.

The contract every policy meets, `SamplingPolicy` (``reset(problem, seed=None)`` and
``policy(observation)``, an optional fast path and declared settings), is
`temp_gym.planning.policy`'s; it is importable from here too.
"""

from __future__ import annotations

import numpy as np

from temp_gym.planning.observation import task_entries
from temp_gym.planning.policy import SamplingPolicy  # noqa: F401  (the contract, re-exported)
from temp_gym.planning.samplers import GoalBiasedSampler, InformedSampler, UniformSampler
from temp_gym.planning.settings import PlanSettings, seed_value
from temp_gym.problem import Problem
from temp_gym.worlds.normalization import denormalize, normalize

DEFAULT_GOAL_BIAS = PlanSettings().goal_bias
TASK_KEYS = ("start", "goal", "goal_radius")
"""Observation entries that identify the task a policy plans for (besides ``occupancy``)."""


def task_signature(observation: dict[str, np.ndarray], keys: tuple[str, ...]) -> bytes:
    """The float32 bytes of ``observation``'s ``keys``: equal iff the entries are equal.

    Cheap enough to compare on every call (a few microseconds for an occupancy grid), so a
    policy notices a new task without the caller's help.
    """
    try:
        return b"".join(np.asarray(observation[key], dtype=np.float32).tobytes() for key in keys)
    except (TypeError, KeyError, IndexError) as error:
        raise ValueError(
            f"observation: expected the env's observation dict with {list(keys)}, got "
            f"{type(observation).__name__}"
        ) from error


def carries(observation: object, keys: tuple[str, ...]) -> bool:
    """Whether ``observation`` is a dict with all of ``keys``.

    A hand-built observation may hold only what a policy samples from (e.g. the path so
    far); a policy then plans for the task given to its ``reset``.
    """
    return isinstance(observation, dict) and all(key in observation for key in keys)


def problem_signature(problem: Problem, keys: tuple[str, ...]) -> bytes:
    """`task_signature` of every observation of a tree grown on ``problem`` (no occupancy)."""
    return task_signature(task_entries(problem), keys)


class UniformPolicy:
    """Goal-biased uniform samples: RRT*'s sampler as a policy.

    It follows the observation's goal: after an env reset that the policy was not told about
    (a vector env's automatic reset, or a forgotten ``reset``), it proposes the new goal, and
    uniform samples, which need no bounds in normalized coordinates. Without any ``reset`` it
    samples [-1, 1]^d directly.

    Args:
        seed: seed of the policy's own generator (the same one `plan` uses for its sampler).
        goal_bias: probability of proposing the goal itself.
    """

    def __init__(self, seed: int | None = None, goal_bias: float = DEFAULT_GOAL_BIAS) -> None:
        self.seed = None if seed is None else seed_value(seed)
        self.goal_bias = goal_bias
        self.problem: Problem | None = None
        self.rng = np.random.default_rng(seed)
        self._bounds: np.ndarray | None = None
        self._task: bytes | None = None

    def _base_sampler(self, problem: Problem):
        return UniformSampler(problem.bounds)

    def reset(self, problem: Problem, seed: int | None = None) -> None:
        """Start a new episode; ``seed`` (or the constructor's) re-seeds the generator."""
        self.problem = problem
        self.rng = np.random.default_rng(self.seed if seed is None else seed_value(seed))
        self.base = self._base_sampler(problem)
        self.sampler = GoalBiasedSampler(self.base, problem.goal, self.goal_bias)
        self._bounds = problem.bounds
        self._task = problem_signature(problem, ("goal",))

    def _follow(self, observation: dict[str, np.ndarray]) -> None:
        """Retarget the goal when the observation's differs from the one sampled so far."""
        if self._task is not None and not carries(observation, ("goal",)):
            return
        task = task_signature(observation, ("goal",))
        if task == self._task:
            return
        goal = np.asarray(observation["goal"], dtype=np.float64)
        if goal.ndim != 1 or (self._bounds is not None and goal.shape != self._bounds[0].shape):
            expected = "(d,)" if self._bounds is None else f"({self._bounds.shape[1]},)"
            raise ValueError(
                f"observation['goal']: expected shape {expected}, got {goal.shape}: one env's "
                "observation of the robot given to reset (call the policy per sub-env of a "
                "vector env)"
            )
        if self._bounds is None:  # never reset: sample the normalized box itself
            self._bounds = np.stack([-np.ones_like(goal), np.ones_like(goal)])
            self.base = UniformSampler(self._bounds)
        self.sampler = GoalBiasedSampler(self.base, denormalize(goal, self._bounds), self.goal_bias)
        self._task = task

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """Return a normalized sample for the observation's goal."""
        self._follow(observation)
        return normalize(self.sampler.sample(self.rng), self._bounds)


class InformedPolicy(UniformPolicy):
    """Informed RRT*'s sampler as a policy: uniform until a solution, then the informed set.

    It reads the best cost from the observation (``best_cost`` is relative to the start-goal
    distance), so it needs nothing but the problem and the observation. The informed set lives
    in world units, which the observation does not carry: an observation of another task than
    the one given to ``reset`` is a ``ValueError``.
    """

    def _base_sampler(self, problem: Problem):
        return InformedSampler(problem.bounds, problem.start, problem.goal, problem.goal_radius)

    def reset(self, problem: Problem, seed: int | None = None) -> None:
        """Start a new episode; ``seed`` (or the constructor's) re-seeds the generator."""
        super().reset(problem, seed)
        self._task = problem_signature(problem, TASK_KEYS)

    def _follow(self, observation: dict[str, np.ndarray]) -> None:
        if self.problem is None:
            raise RuntimeError(
                "InformedPolicy: call policy.reset(problem) before sampling (it needs the "
                "problem's bounds in world units)"
            )
        if carries(observation, TASK_KEYS) and task_signature(observation, TASK_KEYS) != self._task:
            raise ValueError(
                "observation: its start, goal or goal_radius differ from the problem given to "
                "InformedPolicy.reset; call policy.reset(env.unwrapped.problem) after every env "
                "reset (a vector env resets finished sub-envs by itself)"
            )

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """Return a normalized sample from the current informed set."""
        self._follow(observation)
        if observation["solved"][0] > 0:
            distance = float(np.linalg.norm(self.problem.goal - self.problem.start))
            # The observation holds the cost in float32: round up so the set never shrinks
            # below the true informed set.
            cost = float(observation["best_cost"][0]) * distance * (1.0 + 1e-6)
            self.base.set_best_cost(cost)
        return normalize(self.sampler.sample(self.rng), self.problem.bounds)
