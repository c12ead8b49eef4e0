"""RRT-Connect (Kuffner and LaValle 2000): two RRT trees, from the start and from the goal.

The semantics are OMPL's ``RRTConnect``. Each iteration draws one uniform sample, EXTENDs the
tree whose turn it is one step towards it (at most ``range``), then CONNECTs the other tree
towards the new node: steps of at most ``range`` until it reaches that node or a motion
collides. Then the trees swap roles. The goal tree is rooted at ``problem.goal`` (a free state,
the centre of the goal region), and its motions are checked in the direction the joined path
runs, towards the goal.

The run stops at the first solution: the trees joined at one state, or a node of the start tree
inside the goal region (OMPL's planner only joins trees, since a goal there is a set of states
to root the goal tree at; here the goal region is a ball around one state, and a start tree
that enters it has solved the problem). It is not an anytime planner: ``stop_at_first`` and
``target_cost`` change nothing, and it samples uniformly, so ``goal_bias`` is not used.

Nodes are counted as the other planners count them: both trees' nodes, roots included, count
against ``max_nodes`` and in the result (so nodes to a first solution compare with a one-tree
planner's). On a join, the goal tree's branch from the joining node to the goal is appended to
the start tree as a chain of nodes (up to the first node inside the goal region); the result's
tree is the start tree with that chain, and its path is certified by the exact checker like
any other planner's (`temp_gym.planning.result.tree_plan_result`).

The iterations run in `temp_gym.planning._compiled_connect` when the checker has a compiled path,
else in Python over the checker's ``edge_free``; both grow the same trees.

Example:
    >>> result = plan(problem, planner="rrt_connect", seed=0, max_nodes=2000)
    >>> result.success, len(result.history["nodes"])
    (True, 1)
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from temp_gym.planning import _compiled_connect as compiled
from temp_gym.planning._compiled_connect import ADVANCED, REACHED, TRAPPED
from temp_gym.planning._compiled_tree import (
    CHECKS,
    FALLBACK_BATCH,
    GOAL_RADIUS_SQ,
    _count_new_node,
    graft_branch,
    slice_length,
)
from temp_gym.planning._generator import address
from temp_gym.planning._kernels import insert_node, nearest_and_steer
from temp_gym.planning.result import AnytimeLog, PlanResult, tree_plan_result
from temp_gym.planning.samplers import UniformSampler
from temp_gym.planning.settings import PlanSettings, positive
from temp_gym.planning.tree import Tree, default_step_size
from temp_gym.problem import Problem
from temp_gym.worlds.collision.compiled import compiled_context_of

NAME = "rrt_connect"
"""The planner's name in the registry and in its results."""


@dataclass(frozen=True)
class RRTConnectSettings(PlanSettings):
    """``rrt_connect``'s settings: the common ones (`PlanSettings`) and ``range``.

    ``stop_at_first``, ``target_cost`` and ``goal_bias`` are not used: RRT-Connect always stops
    at its first solution and samples uniformly (the module docstring says why).
    """

    range: float | None = None
    """Longest extension, as OMPL's ``range`` (world units; radians for an arm); None:
    ``step_size``, whose None is the robot's step (`temp_gym.planning.tree.default_step_size`)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.range is not None:
            self._normalize("range", positive(self.range, "range"))


def extension_range(problem: Problem, settings: RRTConnectSettings) -> float:
    """The longest extension: ``range``, else ``step_size``, else the robot's step."""
    if settings.range is not None:
        return settings.range
    return default_step_size(problem) if settings.step_size is None else settings.step_size


def rrt_connect(problem: Problem, settings: RRTConnectSettings) -> PlanResult:
    """RRT-Connect on ``problem`` until its first solution or a stop rule (module docstring)."""
    log = AnytimeLog()
    step = extension_range(problem, settings)
    tree = Tree(problem, step_size=step)
    if tree.best_node >= 0:  # the start lies in the goal region
        log.record_tree(tree)
    elif settings.max_nodes >= 2:  # room for the goal tree's root
        goal_tree = Tree(problem.swapped(), step_size=step, checker_of=tree)
        rng = np.random.default_rng(settings.seed)
        status, link = connect_trees(tree, goal_tree, settings, rng, log.started)
        _finish(tree, goal_tree, status, link, log)
    return tree_plan_result(problem, tree, NAME, settings, log)


