"""`plan()`: run a registered planner on a `Problem`.

Example:
    >>> result = plan(problem, planner="informed_rrt_star", seed=1, max_nodes=2000)
    >>> result.success, result.path[0].tolist() == problem.start.tolist()
    (True, True)
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable

from temp_gym.planning.planners import informed_rrt_star, rrt_star
from temp_gym.planning.result import PlanResult, PlanSettings
from temp_gym.planning.temp_planner import temp
from temp_gym.problem import Problem

PlannerFunction = Callable[[Problem, PlanSettings], PlanResult]

PLANNERS: dict[str, PlannerFunction] = {}
"""Planner name -> function; `plan` dispatches through it."""


def register_planner(name: str, function: PlannerFunction, overwrite: bool = False) -> None:
    """Make ``function`` available as ``plan(..., planner=name)``."""
    if not overwrite and name in PLANNERS:
        raise ValueError(f"planner: {name!r} is already registered")
    PLANNERS[name] = function


def _ompl_planner(name: str) -> PlannerFunction:
    def run(problem: Problem, settings: PlanSettings) -> PlanResult:
        from temp_gym.planning.ompl_planners import solve_with_ompl

        return solve_with_ompl(problem, settings, name)

    run.__name__ = name
    run.__doc__ = f"OMPL's {name.removeprefix('ompl_')} (needs `pip install temp-gym[ompl]`)."
    return run


register_planner("rrt_star", rrt_star)
register_planner("informed_rrt_star", informed_rrt_star)
register_planner("temp", temp)
# OMPL is imported only when one of these runs; without it they raise a clear ImportError.
register_planner("ompl_rrt_star", _ompl_planner("ompl_rrt_star"))
register_planner("ompl_informed_rrt_star", _ompl_planner("ompl_informed_rrt_star"))


def _is_int(value: object) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def _is_number(value: object) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def plan(
    problem: Problem,
    planner: str = "temp",
    seed: int = 0,
    max_nodes: int = 5000,
    time_limit: float | None = None,
    stop_at_first: bool = False,
    step_size: float | None = None,
    goal_bias: float = 0.05,
    target_cost: float | None = None,
    max_samples: int | None = None,
    policy: object = None,
    attention_nodes: int | None = None,
    attention_patience: int | None = None,
) -> PlanResult:
    """Solve ``problem`` with a registered planner and return a certified `PlanResult`.

    The run stops at the first of: ``max_nodes`` tree nodes, ``max_samples`` samples,
    ``time_limit`` seconds, the first solution (``stop_at_first``), a solution costing at
    most ``target_cost``. A returned path is certified by the exact collision checker, starts
    at ``problem.start`` and ends inside the goal region. The same seed gives the same result
    (wall times aside) unless the time limit is what stopped the run.

    Args:
        problem: The query.
        planner: A key of `PLANNERS`: ``temp`` (the default: TEMP, with the policy shipped
            for the robot unless ``policy`` is given), ``rrt_star``, ``informed_rrt_star``,
            ``ompl_rrt_star``, ``ompl_informed_rrt_star``.
        seed: Seed of the planner's random generator.
        max_nodes: Tree-size budget, root included (at least 1).
        time_limit: Seconds of wall time, or None for no limit.
        stop_at_first: Stop at the first solution.
        step_size: Steering step; None picks 5% of the largest bound side for point robots
            (1.0 in ``[0, 20]^d``) and 0.5 rad for the iiwa.
        goal_bias: Probability of sampling the goal, in ``[0, 1]``.
        target_cost: Stop once a solution costs at most this.
        max_samples: Sample budget; None means ``100 * max_nodes``.
        policy: ``temp`` only: a `temp_gym.policies.SamplingPolicy` (for instance
            `temp_gym.load_policy("TEMP-2D-v0")`); None loads the shipped policy for the robot.
        attention_nodes: ``temp`` only: tree-node budget of attention-based planning before
            classical planning takes over, the n of Algorithm 1 (None: the policy's own
            ``attention_nodes``, which shipped policies carry; else all of ``max_nodes``).
        attention_patience: ``temp`` only: attention-phase nodes in a row without getting
            closer to the goal before classical planning takes over (None: proportional to
            the start-goal distance, `temp_gym.planning.attention.default_patience`; 0: never,
            the paper's Algorithm 1).

    Raises:
        ValueError: For an unknown planner or an invalid argument.
    """
    if not isinstance(problem, Problem):
        raise ValueError(f"problem: expected a Problem, got {type(problem).__name__}")
    if planner not in PLANNERS:
        raise ValueError(
            f"planner: unknown planner {planner!r}; expected one of {sorted(PLANNERS)}"
        )
    if not _is_int(seed) or seed < 0:
        raise ValueError(f"seed: expected a non-negative integer, got {seed!r}")
    if not _is_int(max_nodes) or max_nodes < 1:
        raise ValueError(f"max_nodes: expected an integer of at least 1, got {max_nodes!r}")
    if time_limit is not None and (not _is_number(time_limit) or not time_limit >= 0):
        raise ValueError(f"time_limit: expected a non-negative number or None, got {time_limit!r}")
    if step_size is not None and (
        not _is_number(step_size) or not math.isfinite(step_size) or step_size <= 0
    ):
        raise ValueError(f"step_size: expected a positive number or None, got {step_size!r}")
    if not _is_number(goal_bias) or not 0.0 <= goal_bias <= 1.0:
        raise ValueError(f"goal_bias: expected a number in [0, 1], got {goal_bias!r}")
    if target_cost is not None and (not _is_number(target_cost) or math.isnan(target_cost)):
        raise ValueError(f"target_cost: expected a number or None, got {target_cost!r}")
    if max_samples is not None and (not _is_int(max_samples) or max_samples < 1):
        raise ValueError(f"max_samples: expected an integer of at least 1, got {max_samples!r}")
    if attention_nodes is not None and (not _is_int(attention_nodes) or attention_nodes < 1):
        raise ValueError(
            f"attention_nodes: expected an integer of at least 1, got {attention_nodes!r}"
        )
    if attention_patience is not None and (
        not _is_int(attention_patience) or attention_patience < 0
    ):
        raise ValueError(
            f"attention_patience: expected a non-negative integer or None, got "
            f"{attention_patience!r}"
        )
    if policy is not None and not (hasattr(policy, "reset") and callable(policy)):
        raise ValueError("policy: expected a SamplingPolicy (reset(problem), policy(obs))")
    if policy is not None and planner != "temp":
        raise ValueError(f"policy: only the temp planner takes a policy, not {planner!r}")
    settings = PlanSettings(
        seed=int(seed),
        max_nodes=int(max_nodes),
        time_limit=None if time_limit is None else float(time_limit),
        stop_at_first=bool(stop_at_first),
        step_size=None if step_size is None else float(step_size),
        goal_bias=float(goal_bias),
        target_cost=None if target_cost is None else float(target_cost),
        max_samples=None if max_samples is None else int(max_samples),
        policy=policy,
        attention_nodes=None if attention_nodes is None else int(attention_nodes),
        attention_patience=None if attention_patience is None else int(attention_patience),
    )
    return PLANNERS[planner](problem, settings)
