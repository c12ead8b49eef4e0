"""`PlanResult` and `PlanSettings`: what every planner gets and returns."""

from __future__ import annotations

import math
import numbers
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from temp_gym.planning.tree import Tree
    from temp_gym.problem import Problem


MAX_COUNT = 2**53
"""Largest node or sample budget: counts above it no longer convert to float exactly (and
no tree that large fits in memory)."""


def _count(value: object, name: str, minimum: int = 1) -> int:
    """An integer in ``[minimum, MAX_COUNT]``, or a `ValueError` naming ``name``."""
    if not isinstance(value, numbers.Integral) or isinstance(value, bool):
        raise ValueError(f"{name}: expected an integer of at least {minimum}, got {value!r}")
    if not minimum <= value <= MAX_COUNT:
        shown = value if abs(value) < 10**20 else f"an integer of {len(str(value))} digits"
        raise ValueError(f"{name}: expected an integer in [{minimum}, 2**53], got {shown}")
    return int(value)


def _real(value: object, name: str, expected: str) -> float:
    """``float(value)`` for a real number (not bool), or a `ValueError` naming ``name``."""
    if not isinstance(value, numbers.Real) or isinstance(value, bool):
        raise ValueError(f"{name}: expected {expected}, got {value!r}")
    try:
        return float(value)
    except OverflowError:
        raise ValueError(f"{name}: expected {expected}, got a number beyond float range") from None


def _finite_at_least(value: object, name: str, least: float) -> float:
    """``float(value)`` for a finite real number of at least ``least`` (not bool).

    Anything else is a `ValueError` naming ``name``.
    """
    expected = f"a finite number of at least {least:g}"
    number = _real(value, name, expected)
    if not (math.isfinite(number) and number >= least):
        raise ValueError(f"{name}: expected {expected}, got {value!r}")
    return number


def near_goal_factor(value: object, name: str = "attention_near_goal_factor") -> float:
    """A stall-patience factor near the goal: a finite real number of at least 1."""
    return _finite_at_least(value, name, 1.0)


def resume_factor(value: object, name: str = "attention_resume") -> float:
    """A resume factor: a finite real number of at least 0 (0: never resume).

    It counts the classical nodes between a stall and the resumed attention phase in stall
    patiences (`PlanSettings.attention_resume`).
    """
    return _finite_at_least(value, name, 0.0)


def resume_growth(value: object, name: str = "attention_resume_growth") -> float:
    """A growth factor of the classical turns between resumed phases: finite, at least 1.

    (`PlanSettings.attention_resume_growth`; 1: every turn as long as the first.)
    """
    return _finite_at_least(value, name, 1.0)


def local_fallback_count(value: object, name: str = "attention_local_fallback") -> int:
    """A count of replacements drawn near a colliding proposal, or a `ValueError` naming ``name``.

    (`PlanSettings.attention_local_fallback`; 0: none, Algorithm 1.)
    """
    return _count(value, name, 0)


def rounds_count(value: object, name: str = "attention_rounds") -> int:
    """A number of rounds of the attention phase after it stalled both ways: an integer >= 0.

    (`PlanSettings.attention_rounds`; 0: none.)
    """
    return _count(value, name, 0)


def seed_value(value: object, name: str = "seed") -> int:
    """A seed of a generator: a non-negative integer (not bool), as numpy takes it."""
    if not isinstance(value, numbers.Integral) or isinstance(value, bool) or value < 0:
        raise ValueError(f"{name}: expected a non-negative integer, got {value!r}")
    return int(value)


def noise_level(value: object, name: str = "noise_std") -> float:
    """A standard deviation of output noise: a finite real number of at least 0 (not bool)."""
    return _finite_at_least(value, name, 0.0)


def share(value: object, name: str) -> float:
    """A probability: a real number in ``[0, 1]``."""
    share = _real(value, name, "a number in [0, 1]")
    if not 0.0 <= share <= 1.0:
        raise ValueError(f"{name}: expected a number in [0, 1], got {value!r}")
    return share


