"""OMPL's RRTstar and InformedRRTstar on our `Problem`: the reference baselines.

Both planners see the world only through our fast checker: state validity calls
``states_free`` and motion validity is a custom ``MotionValidator`` that calls ``edge_free``
(OMPL's default discrete motion check, at its default resolution, could cut box corners).
The goal region (a ``GoalState`` with threshold ``goal_radius``), goal bias and path-length
objective match our planners.

Range and neighbourhood (why OMPL's ``range`` is ``RANGE_FACTOR = 2`` steering steps): OMPL's
``range`` is both the steering step and a hard cap on the length of every edge RRTstar makes.
With its radius rule the near radius is ``min(range, r_rrt * (log n / n) ** (1/d))``; with
k-nearest (OMPL's default) the k neighbours are found, but only those closer than ``range`` may
become the new node's parent or be rewired through it (in ``RRTstar.cpp``, k-nearest mode skips
any neighbour at distance ``>= maxDistance_`` before its motion check). This is OMPL's design,
not a bug of the wheel. With ``range`` equal to our step (1.0 in ``[0, 20]^d``) the new node
lies exactly one step from its nearest node and, in 3D at a few thousand nodes, almost never has
another node within one step, so choose-parent and rewiring nearly never fire: in an empty
``[0, 20]^3`` (optimum 30.68) OMPL made 1.12 motion checks per iteration (the steered edge plus
0.12), never one longer than ``range``; k-nearest and the radius rule gave identical trees, and
the cost stalled at 1.31-1.33x the optimum from 500 to 2000 nodes, often an exact integer (every
edge a full step), while our RRT* reached 1.14x. Our planners cap the near radius at
``2 * step`` (`temp_gym.planning.tree.Tree`), so OMPL gets ``range = 2 * step``: the same
longest edge and near-radius cap as ours (its steered edges are then up to two of our steps
long). In the same empty 3D world OMPL's RRTstar then reaches 1.18x at 2000 nodes (2D: 1.015x,
against 1.04x with ``range = step``). ``K_NEAREST = False`` selects OMPL's radius rule, the rule
our planners use; InformedRRTstar keeps OMPL's other defaults (tree pruning, informed sampling).
Pass ``range=step_size`` (`OMPLSettings.range`) for OMPL's steps equal to ours.

Not the cause (checked): the termination condition is evaluated once per iteration and
``solve`` runs once; the objective's cost threshold is ``-inf`` unless ``stop_at_first`` or
``target_cost`` asks otherwise, so OMPL keeps refining (with ``range = step`` and 117,000
iterations it reaches 1.04x in the empty 3D world: slowly, not never).

Node budget: OMPL cannot stop at a tree size, so the termination condition (evaluated once per
iteration) and the motion validator together count the nodes added: the first motion checked
in an iteration is the steered edge, and RRTstar adds a node exactly when it is valid. Pruned
nodes are still counted, as in our planners, which never prune.

Seeding: OMPL seeds its random generators from one process-wide seed generator that can
only be seeded before its first use, so the first OMPL run in a process is seeded with its
``seed`` and later runs continue that stream (a fresh process with the same sequence of runs
reproduces them). OMPL refuses the seed 0 and silently uses 1 instead, so our seed ``s`` is
passed as ``s + 1`` (`ompl_seed`): every seed in ``[0, 2**64 - 2]`` is its own OMPL run.

Needs ``pip install temp-gym[ompl]``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from temp_gym.planning.result import AnytimeLog, PlanResult
from temp_gym.planning.settings import PlanSettings, flag, positive
from temp_gym.planning.tree import default_step_size
from temp_gym.problem import Problem
from temp_gym.worlds.checkers import certify_path, make_checker
from temp_gym.worlds.collision import CollisionChecker

OMPL_PLANNERS = ("ompl_rrt_star", "ompl_informed_rrt_star")
RANGE_FACTOR = 2.0
"""OMPL's ``range`` is this many steering steps unless given (see the module docstring)."""
K_NEAREST = False
"""Whether OMPL's RRTstar uses k-nearest neighbours (True) or its radius rule (False), unless
given."""
_SEEDED = False
MAX_SEED = 2**64 - 2
"""Largest seed the OMPL planners take (OMPL's seeds are 64-bit and may not be 0)."""


def ompl_seed(seed: int) -> int:
    """OMPL's seed for our ``seed``: ``seed + 1``, one-to-one (OMPL maps 0 to 1).

    Raises:
        ValueError: ``seed`` is outside ``[0, MAX_SEED]``.
    """
    if not 0 <= seed <= MAX_SEED:
        raise ValueError(f"seed: the OMPL planners take seeds in [0, 2**64 - 2], got {seed}")
    return seed + 1


