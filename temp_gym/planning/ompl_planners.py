"""OMPL's RRTstar, InformedRRTstar, RRTConnect and BITstar on our `Problem`: the references.

The planners see the world only through our fast checker: state validity calls
``states_free`` and motion validity is a custom ``MotionValidator`` that calls ``edge_free``
(OMPL's default discrete motion check, at its default resolution, could cut box corners).
The goal region (a ``GoalState`` with threshold ``goal_radius``), goal bias and path-length
objective match our planners. ``ompl_rrt_connect`` is the reference of our ``rrt_connect``
(`temp_gym.planning.rrt_connect`), with the same ``range`` (our step unless given), and
``ompl_bit_star`` is Batch Informed Trees (Gammell et al. 2015), which we do not implement;
neither takes a goal bias.

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
iteration) and the motion validator together count the nodes added (`_NODE_RULES`). RRTstar:
the first motion checked in an iteration is the steered edge, and it adds a node exactly when
that is valid. RRTConnect: every valid motion adds a node (to either tree; both roots count),
and once the budget is spent the validator refuses motions, so that a CONNECT, which runs
without looking at the termination condition, cannot overshoot it. BITstar: the distinct states
that a valid edge was checked to, an upper bound of its tree's vertices (it checks an edge
before it decides to add it). Pruned nodes are still counted, as in our planners, which never
prune. Samples are iterations (BITstar's: an edge or a batch of samples each) and sampling
failures the iterations whose first motion was refused (BITstar's: the edges refused).

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
from temp_gym.planning.settings import PlanSettings, count, flag, positive
from temp_gym.planning.tree import default_step_size
from temp_gym.problem import Problem
from temp_gym.worlds.checkers import certify_path, make_checker
from temp_gym.worlds.collision import CollisionChecker

OMPL_PLANNERS = ("ompl_rrt_star", "ompl_informed_rrt_star", "ompl_rrt_connect", "ompl_bit_star")
_NODE_RULES = {"ompl_rrt_star": "first_motion", "ompl_informed_rrt_star": "first_motion",
               "ompl_rrt_connect": "every_motion", "ompl_bit_star": "new_state"}  # fmt: skip
"""How the motion validator counts the nodes a planner adds (the module docstring says why)."""
NEEDS_GOAL_STATE = ("ompl_rrt_connect", "ompl_bit_star")
"""OMPL's planners that plan to goal states drawn from the goal (its ``GoalState``: the goal
itself), and so cannot plan when the checker refuses it; the others reach the goal region."""
RANGE_FACTOR = 2.0
"""OMPL's ``range`` is this many steering steps unless given (see the module docstring)."""
K_NEAREST = False
"""Whether OMPL's RRTstar uses k-nearest neighbours (True) or its radius rule (False), unless
given."""
_SEEDED = False
MAX_SEED = 2**64 - 2
"""Largest seed the OMPL planners take (OMPL's seeds are 64-bit and may not be 0)."""
MAX_SAMPLES_PER_BATCH = 2**31 - 1
"""Largest ``samples_per_batch`` (BITstar takes an unsigned int)."""


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
    """What the callbacks count during one solve; ``rule``: a value of `_NODE_RULES`."""

    def __init__(self, max_nodes: int, deadline: float, rule: str, start: np.ndarray) -> None:
        self.max_nodes = max_nodes
        self.deadline = deadline
        self.rule = rule
        self.nodes = 2 if rule == "every_motion" else 1  # RRTConnect's goal tree has a root
        self.iterations = 0
        self.failures = 0
        self.checks = 0
        self.first_check_pending = False
        self.vertices = {start.tobytes()}
        """BITstar's: the states counted as its tree's vertices (the start's to begin with)."""


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