@dataclass(frozen=True)
class PlanSettings:
    """The arguments of `temp_gym.planning.plan`, handed to every planner; they check themselves.

    Building one validates and normalizes every field (plain ``int`` and ``float``; a policy
    seen through `temp_gym.planning.policy.as_sampling_policy`), so a planner never meets a
    negative budget, a NaN or a bool where a number belongs.

    Raises:
        ValueError: naming the first invalid field and what it expected.
    """

    seed: int = 0
    """Seed of the planner's random generator."""
    max_nodes: int = 5000
    """Stop once the tree has this many nodes (root included)."""
    time_limit: float | None = None
    """Stop after this many seconds of wall time (None: no limit)."""
    stop_at_first: bool = False
    """Stop at the first solution."""
    step_size: float | None = None
    """Steering step; None picks `temp_gym.planning.tree.default_step_size`."""
    goal_bias: float = 0.05
    """Probability of sampling the goal itself."""
    target_cost: float | None = None
    """Stop once a solution at most this costly is found."""
    max_samples: int | None = None
    """Stop after this many samples; None means ``100 * max_nodes`` (a walled-in start)."""

    policy: Any = field(default=None, compare=False, repr=False)
    """Sampling policy of the ``temp`` planner (None: the shipped one for the robot)."""
    attention_nodes: int | None = None
    """``temp`` planner: most tree nodes for attention-based planning, the n of Algorithm 1
    (None: the policy's ``attention_nodes`` if it has one, as shipped policies do; else
    ``max_nodes``)."""
    attention_uniform: float | None = None
    """``temp`` planner: probability of a uniform sample instead of the policy's in the
    attention phase (None: the policy's own setting, else 0)."""
    attention_patience: int | None = None
    """``temp`` planner: attention-phase nodes in a row without a closer approach to the goal
    before classical planning takes over (None: `temp_gym.planning.attention.default_patience`;
    0: never, Algorithm 1 as written)."""
    attention_near_goal_factor: float | None = None
    """``temp`` planner: how many times that patience the attention phase waits once the tree's
    closest approach to the goal is within `temp_gym.planning.attention.NEAR_GOAL_SHARE` of the
    start-goal distance (None: the policy's own setting, else 1, the same patience
    everywhere)."""
    attention_follow_fallback: float | None = None
    """``temp`` planner: probability that the policy continues from a fallback node (a uniform
    sample that replaced a colliding proposal) which brought the tree no closer to the goal;
    otherwise the path so far it reads stays the one it read before (None: the policy's own
    setting, else 1: always, Algorithm 1's UpdatePath)."""
    attention_keep_chunk: bool | None = None
    """``temp`` planner, for a policy that proposes several samples per call (a chunk): when a
    proposal collided and a uniform fallback sample replaced it, the attention phase goes on
    with the chunk's next proposal (True) or drops the rest of the chunk and calls the policy
    again (False; None means False). True reaches a first solution with fewer nodes and MPT
    calls but costlier paths, so an anytime run takes longer to a good one (README)."""
    attention_resume: float | None = None
    """``temp`` planner: after the attention phase stalls, classical planning adds this many
    times the stall patience in nodes, then the attention phase resumes from the newest node,
    in turns until the first solution (None: the policy's own setting, else
    `temp_gym.planning.attention.RESUME_AFTER`; 0: never, classical planning keeps the rest
    of the budget)."""
    attention_resume_growth: float | None = None
    """``temp`` planner: each classical turn between resumed attention phases is this many
    times longer than the one before (None: the policy's own setting, else 1: equal turns of
    ``attention_resume`` patiences). Above 1, a policy that keeps stalling hands more and more
    of the search to Informed RRT*: its resumed phases take a shrinking share of the nodes."""

    goal_tree: bool | None = None
    """``temp`` planner: when the attention phase ends without a solution, grow a second tree
    from the goal beside the planner's until the two meet (`temp_gym.planning.goal_tree`;
    None means True; False: Informed RRT* alone, as before)."""

    attention_from_goal: bool | None = None
    """``temp`` planner: when the attention phase stalls, the policy first grows the goal tree
    (its attention phase on the swapped problem) until the two trees meet or it stalls too
    (`temp_gym.planning.goal_tree.GoalTree.grow_by_attention`; None means True with the goal
    tree; False: the goal tree grows by Informed RRT*'s samples alone). Needs the goal tree."""

    attention_rounds: int | None = None
    """``temp`` planner: after the attention phases from the start and from the goal both
    stalled, up to this many more rounds of the two, a resumed phase on each tree in turn
    (`temp_gym.planning.goal_tree.GoalTree.grow_in_rounds`; None: the policy's own setting,
    else `temp_gym.planning.goal_tree.ATTENTION_ROUNDS`; 0: none). Needs the phase from the
    goal."""

    attention_local_fallback: int | None = None
    """``temp`` planner: when a policy's proposal collides, this many of its replacements are
    drawn near it before uniform ones (`temp_gym.planning.tree.Tree.extend_with_fallback`;
    None: the policy's own setting, else 0, Algorithm 1's uniform replacements)."""

    def __post_init__(self) -> None:
        def normalize(name: str, value: object) -> None:
            object.__setattr__(self, name, value)

        normalize("seed", seed_value(self.seed))
        normalize("max_nodes", _count(self.max_nodes, "max_nodes"))
        if self.time_limit is not None:
            limit = _real(self.time_limit, "time_limit", "a non-negative number or None")
            if not limit >= 0:
                raise ValueError(f"time_limit: expected a non-negative number or None, got {limit}")
            normalize("time_limit", limit)
        if not isinstance(self.stop_at_first, (bool, np.bool_)):
            raise ValueError(f"stop_at_first: expected True or False, got {self.stop_at_first!r}")
        normalize("stop_at_first", bool(self.stop_at_first))
        if self.step_size is not None:
            step = _real(self.step_size, "step_size", "a positive number or None")
            if not (math.isfinite(step) and step > 0):
                raise ValueError(f"step_size: expected a positive number or None, got {step}")
            normalize("step_size", step)
        normalize("goal_bias", share(self.goal_bias, "goal_bias"))
        if self.target_cost is not None:
            target = _real(self.target_cost, "target_cost", "a number or None")
            if math.isnan(target):
                raise ValueError("target_cost: expected a number or None, got nan")
            normalize("target_cost", target)
        for name, minimum in (
            ("max_samples", 1),
            ("attention_nodes", 1),
            ("attention_patience", 0),
            ("attention_local_fallback", 0),
        ):
            value = getattr(self, name)
            if value is not None:
                normalize(name, _count(value, name, minimum))
        if self.attention_uniform is not None:
            normalize("attention_uniform", share(self.attention_uniform, "attention_uniform"))
        if self.attention_follow_fallback is not None:
            normalize(
                "attention_follow_fallback",
                share(self.attention_follow_fallback, "attention_follow_fallback"),
            )
        for name in ("attention_keep_chunk", "goal_tree", "attention_from_goal"):
            value = getattr(self, name)
            if value is not None:
                if not isinstance(value, (bool, np.bool_)):
                    raise ValueError(f"{name}: expected True, False or None, got {value!r}")
                normalize(name, bool(value))
        if self.attention_from_goal and self.goal_tree is False:
            raise ValueError(
                "attention_from_goal: the policy grows the goal tree, which goal_tree=False "
                "turns off; pass attention_from_goal=False or None with it"
            )
        if self.attention_rounds is not None:
            normalize("attention_rounds", rounds_count(self.attention_rounds))
        if self.attention_rounds and (self.attention_from_goal is False or self.goal_tree is False):
            raise ValueError(
                "attention_rounds: the rounds follow the attention phase from the goal, which "
                "attention_from_goal=False or goal_tree=False turns off; pass 0 or None with them"
            )
        if self.attention_resume is not None:
            normalize("attention_resume", resume_factor(self.attention_resume))
        if self.attention_resume_growth is not None:
            normalize("attention_resume_growth", resume_growth(self.attention_resume_growth))
        if self.attention_near_goal_factor is not None:
            normalize(
                "attention_near_goal_factor", near_goal_factor(self.attention_near_goal_factor)
            )
        if self.policy is not None:
            from temp_gym.planning.policy import as_sampling_policy

            normalize("policy", as_sampling_policy(self.policy))  # a ValueError for others

    def derived(self, **changes: Any) -> PlanSettings:
        """A copy with ``changes``, which are not checked again.

        For the budgets a planner derives from its checked settings in its inner loops (a
        turn's node budget, the samples left), where `dataclasses.replace`, which checks
        every field again, would cost more than a short turn.
        """
        unknown = changes.keys() - self.__dict__.keys()
        if unknown:
            raise TypeError(f"derived(): unknown settings {sorted(unknown)}")
        copy = object.__new__(PlanSettings)
        copy.__dict__.update(self.__dict__)
        copy.__dict__.update(changes)
        return copy

    def deadline(self, started: float) -> float:
        """When a run started at ``started`` runs out of time (a perf_counter value; inf: never)."""
        return math.inf if self.time_limit is None else started + self.time_limit

    @property
    def sample_limit(self) -> int:
        """The effective sample limit."""
        return 100 * self.max_nodes if self.max_samples is None else self.max_samples


