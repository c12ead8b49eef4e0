"""The policy contract: what the ``temp`` planner asks of a sampling policy.

**Required** (`SamplingPolicy`): ``reset(problem, seed=None)``, once per problem (the seed is
the planner's: a stochastic policy re-seeds from it, so the same seed gives the same plan; a
deterministic one ignores it), and ``policy(observation)``, which returns the next sample,
normalized to [-1, 1]^d, from the observation `temp_gym.planning.observation.TreeObserver`
builds. A class with these two methods plans::

    class TowardsGoal:
        def reset(self, problem, seed=None):
            pass

        def __call__(self, observation):
            return observation["goal"]

    plan(problem, planner="temp", policy=TowardsGoal())

**Optional fast path** (`FAST_PATHS`, found by `fast_path`), used when present, else the
planner builds whole observations:

* ``propose_chunk(path, length)`` (`ChunkProposer`): float32 ``(k, d)`` samples from the
  path so far alone (``(L, d)`` normalized rows, ``length`` valid), used in turn;
* ``propose(path, length)`` (`Proposer`): one sample, ``(d,)``, from the path so far;
* ``compiled_proposer()`` (`CompiledProposer`): the arrays with which the compiled attention
  loop (`temp_gym.planning._compiled_attention`) runs the policy itself, or None when it
  cannot (a `temp_gym.models.policy.TEMPPolicy` on its numba MPT gives them).

Each must propose what ``policy(observation)`` would for the same tree (the first row of a
chunk is that sample).

**Declared settings** (`POLICY_SETTINGS`), optional attributes read by `policy_settings`; a
policy without one (or with None) gets the default:

* ``encoding_resolution``: cells per workspace axis of the observation's occupancy grid
  (default: the robot's);
* ``max_path_length``: L, the path-so-far rows of the observation (default
  `DEFAULT_MAX_PATH_LENGTH`);
* the ``temp`` planner's settings a policy may carry (`temp_gym.planning.temp_settings.DECLARED`:
  ``attention_nodes``, ``attention_patience``, ``attention_local_fallback``, ...), which the
  planner uses where the caller set none (`temp_gym.planning.temp_settings.TEMPSettings` says
  what each means and its default). A shipped policy carries those it was tuned with.

A policy whose ``reset`` takes the problem alone still works through `as_sampling_policy`
(``plan`` adapts it, with a ``DeprecationWarning``).
"""

from __future__ import annotations

import inspect
import warnings
import weakref
from collections.abc import Callable
from dataclasses import make_dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from temp_gym.planning.observation import DEFAULT_MAX_PATH_LENGTH, check_path_length
from temp_gym.planning.temp_settings import DECLARED
from temp_gym.problem import Problem
from temp_gym.worlds.encoding import check_resolution


@runtime_checkable
class SamplingPolicy(Protocol):
    """Anything that proposes the next sample for a planning episode (module docstring)."""

    def reset(self, problem: Problem, seed: int | None = None) -> None:
        """Prepare for a new problem (the learned policy encodes the environment here).

        ``seed``: the planner's seed; a stochastic policy re-seeds its generator from it (None
        keeps its own), so the same seed gives the same plan.
        """
        ...

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """Return the next sample, normalized to [-1, 1]^d."""
        ...


@runtime_checkable
class Proposer(Protocol):
    """The optional one-sample fast path: the next sample from the path so far alone."""

    def propose(self, path: np.ndarray, length: int) -> np.ndarray:
        """Float32 ``(d,)``: what ``policy(observation)`` returns for that path."""
        ...


@runtime_checkable
class ChunkProposer(Protocol):
    """The optional chunked fast path: the next k samples from the path so far alone."""

    def propose_chunk(self, path: np.ndarray, length: int) -> np.ndarray:
        """Float32 ``(k, d)``; the first row is what ``policy(observation)`` returns."""
        ...


@runtime_checkable
class CompiledProposer(Protocol):
    """The optional compiled fast path (`temp_gym.planning._compiled_attention`)."""

    def compiled_proposer(self) -> tuple | None:
        """The policy as the compiled loop runs it, or None when it cannot.

        ``(weights, goal, prefix tokens, prefix qkv, noise generator, noise_std, chunk, L)``
        for the MPT kernel (`temp_gym.planning.mpt_kernel.forward_kernel`); the loop draws
        the output noise, ``normal(0, noise_std, (chunk, d))`` per call, from the generator
        (None when ``noise_std`` is 0).
        """
        ...


OBSERVATION_SETTINGS = ("encoding_resolution", "max_path_length")
"""The declared settings that shape the observation a policy reads."""

POLICY_SETTINGS = (*OBSERVATION_SETTINGS, *DECLARED)
"""The optional attributes a policy may declare (module docstring)."""

PolicySettings = make_dataclass(
    "PolicySettings",
    [(name, Any, None) for name in POLICY_SETTINGS],
    frozen=True,
)
PolicySettings.__module__ = __name__
PolicySettings.__doc__ = """The settings a policy declares (None: not declared, the default).

One field per name of `POLICY_SETTINGS`: the observation's sizes, then the ``temp`` planner's
settings a policy may carry (`temp_gym.planning.temp_settings.DECLARED`)."""


