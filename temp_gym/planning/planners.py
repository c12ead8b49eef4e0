"""RRT* and Informed RRT*: the anytime loop (`temp_gym.planning.anytime`) on a fresh tree."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from temp_gym.planning.anytime import grow_anytime
from temp_gym.planning.result import AnytimeLog, PlanResult, tree_plan_result
from temp_gym.planning.settings import PlanSettings
from temp_gym.planning.tree import Tree
from temp_gym.problem import Problem


@dataclass(frozen=True)
class RRTStarSettings(PlanSettings):
    """``rrt_star``'s settings: the common ones (`PlanSettings`); it has none of its own."""


@dataclass(frozen=True)
class InformedRRTStarSettings(PlanSettings):
    """``informed_rrt_star``'s settings: the common ones (`PlanSettings`); none of its own."""


def run_tree_planner(
    problem: Problem, settings: PlanSettings, name: str, informed: bool
) -> PlanResult:
    """Grow one `Tree` from goal-biased uniform (or informed) samples until a stop rule fires.

    Stop rules: ``max_nodes`` tree nodes, ``max_samples`` samples, ``time_limit`` seconds,
    the first solution (``stop_at_first``), or a solution within ``target_cost``.
    """
    log = AnytimeLog()
    rng = np.random.default_rng(settings.seed)
    tree = Tree(problem, step_size=settings.step_size)
    if tree.best_node >= 0:  # the start lies in the goal region
        log.record_tree(tree)
    grow_anytime(tree, settings, rng, log, informed)
    return tree_plan_result(problem, tree, name, settings, log)


def rrt_star(problem: Problem, settings: RRTStarSettings) -> PlanResult:
    """RRT* (Karaman & Frazzoli 2011) with goal-biased uniform sampling."""
    return run_tree_planner(problem, settings, "rrt_star", informed=False)


def informed_rrt_star(problem: Problem, settings: InformedRRTStarSettings) -> PlanResult:
    """Informed RRT* (Gammell et al. 2014): uniform until a solution, then informed sampling."""
    return run_tree_planner(problem, settings, "informed_rrt_star", informed=True)