@dataclass(frozen=True)
class PlanTree:
    """The planner's tree when it stopped: what a viewer draws (`temp_gym.viewer`).

    Attributes:
        positions: Node states ``(N, d)``; node 0 is the start.
        parents: Parent index per node ``(N,)``, -1 for the root.
    """

    positions: np.ndarray
    parents: np.ndarray

    @classmethod
    def of(cls, tree: Tree) -> PlanTree:
        """A read-only copy of ``tree``'s nodes and parents (the tree may go on growing)."""
        positions = tree.positions[: tree.num_nodes].copy()
        parents = tree.parents.copy()
        for array in (positions, parents):
            array.setflags(write=False)
        return cls(positions, parents)


@dataclass
class PlanResult:
    """The outcome of one planning run; `to_dict` is JSON-able (the CLI writes it)."""

    planner: str
    """Registered planner name."""
    success: bool
    """Whether a path reaching the goal region was found and certified collision-free."""
    path: np.ndarray | None
    """States ``(K, d)`` from start to a state in the goal region, or None."""
    cost: float
    """Length of ``path`` (inf without one)."""
    nodes: int
    """Tree nodes added, root included (planners that prune still count pruned nodes; TEMP
    counts its goal tree's too, `temp_gym.planning.goal_tree`)."""
    samples: int
    """Samples drawn."""
    sampling_failures: int
    """Samples that added no node: the steered edge collided (or the sample was a node)."""
    collision_checks: int
    """State and edge checks performed by the planner."""
    wall_time: float
    """Seconds spent planning."""
    time_to_first_solution: float | None
    """Seconds until the first solution (None: never)."""
    nodes_to_first_solution: int | None
    """Tree size at the first solution (None: never)."""
    history: dict[str, np.ndarray] = field(default_factory=dict)
    """Anytime log, one entry per best-cost improvement: ``nodes``, ``time``, ``best_cost``."""
    seed: int = 0
    """Seed of the run."""
    certification_failures: int = 0
    """Solutions the exact checker rejected (never reported as the path)."""
    attention: dict[str, Any] | None = None
    """``temp`` planner only: the attention-based phase's ``solved``, ``nodes``, ``time``,
    ``cost``, ``samples``, ``policy_samples`` and ``sampling_failures`` (what the paper
    reports for TEMP), ``policy_calls``, ``stop`` (why it ended,
    `temp_gym.planning.attention.STOPS`) and ``compiled`` (whether it ran compiled), all of
    the first phase; and ``resumes``, how many times the phase resumed after a stall."""
    tree: PlanTree | None = field(default=None, repr=False, compare=False)
    """The tree grown from the start (None: a planner that does not expose one, as OMPL's);
    not part of `to_dict`, so result files stay small."""

    def cost_at(self, nodes: int) -> float:
        """Best cost once the tree had ``nodes`` nodes, read off the history (inf: none yet)."""
        counts = self.history.get("nodes", np.empty(0))
        hits = np.flatnonzero(np.asarray(counts) <= nodes)
        return math.inf if len(hits) == 0 else float(self.history["best_cost"][hits[-1]])

    def to_dict(self) -> dict[str, Any]:
        """A JSON-able dictionary (inf costs become None)."""

        def number(x: float | None) -> float | None:
            return None if x is None or not math.isfinite(x) else float(x)

        return {
            "planner": self.planner,
            "success": bool(self.success),
            "path": None if self.path is None else np.asarray(self.path).tolist(),
            "cost": number(self.cost),
            "nodes": int(self.nodes),
            "samples": int(self.samples),
            "sampling_failures": int(self.sampling_failures),
            "collision_checks": int(self.collision_checks),
            "wall_time": float(self.wall_time),
            "time_to_first_solution": number(self.time_to_first_solution),
            "nodes_to_first_solution": self.nodes_to_first_solution,
            "history": {k: np.asarray(v).tolist() for k, v in self.history.items()},
            "seed": int(self.seed),
            "certification_failures": int(self.certification_failures),
            "attention": None
            if self.attention is None
            else {k: number(v) if isinstance(v, float) else v for k, v in self.attention.items()},
        }

    def summary(self) -> str:
        """One line: planner, success, cost, nodes, time."""
        status = f"cost {self.cost:.4f}" if self.success else "no solution"
        line = (
            f"{self.planner} seed={self.seed}: {status}, {self.nodes} nodes, "
            f"{self.samples} samples ({self.sampling_failures} failed), "
            f"{self.collision_checks} collision checks, {self.wall_time:.3f} s"
        )
        if self.attention is not None:
            phase = self.attention
            stop = phase.get("stop", "solved" if phase["solved"] else "attention_budget")
            outcome = f"cost {phase['cost']:.4f}" if phase["solved"] else f"{stop}, no solution"
            line += f"; attention phase: {outcome} at {phase['nodes']} nodes, {phase['time']:.3f} s"
        return line