def connect_trees(
    tree: Tree,
    goal_tree: Tree,
    settings: PlanSettings,
    rng: np.random.Generator,
    started: float,
    compiled_loop: bool | None = None,
) -> tuple[int, tuple[int, int] | None]:
    """Grow both trees until a solution or a stop rule: ``(status, link)``.

    ``status`` is one of `_compiled_connect`'s: `CONNECTED` (``link``: the nodes of ``tree``
    and ``goal_tree`` at the same state), `SOLVED` (``tree`` reached the goal region) or
    `DONE` (a node, sample or time limit; ``link`` None). ``started``: when the planner's
    clock started (a perf_counter value). ``compiled_loop``: as in
    `temp_gym.planning.anytime.grow_anytime` (None: compiled whenever the checker can).
    """
    context = compiled_context_of(tree.checker) if compiled_loop is not False else None
    if compiled_loop and context is None:
        raise ValueError("compiled_loop: the tree's checker has no compiled path")
    deadline = settings.deadline(started)
    if context is not None:
        return _connect_compiled(tree, goal_tree, settings, rng, deadline, context)
    return _connect_python(tree, goal_tree, settings, rng, deadline)


def _connect_compiled(
    tree: Tree,
    goal_tree: Tree,
    settings: PlanSettings,
    rng: np.random.Generator,
    deadline: float,
    context: tuple,
) -> tuple[int, tuple[int, int] | None]:
    """`connect_trees` in `_compiled_connect.connect_slice`, a slice at a time."""
    problem = tree.problem
    goal = np.ascontiguousarray(problem.goal, dtype=np.float64)
    start = np.ascontiguousarray(problem.start, dtype=np.float64)
    bounds = np.ascontiguousarray(problem.bounds, dtype=np.float64)
    buffer = np.empty((FALLBACK_BATCH, problem.dim))
    cursor = np.array([FALLBACK_BATCH], dtype=np.int64)
    target = np.empty(problem.dim)
    state = np.zeros(len(compiled.STATE), dtype=np.int64)
    limits = np.array([settings.max_nodes, min(settings.sample_limit, np.iinfo(np.int64).max)],
                      dtype=np.int64)  # fmt: skip
    link = np.full(len(compiled.LINK), -1, dtype=np.int64)
    rng_address = address(rng)  # `rng` stays alive here while the slices draw from it
    if time.perf_counter() >= deadline:
        return compiled.DONE, None
    iterations = slice_length(deadline, time.perf_counter(), 0.0)
    while True:
        ours, theirs = tree.compiled_state(), goal_tree.compiled_state()
        began, samples = time.perf_counter(), tree.samples + goal_tree.samples
        status = compiled.connect_slice(
            ours, theirs, goal, start, bounds, context, rng_address, buffer, cursor, target,
            state, limits, link, iterations,
        )  # fmt: skip
        tree.load_compiled_state(ours[1], ours[2])
        goal_tree.load_compiled_state(theirs[1], theirs[2])
        if status == compiled.CONNECTED:
            return status, (int(link[compiled.START_NODE]), int(link[compiled.GOAL_NODE]))
        if status in (compiled.SOLVED, compiled.DONE):
            return status, None
        now = time.perf_counter()
        if now >= deadline:
            return compiled.DONE, None
        if status == compiled.FULL_START:
            tree.grow()
        elif status == compiled.FULL_GOAL:
            goal_tree.grow()
        else:  # one sample per iteration
            pace = (now - began) / max(tree.samples + goal_tree.samples - samples, 1)
            iterations = slice_length(deadline, now, pace)


