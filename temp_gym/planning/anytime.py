"""The anytime loop: RRT* extensions from goal-biased samples until a stop rule fires.

RRT* (uniform samples), Informed RRT* (informed samples once a solution exists) and TEMP's
classical phase (Informed RRT* on the tree its attention phase grew) are this one loop, run
on the shared `temp_gym.planning.tree.Tree`. Stop rules, checked before every extension:

* a solution exists and ``stop_at_first`` is set, or it costs at most ``target_cost``;
* the tree has ``max_nodes`` nodes, or ``sample_limit`` samples were drawn;
* ``time_limit`` seconds have passed since the planner started (its `AnytimeLog`'s clock).

Every improvement of the best cost is logged, and shrinks the informed set.
"""

from __future__ import annotations

import math
import time

import numpy as np

from temp_gym.planning.result import AnytimeLog, PlanSettings
from temp_gym.planning.samplers import GoalBiasedSampler, InformedSampler, UniformSampler
from temp_gym.planning.tree import Tree


def finished(tree: Tree, settings: PlanSettings, deadline: float) -> bool:
    """Whether a stop rule of the module docstring fires (``deadline``: a perf_counter value)."""
    if tree.best_node >= 0:
        target = -math.inf if settings.target_cost is None else settings.target_cost
        if settings.stop_at_first or tree.best_cost <= target:
            return True
    return (
        tree.num_nodes >= settings.max_nodes
        or tree.samples >= settings.sample_limit
        or time.perf_counter() >= deadline
    )


def grow_anytime(
    tree: Tree, settings: PlanSettings, rng: np.random.Generator, log: AnytimeLog, informed: bool
) -> None:
    """Extend ``tree`` until a stop rule fires, logging each improvement in ``log``.

    ``informed``: Informed RRT*'s sampler (uniform until a solution exists, then the informed
    set of the best cost, which may already be the tree's), else RRT*'s uniform one. The
    sampler is built only when the loop runs at all.
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
    sampler = GoalBiasedSampler(base, problem.goal, settings.goal_bias)
    while True:
        result = tree.extend(sampler.sample(rng))
        if result.improved:
            log.record_tree(tree)
            if informed:
                base.set_best_cost(tree.best_cost)
        if finished(tree, settings, deadline):
            return


__all__ = ["finished", "grow_anytime"]