class AnytimeLog:
    """A planner's clock and its record of ``(nodes, time, best_cost)`` at every improvement.

    Times are seconds since ``started`` (default: when the log is made, the planner's start);
    the first entry is the first solution.
    """

    def __init__(self, started: float | None = None) -> None:
        self.started = time.perf_counter() if started is None else float(started)
        self.extra_nodes = 0
        """Nodes the planner grew outside its tree (TEMP's goal tree,
        `temp_gym.planning.goal_tree`), counted in every record and in the result's nodes."""
        self.nodes: list[int] = []
        self.times: list[float] = []
        self.costs: list[float] = []

    def elapsed(self) -> float:
        """Seconds since the planner started."""
        return time.perf_counter() - self.started

    def record(self, nodes: int, elapsed: float, cost: float) -> None:
        """Append one improvement."""
        self.nodes.append(int(nodes))
        self.times.append(float(elapsed))
        self.costs.append(float(cost))

    def record_tree(self, tree: Tree) -> None:
        """Append the tree's new best cost, now."""
        self.record(tree.num_nodes + self.extra_nodes, self.elapsed(), tree.best_cost)

    @property
    def first_time(self) -> float | None:
        """Seconds to the first solution (None: none yet)."""
        return self.times[0] if self.times else None

    @property
    def first_nodes(self) -> int | None:
        """Tree nodes at the first solution (None: none yet)."""
        return self.nodes[0] if self.nodes else None

    def as_arrays(self) -> dict[str, np.ndarray]:
        """The history dictionary of `PlanResult`."""
        return {
            "nodes": np.asarray(self.nodes, dtype=np.int64),
            "time": np.asarray(self.times, dtype=np.float64),
            "best_cost": np.asarray(self.costs, dtype=np.float64),
        }