def _import_ompl():
    try:
        from ompl import base, geometric, util
    except ImportError as error:
        raise ImportError(
            "the OMPL planners need the ompl Python bindings: pip install temp-gym[ompl]"
        ) from error
    return base, geometric, util


class _Counters:
    """What the callbacks count during one solve."""

    def __init__(self, max_nodes: int, deadline: float) -> None:
        self.max_nodes = max_nodes
        self.deadline = deadline
        self.nodes = 1
        self.iterations = 0
        self.failures = 0
        self.checks = 0
        self.first_check_pending = False


@dataclass(frozen=True)
class OMPLSettings(PlanSettings):
    """The settings of OMPL's planners: the common ones plus OMPL's own."""

    range: float | None = None
    """OMPL's ``range``: the steering step and longest edge (world units; None:
    `RANGE_FACTOR` steering steps, see the module docstring)."""
    k_nearest: bool = K_NEAREST
    """Neighbours by OMPL's k-nearest rule (True) or by its radius rule (False, ours)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.range is not None:
            self._normalize("range", positive(self.range, "range"))
        self._normalize("k_nearest", flag(self.k_nearest, "k_nearest"))


@dataclass(frozen=True)
class OMPLRRTStarSettings(OMPLSettings):
    """``ompl_rrt_star``'s settings (`OMPLSettings`)."""


@dataclass(frozen=True)
class OMPLInformedRRTStarSettings(OMPLSettings):
    """``ompl_informed_rrt_star``'s settings (`OMPLSettings`)."""


MIN_EXTENT = 1e-12
"""Shortest diagonal of the bounds OMPL plans in: its longest valid segment (1% of the
diagonal) must be a positive double well above rounding, or ``SpaceInformation.setup`` fails."""


