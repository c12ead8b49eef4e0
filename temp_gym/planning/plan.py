"""`plan()`: run a registered planner on a `Problem`.

Example:
    >>> result = plan(problem, planner="informed_rrt_star", seed=1, max_nodes=2000)
    >>> result.success, result.path[0].tolist() == problem.start.tolist()
    (True, True)
    >>> plan(problem, settings=TEMPSettings(max_nodes=3000, attention_patience=30))
"""

from __future__ import annotations

import time
from typing import Any

from temp_gym.planning.ompl_planners import (
    OMPLBITStarSettings,
    OMPLInformedRRTStarSettings,
    OMPLRRTConnectSettings,
    OMPLRRTStarSettings,
)
from temp_gym.planning.planners import (
    InformedRRTStarSettings,
    RRTStarSettings,
    informed_rrt_star,
    rrt_star,
)
from temp_gym.planning.registry import PLANNERS, planner_of, register_planner, settings_for
from temp_gym.planning.result import PlanResult
from temp_gym.planning.rrt_connect import RRTConnectSettings, rrt_connect
from temp_gym.planning.settings import PlanSettings, flag
from temp_gym.planning.simplify import path_length, shorter_path
from temp_gym.planning.temp_planner import temp
from temp_gym.planning.temp_settings import TEMPSettings
from temp_gym.planning.warmup import warm_up
from temp_gym.problem import Problem

DEFAULT_PLANNER = "temp"
"""The planner of ``plan(problem)``: TEMP with the policy shipped for the robot."""


def _ompl_planner(name: str):
    def run(problem: Problem, settings: PlanSettings) -> PlanResult:
        from temp_gym.planning.ompl_planners import solve_with_ompl

        return solve_with_ompl(problem, settings, name)

    run.__name__ = name
    run.__doc__ = f"OMPL's {name.removeprefix('ompl_')} (needs `pip install temp-gym[ompl]`)."
    return run


register_planner("rrt_star", rrt_star, RRTStarSettings)
register_planner("informed_rrt_star", informed_rrt_star, InformedRRTStarSettings)
register_planner("rrt_connect", rrt_connect, RRTConnectSettings)
register_planner("temp", temp, TEMPSettings)
# OMPL is imported only when one of these runs; without it they raise a clear ImportError.
register_planner("ompl_rrt_star", _ompl_planner("ompl_rrt_star"), OMPLRRTStarSettings)
register_planner(
    "ompl_informed_rrt_star", _ompl_planner("ompl_informed_rrt_star"), OMPLInformedRRTStarSettings
)
register_planner("ompl_rrt_connect", _ompl_planner("ompl_rrt_connect"), OMPLRRTConnectSettings)
register_planner("ompl_bit_star", _ompl_planner("ompl_bit_star"), OMPLBITStarSettings)


def plan(
    problem: Problem,
    planner: str | None = None,
    settings: PlanSettings | None = None,
    simplify: bool = False,
    **options: Any,
) -> PlanResult:
    """Solve ``problem`` with a registered planner and return a certified `PlanResult`.

    The run stops at the first of: ``max_nodes`` tree nodes, ``max_samples`` samples,
    ``time_limit`` seconds, the first solution (``stop_at_first``), a solution costing at
    most ``target_cost``. A returned path is certified by the exact collision checker, starts
    at ``problem.start`` and ends inside the goal region. The same seed gives the same result
    (wall times aside) unless the time limit is what stopped the run; OMPL's planners are the
    exception: OMPL takes one seed per process, at its first run, and later runs continue its
    stream (`temp_gym.planning.ompl_planners`), so only the same sequence of OMPL runs in a
    fresh process repeats them.

    What the time limit and the reported times cover: the planner's run, from building its
    tree (collision checker, per-workspace set-up, TEMP's workspace encoding) to the end of
    the search. Not covered: the first call in a process for each robot and planner first
    plans the same problem briefly, untimed, to compile the numba kernels
    (`temp_gym.planning.warmup`; seconds with an empty numba cache, milliseconds otherwise);
    loading a shipped policy; and certifying the returned path (and simplifying it), which
    ``wall_time`` includes but the limit does not stop.

    Settings: each planner has its own settings class (`PLANNERS[name].settings`), which
    extends the common `PlanSettings` (``seed``, ``max_nodes``, ``time_limit``,
    ``stop_at_first``, ``step_size``, ``goal_bias``, ``target_cost``, ``max_samples``):
    `TEMPSettings` for ``temp`` (its ``policy`` and the attention phase's settings),
    `RRTStarSettings`, `InformedRRTStarSettings`, `RRTConnectSettings` (``range``), and for the
    OMPL planners `OMPLSettings` (OMPL's RRT*s), `OMPLRRTConnectSettings` and
    `OMPLBITStarSettings`.
    Pass one as ``settings``, or its fields as keywords, or both (the keywords win)::

        plan(problem, planner="rrt_star", seed=1, max_nodes=2000)
        plan(problem, settings=TEMPSettings(attention_patience=30), seed=1)

    TEMP's settings left None take the policy's own (a shipped policy carries those it was
    tuned with), else the planner's defaults (`TEMPSettings` says which).

    ``simplify=True`` shortens a found path as MoveIt does after planning
    (`temp_gym.planning.simplify`: vertex reduction and random shortcuts, seeded by ``seed``),
    certified again by the exact checker. ``path`` and ``cost`` are then the simplified path's,
    ``simplification`` keeps the planner's own cost and waypoints and the time it took, and
    ``wall_time`` includes it. The anytime ``history`` stays the planner's.

    Args:
        problem: The query.
        planner: A key of `PLANNERS`: ``temp`` (TEMP, with the policy shipped for the robot
            unless ``policy`` is given), ``rrt_star``, ``informed_rrt_star``, ``rrt_connect``,
            ``ompl_rrt_star``, ``ompl_informed_rrt_star``, ``ompl_rrt_connect``,
            ``ompl_bit_star``. None: the planner whose settings class ``settings`` is, else
            ``temp``.
        settings: The planner's settings (its class, or a plain `PlanSettings` whose common
            fields it takes); None: every field's default.
        simplify: Shorten the found path (above).
        **options: Fields of the planner's settings class, applied over ``settings``. A field
            of another planner's is refused, naming the form to use (None is let through:
            not set).

    Raises:
        ValueError: An unknown planner, settings of another planner, or an invalid setting;
            one line naming the field.
    """
    if not isinstance(problem, Problem):
        raise ValueError(f"problem: expected a Problem, got {type(problem).__name__}")
    if planner is None:
        planner = planner_of(settings) or DEFAULT_PLANNER
    simplify = flag(simplify, "simplify")
    chosen = settings_for(planner, settings, **options)
    warm_up(problem, planner, chosen, PLANNERS)  # compile before the clock starts
    result = PLANNERS[planner].function(problem, chosen)
    if simplify and result.success:
        started = time.perf_counter()
        shorter = shorter_path(problem, result.path, seed=chosen.seed)
        took = time.perf_counter() - started
        result.simplification = {"cost": result.cost, "waypoints": len(result.path), "time": took}
        if shorter is not None:
            result.path, result.cost = shorter, path_length(shorter)
        result.wall_time += took
    return result
