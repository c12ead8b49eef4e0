"""The anytime loop: RRT* extensions from goal-biased samples until a stop rule fires.

RRT* (uniform samples), Informed RRT* (informed samples once a solution exists) and TEMP's
classical phase (Informed RRT* on the tree its attention phase grew) are this one loop, run
on the shared `temp_gym.planning.tree.Tree`. Stop rules, checked before every extension:

* a solution exists and ``stop_at_first`` is set, or it costs at most ``target_cost`` (0
  without one: a solution of cost 0, the start already in the goal region, cannot improve,
  and OMPL's planners stop there too);
* the tree has ``max_nodes`` nodes, or ``sample_limit`` samples were drawn;
* ``time_limit`` seconds have passed since the planner started (its `AnytimeLog`'s clock).

Every improvement of the best cost is logged, and shrinks the informed set.
"""

from __future__ import annotations

import time

import numpy as np

from temp_gym.planning import _compiled_anytime as compiled
from temp_gym.planning._compiled_tree import slice_length
from temp_gym.planning._generator import address
from temp_gym.planning.result import AnytimeLog
from temp_gym.planning.samplers import GoalBiasedSampler, InformedSampler, UniformSampler
from temp_gym.planning.settings import PlanSettings
from temp_gym.planning.tree import Tree
from temp_gym.worlds.collision.compiled import compiled_context_of

NO_TARGET = 0.0
"""The cost a run without ``target_cost`` stops at: none is lower."""


def finished(tree: Tree, settings: PlanSettings, deadline: float) -> bool:
    """Whether a stop rule of the module docstring fires (``deadline``: a perf_counter value)."""
    if tree.best_node >= 0:
        target = NO_TARGET if settings.target_cost is None else settings.target_cost
        if settings.stop_at_first or tree.best_cost <= target:
            return True
    return (
        tree.num_nodes >= settings.max_nodes
        or tree.samples >= settings.sample_limit
        or time.perf_counter() >= deadline
    )


def grow_anytime(
    tree: Tree,
    settings: PlanSettings,
    rng: np.random.Generator,
    log: AnytimeLog,
    informed: bool,
    compiled_loop: bool | None = None,
) -> None:
    """Extend ``tree`` until a stop rule fires, logging each improvement in ``log``.

    ``informed``: Informed RRT*'s sampler (uniform until a solution exists, then the informed
    set of the best cost, which may already be the tree's), else RRT*'s uniform one. The
    sampler is built only when the loop runs at all.

    ``compiled_loop``: run the extensions in the compiled loop (`_compiled_anytime`; True: an
    error when the checker has no compiled path) or in Python (False); None picks the compiled
    one whenever the checker has a compiled path. Both grow the same tree.
    """
    deadline = settings.deadline(log.started)
    if finished(tree, settings, deadline):
        return
    problem = tree.problem
    if informed:
        base = InformedSampler(problem.bounds, problem.start, problem.goal, problem.goal_radius)
        base.set_best_cost(tree.best_cost)
    else:
        base = UniformSampler(problem.bounds)
    context = compiled_context_of(tree.checker) if compiled_loop is not False else None
    if compiled_loop and context is None:
        raise ValueError("compiled_loop: the tree's checker has no compiled path")
    if context is not None:
        _grow_compiled(tree, settings, rng, log, base, context, deadline)
        return
    sampler = GoalBiasedSampler(base, problem.goal, settings.goal_bias)
    while True:
        result = tree.extend(sampler.sample(rng))
        if result.improved:
            log.record_tree(tree)
            if informed:
                base.set_best_cost(tree.best_cost)
        if finished(tree, settings, deadline):
            return


def _grow_compiled(
    tree: Tree,
    settings: PlanSettings,
    rng: np.random.Generator,
    log: AnytimeLog,
    base: UniformSampler | InformedSampler,
    context: tuple,
    deadline: float,
) -> None:
    """`grow_anytime`'s loop with the extensions in `_compiled_anytime.anytime_slice`."""
    problem = tree.problem
    goal = np.ascontiguousarray(problem.goal, dtype=np.float64)
    bounds = np.ascontiguousarray(problem.bounds, dtype=np.float64)
    batch = np.empty((0, problem.dim))
    state = np.zeros(len(compiled.STATE), dtype=np.int64)
    limits = np.array(
        [settings.max_nodes, min(settings.sample_limit, np.iinfo(np.int64).max),
         int(settings.stop_at_first)],
        dtype=np.int64,
    )  # fmt: skip
    target = NO_TARGET if settings.target_cost is None else float(settings.target_cost)
    rng_address = address(rng)  # `rng` stays alive here while the slices draw from it
    iterations = slice_length(deadline, time.perf_counter(), 0.0)
    while True:
        arrays, counters, best_cost, params = tree.compiled_state()
        began, samples = time.perf_counter(), tree.samples
        status = compiled.anytime_slice(
            arrays, counters, best_cost, params, goal, bounds, context, rng_address,
            float(settings.goal_bias), batch, state, limits, target, iterations,
        )  # fmt: skip
        tree.load_compiled_state(counters, best_cost)
        if status == compiled.IMPROVED:  # logged first: a slice may end past the deadline
            log.record_tree(tree)
        now = time.perf_counter()
        if now >= deadline:
            return
        pace = (now - began) / max(tree.samples - samples, 1)  # one sample per iteration
        iterations = slice_length(deadline, now, pace)
        if status == compiled.NEED_BATCH:
            batch = base.draw_batch(rng)
            state[compiled.NEXT_ROW], state[compiled.ROWS] = 0, len(batch)
        elif status == compiled.IMPROVED:
            if finished(tree, settings, deadline):  # the stop rule the next slice would fire
                return
            if isinstance(base, InformedSampler) and base.best_cost != tree.best_cost:
                base.set_best_cost(tree.best_cost)  # a new informed set: the batch is stale
                state[compiled.NEXT_ROW] = state[compiled.ROWS] = 0
        elif status == compiled.FULL:
            tree.grow()
        elif status == compiled.DONE:
            return


__all__ = ["finished", "grow_anytime"]