def solve_with_ompl(problem: Problem, settings: OMPLSettings, name: str) -> PlanResult:
    """Run OMPL's planner ``name`` (one of `OMPL_PLANNERS`) and return a certified result.

    A start already in the goal region is a solution of cost 0, returned as our planners
    return it (the path ``[start, start]``), without OMPL: its InformedRRTstar cannot even set
    up its informed set when start and goal coincide.

    Raises:
        ValueError: bounds narrower than `MIN_EXTENT` across, which OMPL cannot plan in.
    """
    if name not in OMPL_PLANNERS:
        raise ValueError(f"planner: unknown OMPL planner {name!r}; expected one of {OMPL_PLANNERS}")
    seed = ompl_seed(settings.seed)
    extent = float(np.linalg.norm(problem.bounds[1] - problem.bounds[0]))
    if not extent >= MIN_EXTENT:
        raise ValueError(
            f"bounds: OMPL's planners need bounds at least {MIN_EXTENT:g} across (the "
            f"diagonal), got {extent:g}; our planners (rrt_star, informed_rrt_star, temp) "
            "plan in them"
        )
    started = time.perf_counter()
    if float(np.sum((problem.start - problem.goal) ** 2)) <= problem.goal_radius**2:
        return _start_in_goal(problem, settings, name, started)
    ob, og, ou = _import_ompl()
    ou.setLogLevel(ou.LogLevel.LOG_ERROR)
    global _SEEDED
    if not _SEEDED:
        ou.RNG.setSeed(seed)
        _SEEDED = True
    dim = problem.dim
    checker = make_checker(problem)
    time_limit = math.inf if settings.time_limit is None else settings.time_limit
    counters = _Counters(settings.max_nodes, started + time_limit)

    space = ob.RealVectorStateSpace(dim)
    bounds = ob.RealVectorBounds(dim)
    for k in range(dim):
        bounds.setLow(k, float(problem.bounds[0, k]))
        bounds.setHigh(k, float(problem.bounds[1, k]))
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)

    def to_array(state) -> np.ndarray:
        return np.array([state[k] for k in range(dim)])

    def state_is_valid(state) -> bool:
        counters.checks += 1
        return bool(checker.states_free(to_array(state)[None])[0])

    si.setStateValidityChecker(state_is_valid)
    validator = _make_motion_validator(ob, si, checker, counters, to_array)
    si.setMotionValidator(validator)
    si.setup()

    pdef = ob.ProblemDefinition(si)
    start = space.allocState()
    goal = space.allocState()
    for k in range(dim):
        start[k] = float(problem.start[k])
        goal[k] = float(problem.goal[k])
    pdef.addStartState(start)
    goal_region = ob.GoalState(si)
    goal_region.setState(goal)
    goal_region.setThreshold(problem.goal_radius)
    pdef.setGoal(goal_region)
    objective = ob.PathLengthOptimizationObjective(si)
    if settings.stop_at_first:
        objective.setCostThreshold(ob.Cost(math.inf))
    elif settings.target_cost is not None:
        objective.setCostThreshold(ob.Cost(settings.target_cost))
    else:
        objective.setCostThreshold(ob.Cost(-math.inf))
    pdef.setOptimizationObjective(objective)

    planner = og.RRTstar(si) if name == "ompl_rrt_star" else og.InformedRRTstar(si)
    step = default_step_size(problem) if settings.step_size is None else settings.step_size
    planner.setRange(RANGE_FACTOR * step if settings.range is None else settings.range)
    planner.setKNearest(settings.k_nearest)
    planner.setGoalBias(settings.goal_bias)
    planner.setProblemDefinition(pdef)
    planner.setup()

    log = AnytimeLog()
    best = [math.inf]
    max_samples = settings.sample_limit

    def should_stop() -> bool:
        # Called once at the top of every planner iteration: poll the best cost, then arm the
        # motion validator to recognise this iteration's steered edge.
        cost = planner.bestCost().value()
        if cost < best[0]:
            best[0] = cost
            log.record(counters.nodes, time.perf_counter() - started, cost)
        if (
            counters.nodes >= counters.max_nodes
            or counters.iterations >= max_samples
            or time.perf_counter() >= counters.deadline
        ):
            return True
        counters.iterations += 1
        counters.first_check_pending = True
        return False

    planner.solve(ob.PlannerTerminationCondition(should_stop))
    # OMPL returns as soon as a solution meets the cost threshold, without another call to
    # should_stop: log that last improvement too (the tolerance protocol reads it).
    final_cost = planner.bestCost().value()
    if final_cost < best[0]:
        best[0] = final_cost
        log.record(counters.nodes, time.perf_counter() - started, final_cost)
    path = None
    cost = math.inf
    rejected = 0
    if pdef.hasExactSolution():
        solution = pdef.getSolutionPath()
        candidate = np.array([to_array(s) for s in solution.getStates()])
        if certify_path(problem, candidate):
            path, cost = (
                candidate,
                float(np.sum(np.linalg.norm(np.diff(candidate, axis=0), axis=1))),
            )
        else:
            rejected = 1
    history = log.as_arrays()
    first = len(history["nodes"]) > 0
    return PlanResult(
        planner=name,
        success=path is not None,
        path=path,
        cost=cost,
        nodes=counters.nodes,
        samples=counters.iterations,
        sampling_failures=counters.failures,
        collision_checks=counters.checks,
        wall_time=time.perf_counter() - started,
        time_to_first_solution=float(history["time"][0]) if first else None,
        nodes_to_first_solution=int(history["nodes"][0]) if first else None,
        history=history,
        seed=settings.seed,
        certification_failures=rejected,
    )


def _make_motion_validator(ob, si, checker: CollisionChecker, counters: _Counters, to_array):
    """A ``MotionValidator`` calling our exact-for-points / conservative ``edge_free``."""

    class EdgeMotionValidator(ob.MotionValidator):
        def checkMotion(self, s1, s2, *last_valid) -> bool:  # noqa: N802 (OMPL's name)
            counters.checks += 1
            free = bool(checker.edge_free(to_array(s1), to_array(s2)))
            if counters.first_check_pending:
                counters.first_check_pending = False
                if free:
                    counters.nodes += 1
                else:
                    counters.failures += 1
            return free

    return EdgeMotionValidator(si)


def _start_in_goal(
    problem: Problem, settings: PlanSettings, name: str, started: float
) -> PlanResult:
    """The result for a start that lies in the goal region: the path ``[start, start]``."""
    path = np.array([problem.start, problem.start], dtype=np.float64)
    if not certify_path(problem, path):  # a start in collision: no path at all
        path = None
    log = AnytimeLog(started)
    if path is not None:
        log.record(1, time.perf_counter() - started, 0.0)
    history = log.as_arrays()
    return PlanResult(
        planner=name,
        success=path is not None,
        path=path,
        cost=0.0 if path is not None else math.inf,
        nodes=1,
        samples=0,
        sampling_failures=0,
        collision_checks=0,
        wall_time=time.perf_counter() - started,
        time_to_first_solution=float(history["time"][0]) if path is not None else None,
        nodes_to_first_solution=1 if path is not None else None,
        history=history,
        seed=settings.seed,
    )