@dataclass(frozen=True)
class OMPLRRTConnectSettings(PlanSettings):
    """``ompl_rrt_connect``'s settings: the common ones and ``range``.

    ``goal_bias``, ``stop_at_first`` and ``target_cost`` are not used: RRTConnect samples
    uniformly and stops at its first solution, as our ``rrt_connect``.
    """

    range: float | None = None
    """OMPL's ``range``, the longest extension (world units; None: ``step_size``, whose None is
    the robot's step: the range of our ``rrt_connect``)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.range is not None:
            self._normalize("range", positive(self.range, "range"))
        if self.max_nodes < 2:  # OMPL makes both roots before any budget is read
            raise ValueError(
                f"max_nodes: at least 2 for OMPL's RRTConnect, whose two trees start with a "
                f"root each (both count), got {self.max_nodes}"
            )


@dataclass(frozen=True)
class OMPLBITStarSettings(PlanSettings):
    """``ompl_bit_star``'s settings: the common ones and two of BITstar's own.

    ``goal_bias`` and ``step_size`` are not used: BITstar samples in batches and has no steering
    step.
    """

    k_nearest: bool = K_NEAREST
    """Neighbours by BITstar's k-nearest rule (True, OMPL's default) or its radius rule
    (False, the rule of our planners)."""
    samples_per_batch: int = 100
    """States BITstar samples per batch (OMPL's default)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        self._normalize("k_nearest", flag(self.k_nearest, "k_nearest"))
        batch = count(self.samples_per_batch, "samples_per_batch")
        if batch > MAX_SAMPLES_PER_BATCH:
            raise ValueError(f"samples_per_batch: expected at most 2**31 - 1, got {batch}")
        self._normalize("samples_per_batch", batch)


MIN_EXTENT = 1e-12
"""Shortest diagonal of the bounds OMPL plans in: its longest valid segment (1% of the
diagonal) must be a positive double well above rounding, or ``SpaceInformation.setup`` fails."""


def solve_with_ompl(problem: Problem, settings: PlanSettings, name: str) -> PlanResult:
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
            f"diagonal), got {extent:g}; our planners (rrt_star, informed_rrt_star, "
            "rrt_connect, temp) plan in them"
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
    rule = _NODE_RULES[name]
    counters = _Counters(settings.max_nodes, started + time_limit, rule, problem.start)
    start_free, goal_free = checker.states_free(np.stack([problem.start, problem.goal]))
    counters.checks += 2
    if not start_free or (name in NEEDS_GOAL_STATE and not goal_free):
        # OMPL would report no valid start at once, or wait for a valid goal state, polling the
        # termination condition about every 5 ms until `sample_limit` polls.
        return _no_plan(name, counters, settings, started)

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

    planner = _configured_planner(og, si, problem, settings, name)
    planner.setProblemDefinition(pdef)
    planner.setup()
    anytime = rule != "every_motion"  # RRTConnect has no best cost to poll: it stops when solved

    log = AnytimeLog()
    best = [math.inf]
    max_samples = settings.sample_limit

    def should_stop() -> bool:
        # Called once at the top of every planner iteration: poll the best cost, then arm the
        # motion validator to recognise this iteration's steered edge.
        if anytime:
            cost = planner.bestCost().value()
            if cost < best[0]:
                best[0] = cost
                log.record(counters.nodes, time.perf_counter() - started, cost)
        if counters.first_check_pending and rule == "every_motion":
            counters.failures += 1  # the last EXTEND made no motion: its new state was invalid
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
    solved_at = time.perf_counter() - started
    candidate = None
    if pdef.hasExactSolution():
        solution = pdef.getSolutionPath()
        candidate = np.array([to_array(s) for s in solution.getStates()])
    if anytime:
        final_cost = planner.bestCost().value()
    else:
        final_cost = math.inf if candidate is None else _length(candidate)
    if final_cost < best[0]:
        best[0] = final_cost
        log.record(counters.nodes, solved_at, final_cost)
    path = None
    cost = math.inf
    rejected = 0
    if candidate is not None:
        if certify_path(problem, candidate):
            path, cost = candidate, _length(candidate)
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


def _configured_planner(og, si, problem: Problem, settings: PlanSettings, name: str):
    """OMPL's planner ``name`` on ``si``, with the settings of ``settings`` it takes."""
    step = default_step_size(problem) if settings.step_size is None else settings.step_size
    if name == "ompl_bit_star":
        planner = og.BITstar(si)
        planner.setUseKNearest(settings.k_nearest)
        planner.setSamplesPerBatch(settings.samples_per_batch)
        return planner
    if name == "ompl_rrt_connect":
        planner = og.RRTConnect(si)
        planner.setRange(step if settings.range is None else settings.range)
        return planner
    planner = og.RRTstar(si) if name == "ompl_rrt_star" else og.InformedRRTstar(si)
    planner.setRange(RANGE_FACTOR * step if settings.range is None else settings.range)
    planner.setKNearest(settings.k_nearest)
    planner.setGoalBias(settings.goal_bias)
    return planner


def _length(path: np.ndarray) -> float:
    """The length of a path of states ``(K, d)``."""
    return float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))


def _make_motion_validator(ob, si, checker: CollisionChecker, counters: _Counters, to_array):
    """A ``MotionValidator`` calling our exact-for-points / conservative ``edge_free``.

    It counts the nodes the planner adds by ``counters.rule`` (`_NODE_RULES`).
    """

    class EdgeMotionValidator(ob.MotionValidator):
        def checkMotion(self, s1, s2, *last_valid) -> bool:  # noqa: N802 (OMPL's name)
            rule, pending = counters.rule, counters.first_check_pending
            counters.first_check_pending = False
            if rule == "every_motion" and counters.nodes >= counters.max_nodes:
                return False  # the budget is spent: a CONNECT would add nodes past it
            counters.checks += 1
            end = to_array(s2)
            free = bool(checker.edge_free(to_array(s1), end))
            if rule == "every_motion":
                counters.nodes += free
                counters.failures += pending and not free
            elif rule == "new_state":
                key = end.tobytes()
                if free and key not in counters.vertices:
                    counters.vertices.add(key)
                    counters.nodes += 1
                counters.failures += not free
            elif pending:
                counters.nodes += free
                counters.failures += not free
            return free

    return EdgeMotionValidator(si)


def _no_plan(name: str, counters: _Counters, settings: PlanSettings, started: float) -> PlanResult:
    """The result of a run that cannot start.

    Its checker refuses the start, or the goal of a planner that needs goal states
    (`NEEDS_GOAL_STATE`).
    """
    return PlanResult(
        planner=name,
        success=False,
        path=None,
        cost=math.inf,
        nodes=counters.nodes,
        samples=0,
        sampling_failures=0,
        collision_checks=counters.checks,
        wall_time=time.perf_counter() - started,
        time_to_first_solution=None,
        nodes_to_first_solution=None,
        history=AnytimeLog(started).as_arrays(),
        seed=settings.seed,
    )


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
