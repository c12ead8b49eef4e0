"""`PlanResult`: what every planner returns, and the helpers that build it (`AnytimeLog`).

What a planner gets is its settings (`temp_gym.planning.settings`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from temp_gym.planning.settings import PlanSettings
    from temp_gym.planning.tree import Tree
    from temp_gym.problem import Problem


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
    simplification: dict[str, Any] | None = None
    """With ``plan(..., simplify=True)`` and a solution: the planner's own path's ``cost`` and
    ``waypoints``, and the ``time`` simplification took (`temp_gym.planning.simplify`, counted
    in ``wall_time``); ``path`` and ``cost`` are then the simplified path's."""
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
            "simplification": None
            if self.simplification is None
            else {
                k: number(v) if isinstance(v, float) else v for k, v in self.simplification.items()
            },
        }

    def summary(self) -> str:
        """One line: planner, success, cost, nodes, time (a hint if it never left its start)."""
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
        if self.simplification is not None:
            before = self.simplification
            line += f"; simplified from cost {before['cost']:.4f} in {before['time']:.3f} s"
        grown = len(self.tree.positions) if self.tree is not None else self.nodes
        if not self.success and grown <= 1 and self.samples > 0:
            line += ("; no motion out of the start was certified (is the start walled in, or "
                     "nearer a surface than the fast checker can leave?)")  # fmt: skip
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
