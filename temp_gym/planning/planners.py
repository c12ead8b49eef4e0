"""RRT* and Informed RRT*: loops that feed samples to the shared `Tree` core."""

from __future__ import annotations

import math
import time

import numpy as np

from temp_gym.planning.result import (
    AnytimeLog,
    PlanResult,
    PlanSettings,
    tree_plan_result,
)
from temp_gym.planning.samplers import GoalBiasedSampler, InformedSampler, UniformSampler
from temp_gym.planning.tree import Tree
from temp_gym.problem import Problem


def run_tree_planner(
    problem: Problem, settings: PlanSettings, name: str, informed: bool
) -> PlanResult:
    """Grow one `Tree` from goal-biased uniform (or informed) samples until a stop rule fires.

    Stop rules: ``max_nodes`` tree nodes, ``max_samples`` samples, ``time_limit`` seconds,
    the first solution (``stop_at_first``), or a solution within ``target_cost``.
    """
    started = time.perf_counter()
    rng = np.random.default_rng(settings.seed)
    tree = Tree(problem, step_size=settings.step_size)
    if informed:
        base = InformedSampler(problem.bounds, problem.start, problem.goal, problem.goal_radius)
    else:
        base = UniformSampler(problem.bounds)
    sampler = GoalBiasedSampler(base, problem.goal, settings.goal_bias)
    log = AnytimeLog()
    first_time: float | None = None
    first_nodes: int | None = None
    target = -math.inf if settings.target_cost is None else settings.target_cost
    time_limit = math.inf if settings.time_limit is None else settings.time_limit
    max_nodes, max_samples = settings.max_nodes, settings.sample_limit
    solved = tree.best_node >= 0  # the start may already lie in the goal region
    if solved:
        first_time, first_nodes = time.perf_counter() - started, tree.num_nodes
        log.record(tree.num_nodes, first_time, tree.best_cost)
    while not (solved and (settings.stop_at_first or tree.best_cost <= target)):
        if tree.num_nodes >= max_nodes or tree.samples >= max_samples:
            break
        if time.perf_counter() - started >= time_limit:
            break
        result = tree.extend(sampler.sample(rng))
        if result.improved:
            elapsed = time.perf_counter() - started
            log.record(tree.num_nodes, elapsed, tree.best_cost)
            if not solved:
                solved, first_time, first_nodes = True, elapsed, tree.num_nodes
            if informed:
                base.set_best_cost(tree.best_cost)
    return tree_plan_result(problem, tree, name, settings, started, log, first_time, first_nodes)


def rrt_star(problem: Problem, settings: PlanSettings) -> PlanResult:
    """RRT* (Karaman & Frazzoli 2011) with goal-biased uniform sampling."""
    return run_tree_planner(problem, settings, "rrt_star", informed=False)


def informed_rrt_star(problem: Problem, settings: PlanSettings) -> PlanResult:
    """Informed RRT* (Gammell et al. 2014): uniform until a solution, then informed sampling."""
    return run_tree_planner(problem, settings, "informed_rrt_star", informed=True)
