"""Compile before the clock starts: one short, untimed plan per process, robot and planner.

The hot loops are numba kernels compiled on first use (or loaded from numba's cache in
``__pycache__``); with an empty cache that took 20 s of a 7D plan, inside its time limit, so
a first ``temp-plan --time-limit 2`` returned "no solution, 2 nodes". `warm_up` runs the
planner once on the caller's own problem with a tiny budget before `temp_gym.plan` starts
timing, so every kernel that planner reaches (tree, sampler, collision checker, the TEMP
policy's fast MPT, certification; the fast checker's Python methods, which OMPL calls; the
exact free volume, which only some workspaces need) is compiled, and per-process setup (the
checker's robot geometry, torch's first inference) is done. It lists no kernels by name:
whatever the planner calls is warmed. For ``temp`` that includes the goal tree, which a timed
run meets only once an attention phase stops unsolved: a third plan, on a query whose goal is
a free straight motion away, stops the attention phase after one node so that the goal tree
joins it (without it, the first such task of a process paid 20 ms of loading, or 1.8 s of
compiling with an empty cache, inside its time; ``rrt_connect`` plans that query too, for its
first join); a fourth, on uniform samples with a stall patience of one node, stalls, so that
the phases after a stall are loaded too (their compiled sequence cost the first stalled 2D
plan of a process 66 ms of loading). A trivial first problem (the start at the goal, an
empty world) reaches less, so the warm-up also grows a tree past its first capacity (a point
robot's grid grows then), computes the free volume of its bounds with one box in them, and
joins towards the first axis when the goal is the start: without them, a timed run on the
next problem compiled those inside its limit (7 s of a 1 s limit with an empty cache).

With an empty cache the compiling takes minutes (longest for the arm), so the first time a
process meets a compilation it logs one line through the ``temp_gym`` logger at WARNING level,
which Python prints on stderr unless logging is configured otherwise (as matplotlib announces
building its font cache): "compiling the planner's kernels for kuka_iiwa14 (first use, about 2
minutes; cached afterwards)". It is numba's own compile event that triggers it, never a cache
load, so a warm cache stays quiet.

It leaves no trace in results or in the caller's objects: planners seed their own
generators from ``settings.seed``, the per-workspace caches it fills (free volume,
occupancy, EISE encoding) hold the values the timed run would compute, and the caller's
policy is never called: a policy that offers ``fresh()`` (a `TEMPPolicy`: the same model and
settings, its own state) warms up through such a copy, any other through RRT* (which compiles
the tree's kernels; a Python policy has nothing to compile). OMPL's planners warm up through
ours too (OMPL seeds a process-wide stream at its first run, which must stay the caller's).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np
from numba.core import event

from temp_gym.planning.settings import PlanSettings
from temp_gym.planning.temp_settings import TEMPSettings
from temp_gym.planning.tree import Tree, default_step_size, workspace_free_volume
from temp_gym.problem import Problem, Workspace
from temp_gym.worlds.checkers import certify_path, make_checker
from temp_gym.worlds.robots import robot_spec

logger = logging.getLogger("temp_gym")

WARM_UP_NODES = 64
"""Tree nodes of a warm-up plan (half of them attention-based for ``temp``)."""
STAND_INS = {"ompl_rrt_star": "rrt_star", "ompl_informed_rrt_star": "rrt_star",
             "ompl_rrt_connect": "rrt_star", "ompl_bit_star": "rrt_star"}  # fmt: skip
"""Planners warmed up through another (see the module docstring)."""

_WARMED: set[tuple[str, str, bool]] = set()
_ANNOUNCED: set[str] = set()


class CompileNotice(event.Listener):
    """Logs, once per process and robot, that numba is compiling (see the module docstring)."""

    def __init__(self, robot: str) -> None:
        self.robot = robot

    def on_start(self, event: event.Event) -> None:
        """The first compilation for this robot in this process: say so, with an estimate."""
        if self.robot in _ANNOUNCED:
            return
        _ANNOUNCED.add(self.robot)
        minutes = robot_spec(self.robot).compile_minutes
        estimate = "a minute" if minutes <= 1 else f"{minutes:g} minutes"
        logger.warning(
            "compiling the planner's kernels for %s (first use, about %s; cached afterwards)",
            self.robot,
            estimate,
        )

    def on_end(self, event: event.Event) -> None:
        """Nothing to do when a compilation ends."""


def warm_up(
    problem: Problem, planner: str, settings: PlanSettings, planners: Mapping[str, Any]
) -> bool:
    """Plan ``problem`` briefly with ``planner`` unless this process already did; untimed.

    ``settings`` are the planner's (`temp_gym.planning.registry.settings_for`), ``planners``
    the registry. Returns whether a warm-up ran. Keyed by (robot, planner, whether every
    obstacle is an axis-aligned box): kernels are compiled per process, not per problem, but
    a workspace of other obstacle kinds has a checker, and compiled loops, of its own.
    """
    name = STAND_INS.get(planner, planner)
    policy = settings.policy if isinstance(settings, TEMPSettings) else None
    fresh = None if policy is None else getattr(policy, "fresh", None)
    if name == "temp" and policy is not None and fresh is None:
        name = "rrt_star"
    key = (problem.robot, name, problem.workspace.axis_aligned)
    if key in _WARMED:  # checked before any copy of the policy is made: this is per call
        return False
    _WARMED.add(key)
    with event.install_listener("numba:compile", CompileNotice(problem.robot)):
        _warm(problem, planner, name, settings, planners)
    return True


def _warm(
    problem: Problem,
    planner: str,
    name: str,
    settings: PlanSettings,
    planners: Mapping[str, Any],
) -> None:
    """The warm-up plans and checks of `warm_up` (its docstring and the module's say which).

    ``name`` is the planner that plans them: ``planner`` itself, or its stand-in.
    """
    policy = settings.policy if isinstance(settings, TEMPSettings) else None
    fresh = None if policy is None else getattr(policy, "fresh", None)
    if name == "temp" and fresh is not None:
        policy = fresh()
        if policy is None:  # no copy to be had: warm up what every planner shares
            name = "rrt_star"
    short = replace(
        settings if name == planner else settings.common(),  # a stand-in: the common ones
        max_nodes=WARM_UP_NODES,
        max_samples=None,
        time_limit=None,
        stop_at_first=False,
        target_cost=-math.inf,  # grows its nodes even from a start in the goal region (cost 0)
    )
    if isinstance(short, TEMPSettings):
        short = replace(short, attention_nodes=WARM_UP_NODES // 2, policy=policy)
    planners[name](problem, short)
    # The short plan may find no path: plan once more with the start inside the goal region
    # (solution extraction), and certify one short motion (the exact checker).
    planners[name](problem.replace(goal=problem.start.tolist()), short)
    toward_goal = problem.start + 1e-3 * (problem.goal - problem.start)
    certify_path(problem, np.stack([problem.start, toward_goal, problem.start]))
    # Our planners' loops check motions in compiled code; OMPL's callbacks (and Python loops)
    # call the fast checker's Python methods: compile those too.
    checker = make_checker(problem)
    if name == "rrt_connect":  # a first join, whose graft a short plan may not reach
        near = _joinable_problem(problem, checker, settings.step_size)
        if near is not None:
            planners[name](near, short)
    if isinstance(short, TEMPSettings) and settings.goal_tree is not False:
        near = _joinable_problem(problem, checker, settings.step_size)
        if near is not None:  # the attention phase ends unsolved, the goal tree joins
            planners[name](near, replace(short, attention_nodes=1))
        if settings.attention_from_goal is not False:
            # A stall: the phases after it (from the goal, the rounds) run in a kernel of
            # their own. Uniform samples with a patience of one node stall all but surely.
            planners[name](problem, replace(short, attention_patience=1, attention_uniform=1.0))
    start = np.array(problem.start, dtype=np.float64)  # writable, as the callers' arrays are
    checker.states_free(start[None])
    checker.edge_free(start, toward_goal)
    checker.edges_free(start[None], toward_goal[None])
    # A point world's tree computes the exact free volume only in some workspaces (when the
    # cheap bound of it is not enough for its near radius), so a timed run could be the first
    # to load that kernel: compute it here, untimed, through the per-workspace cache a tree
    # reads (for the iiwa's Monte Carlo estimate the plans above already filled it).
    workspace_free_volume(problem, checker)
    grown = Tree(problem, checker)
    grown.grow()  # past its first capacity a point robot's tree makes its grid,
    grown.grow()  # and then grows it
    if problem.workspace.num_obstacles == 0 and hasattr(checker, "free_volume"):
        # An empty world's exact volume needs no union of boxes; the next world's may.
        low, high = problem.bounds
        one_box = Workspace(problem.robot, problem.bounds, ((low + high) / 2)[None],
                            ((high - low) / 4)[None])  # fmt: skip
        make_checker(one_box).free_volume()


def _joinable_problem(problem: Problem, checker, step_size: float | None) -> Problem | None:
    """``problem`` with its goal one step and two goal radii from the start, a free motion away.

    One attention node cannot reach that goal's region, so a plan stopped after one node has
    a goal tree, whose first join (the start to this goal) succeeds. Tried towards the goal and
    then away from it (along the first axis when the goal is the start); None when neither is
    free and inside the bounds (a best effort: the warm-up never fails a plan).
    """
    start = np.asarray(problem.start, dtype=np.float64)
    direction = np.asarray(problem.goal, dtype=np.float64) - start
    length = float(np.linalg.norm(direction))
    if length == 0.0:  # the goal is the start: any direction will do
        direction, length = np.eye(len(start))[0], 1.0
    step = default_step_size(problem) if step_size is None else float(step_size)
    distance = step + 2.0 * float(problem.goal_radius)
    for sign in (1.0, -1.0):
        goal = start + sign * direction * (distance / length)
        try:  # the problem's own checks: inside the bounds, collision-free
            near = problem.replace(goal=goal.tolist())
        except ValueError:
            continue
        if checker.edge_free(start, goal):
            return near
    return None