FAST_PATHS = ("compiled_proposer", "propose_chunk", "propose")
"""The optional fast-path methods, the planner's first choice first."""


def fast_path(policy: Any, name: str) -> Callable[..., Any] | None:
    """``policy``'s bound ``name`` (one of `FAST_PATHS`), or None when it offers none.

    Looked up as an attribute (as ``hasattr`` does, on every Python version), so a wrapper
    that forwards attributes offers what it wraps.
    """
    if name not in FAST_PATHS:
        raise ValueError(f"name: expected one of {FAST_PATHS}, got {name!r}")
    method = getattr(policy, name, None)
    return method if callable(method) else None


def policy_settings(policy: Any) -> PolicySettings:
    """The settings ``policy`` declares as attributes; None for each it does not."""
    return PolicySettings(**{name: getattr(policy, name, None) for name in POLICY_SETTINGS})


def observation_settings(
    policy: Any, robot_resolution: int, workspace_dim: int = 3
) -> tuple[int, int]:
    """``(encoding_resolution, max_path_length)`` of the observations ``policy`` reads.

    Its declared values, else the robot's resolution and `DEFAULT_MAX_PATH_LENGTH`.

    Raises:
        ValueError: a declared value the envs would refuse, in one line naming
            ``policy.<name>``.
    """
    declared = policy_settings(policy)
    resolution, length = declared.encoding_resolution, declared.max_path_length
    if resolution is not None:
        resolution = check_resolution(resolution, workspace_dim, "policy.encoding_resolution")
    if length is not None:
        length = check_path_length(length, "policy.max_path_length")
    return (
        robot_resolution if resolution is None else resolution,
        DEFAULT_MAX_PATH_LENGTH if length is None else length,
    )


class _ProblemOnlyReset:
    """A policy whose ``reset`` takes the problem alone, seen through the contract."""

    def __init__(self, policy: Any) -> None:
        self.policy = policy

    def reset(self, problem: Problem, seed: int | None = None) -> None:
        self.policy.reset(problem)

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        return self.policy(observation)

    def __getattr__(self, name: str) -> Any:  # settings and fast paths of the policy
        return getattr(self.policy, name)


_TAKES_SEED: weakref.WeakKeyDictionary[Callable[..., Any], bool] = weakref.WeakKeyDictionary()
"""Per ``reset`` function of a policy class: whether it takes ``seed`` (`inspect.signature`
costs tens of microseconds, and `plan` asks once per call)."""


def _reset_takes_seed(reset: Callable[..., Any]) -> bool:
    """Whether ``reset`` takes a ``seed``; True when it has no signature to read (a builtin)."""
    function = getattr(reset, "__func__", None)  # a bound method: its class's function
    known = None if function is None else _TAKES_SEED.get(function)
    if known is not None:
        return known
    try:
        takes = "seed" in inspect.signature(reset).parameters
    except (TypeError, ValueError):  # no signature to read: trust the contract
        takes = True
    if function is not None:
        _TAKES_SEED[function] = takes
    return takes


def check_compatible(
    trained_robot: str,
    trained_dim: int,
    robot: str | None,
    dim: int | None,
    source: str = "the model",
) -> None:
    """Raise a clear `ValueError` when a policy trained for one robot is used for another."""
    if dim is not None and int(dim) != int(trained_dim):
        raise ValueError(
            f"{source} was trained for {trained_robot} (d={trained_dim}) and cannot plan in "
            f"d={dim}" + (f" ({robot})" if robot else "")
        )
    if robot is not None and robot != trained_robot:
        raise ValueError(
            f"{source} was trained for robot {trained_robot!r} (d={trained_dim}), not {robot!r}"
        )


def as_sampling_policy(policy: Any) -> SamplingPolicy:
    """``policy`` itself, or, when its ``reset`` takes no ``seed``, an adapter that drops it.

    Raises:
        ValueError: when ``policy`` has no ``reset`` or cannot be called.
    """
    if not isinstance(policy, SamplingPolicy):
        raise ValueError(
            "policy: expected a SamplingPolicy (reset(problem, seed=None), policy(obs))"
        )
    if _reset_takes_seed(policy.reset):
        return policy
    warnings.warn(
        f"{type(policy).__name__}.reset(problem): a SamplingPolicy's reset takes "
        "reset(problem, seed=None) (temp_gym.planning.policy); the seed is dropped",
        DeprecationWarning,
        stacklevel=3,
    )
    return _ProblemOnlyReset(policy)


__all__ = [
    "FAST_PATHS",
    "POLICY_SETTINGS",
    "ChunkProposer",
    "CompiledProposer",
    "PolicySettings",
    "Proposer",
    "SamplingPolicy",
    "as_sampling_policy",
    "check_compatible",
    "fast_path",
    "observation_settings",
    "policy_settings",
]