def _connect_python(
    tree: Tree,
    goal_tree: Tree,
    settings: PlanSettings,
    rng: np.random.Generator,
    deadline: float,
) -> tuple[int, tuple[int, int] | None]:
    """`connect_trees` driven from Python over the checker's ``edge_free`` (the reference)."""
    sampler = UniformSampler(tree.problem.bounds)
    trees, goals = (tree, goal_tree), (tree.problem.goal, tree.problem.start)
    turn = 0
    while True:
        nodes = tree.num_nodes + goal_tree.num_nodes
        if nodes >= settings.max_nodes or tree.samples + goal_tree.samples >= settings.sample_limit:
            return compiled.DONE, None
        if time.perf_counter() >= deadline:
            return compiled.DONE, None
        grown, extended = trees[turn], turn
        if grown.num_nodes == grown.capacity:
            grown.grow()
        before = grown.num_nodes
        _, node = step_towards(grown, goals[extended], sampler.sample(rng), extended == 0)
        grown.samples += 1
        turn = 1 - turn
        if grown.num_nodes == before:
            grown.sampling_failures += 1
            continue
        if tree.best_node >= 0:
            return compiled.SOLVED, None
        target = grown.positions[node].copy()
        while True:  # CONNECT: the tree that extends next goes towards the new node
            if tree.num_nodes + goal_tree.num_nodes >= settings.max_nodes:
                return compiled.DONE, None
            other = trees[turn]
            if other.num_nodes == other.capacity:
                other.grow()
            outcome, reached = step_towards(other, goals[turn], target, turn == 0)
            if tree.best_node >= 0:
                return compiled.SOLVED, None
            if outcome == REACHED:
                return compiled.CONNECTED, ((reached, node) if turn == 0 else (node, reached))
            if outcome == TRAPPED:
                break


def step_towards(
    tree: Tree, goal: np.ndarray, target: np.ndarray, forward: bool
) -> tuple[int, int]:
    """`_compiled_connect.grow_towards` from Python, over the tree's checker: ``(outcome, node)``.

    The tree must have room for one more node.
    """
    arrays, counters, best_cost, params = tree.compiled_state()
    positions, costs, links, goal_nodes, near_idx, near_dist, cand_idx, _, new, grid = arrays
    count = tree.num_nodes
    nearest, distance = nearest_and_steer(
        positions, count, target, tree.step_size, new, grid, near_idx
    )
    if not distance > 0.0:
        return REACHED, int(nearest)
    reached = distance <= tree.step_size
    if reached:
        new[:] = target
    tree.collision_checks += 1
    ends = (positions[nearest], new) if forward else (new, positions[nearest])
    if not tree.checker.edge_free(*ends):
        return TRAPPED, int(nearest)
    goal = np.ascontiguousarray(goal, dtype=np.float64)
    cost, reached_goal, _ = insert_node(
        positions, costs, links, count, new, nearest, goal, params[GOAL_RADIUS_SQ], near_idx,
        near_dist, 0, cand_idx,
    )  # fmt: skip
    counters[CHECKS] = tree.collision_checks
    _count_new_node(counters, goal_nodes, best_cost, count, cost, reached_goal)
    tree.load_compiled_state(counters, best_cost)
    return (REACHED if reached else ADVANCED), count


def _finish(
    tree: Tree, goal_tree: Tree, status: int, link: tuple[int, int] | None, log: AnytimeLog
) -> None:
    """Give ``tree`` the solution and both trees' counters; log the solution.

    On a join, the goal tree's branch past the joining node is appended to ``tree``.
    """
    grafted = 0
    if status == compiled.CONNECTED and link is not None:
        branch = goal_tree.path_to(link[1])[::-1][1:].copy()  # past the shared state, to the goal
        while tree.capacity < tree.num_nodes + len(branch):
            tree.grow()
        arrays, counters, best_cost, params = tree.compiled_state()
        goal = np.ascontiguousarray(tree.problem.goal, dtype=np.float64)
        grafted = graft_branch(arrays, counters, best_cost, params, goal, link[0], branch)
        tree.load_compiled_state(counters, best_cost)
    tree.samples += goal_tree.samples
    tree.sampling_failures += goal_tree.sampling_failures
    tree.collision_checks += goal_tree.collision_checks
    log.extra_nodes = goal_tree.num_nodes - grafted
    if tree.best_node >= 0:
        log.record_tree(tree)


__all__ = ["NAME", "RRTConnectSettings", "connect_trees", "extension_range", "rrt_connect"]