def certified_tree_solution(
    problem: Problem, tree: Tree, max_tries: int = 32
) -> tuple[np.ndarray | None, float, int]:
    """The cheapest goal-node path the exact checker certifies: ``(path, cost, rejected)``.

    A path has at least two states, as OMPL's do: a start inside the goal region gives
    ``[start, start]`` at cost 0.

    Goal nodes are tried in cost order (at most ``max_tries``), so a rare fast-versus-exact
    disagreement falls back to the next-best solution instead of failing the run;
    ``rejected`` counts the paths the exact checker rejected.
    """
    from temp_gym.worlds.checkers import certify_path

    goal_nodes = tree.goal_nodes
    order = goal_nodes[np.argsort(tree.costs[goal_nodes], kind="stable")][:max_tries]
    rejected = 0
    for node in order:
        path = tree.path_to(int(node))
        if len(path) == 1:  # the start lies in the goal region: one motion of length 0
            path = np.repeat(path, 2, axis=0)
        if certify_path(problem, path):
            return path, float(tree.costs[node]), rejected
        rejected += 1
    return None, math.inf, rejected


def tree_plan_result(
    problem: Problem,
    tree: Tree,
    planner: str,
    settings: PlanSettings,
    log: AnytimeLog,
    **extra: Any,
) -> PlanResult:
    """The `PlanResult` of a finished tree: certified best path, counters, wall time, history."""
    path, cost, rejected = certified_tree_solution(problem, tree)
    return PlanResult(
        planner=planner,
        success=path is not None,
        path=path,
        cost=cost,
        nodes=tree.num_nodes + log.extra_nodes,
        samples=tree.samples,
        sampling_failures=tree.sampling_failures,
        collision_checks=tree.collision_checks,
        wall_time=log.elapsed(),
        time_to_first_solution=log.first_time,
        nodes_to_first_solution=log.first_nodes,
        history=log.as_arrays(),
        seed=settings.seed,
        certification_failures=rejected,
        **extra,
        tree=PlanTree.of(tree),  # last: copied after the clock stopped
    )
