"""The TEMP planner: attention-based planning (the paper's Algorithm 1), then classical planning.

**Attention-based planning (AP)**, for at most ``attention_nodes`` iterations:

1. the policy (the MPT) proposes ``x_sample`` from the observation of the tree: environment,
   start, goal and the path so far (`temp_gym.planning.observation.TreeObserver`); with
   probability ``goal_bias`` (default 0.05, the goal bias RRT* and Informed RRT* get too) the
   goal is the sample instead;
2. nearest node and steer by the step size;
3. while that edge collides, a uniform random sample replaces it (each failure is counted);
4. find-near and choose-parent;
5. append and rewire (`Tree.extend_with_fallback` does 2-5 on the shared core);
6. the path so far becomes the root path of the new node;
7. stop as soon as a node lies in the goal region.

The goal bias is our one addition to Algorithm 1. A learned sampler imitates expert paths
whose last node lies anywhere in the goal region, and its predictions near the goal average
out short of a small region: on 30 validation tasks the 3D policy ended 0.8 world units from
a goal of radius 0.5 and its AP solved 40% of them within 1000 nodes; sampling the goal 5% of
the time, exactly as the baselines do, made it 100% (2D: the median AP nodes fell from 56 to
37). ``goal_bias=0`` gives Algorithm 1 unchanged.

The AP phase's time, nodes and cost are what the paper reports for TEMP; `PlanResult` keeps
them in ``attention`` (``solved``, ``nodes``, ``time``, ``cost``, ``samples``,
``policy_samples``, ``sampling_failures``).

**Classical planning (CP)** then continues the same tree with informed sampling (Informed
RRT*) until ``max_nodes``, ``time_limit`` or ``target_cost``, for asymptotic optimality; with
``stop_at_first`` it is skipped. If AP used up ``attention_nodes`` without reaching the goal, CP
carries on from the tree AP built: so TEMP stays probabilistically complete whatever the
policy proposes.
"""

from __future__ import annotations

import inspect
import math
import time

import numpy as np

from temp_gym.planning.observation import DEFAULT_MAX_PATH_LENGTH, TreeObserver
from temp_gym.planning.result import AnytimeLog, PlanResult, PlanSettings, tree_plan_result
from temp_gym.planning.samplers import GoalBiasedSampler, InformedSampler, UniformSampler
from temp_gym.planning.tree import Tree
from temp_gym.problem import Problem
from temp_gym.worlds.encoding import DEFAULT_RESOLUTION, occupancy_grid
from temp_gym.worlds.workspace import Workspace

MAX_FALLBACK_TRIES = 1000


def _policy_setting(policy, name: str):
    """``policy.name`` or ``policy.model.name`` (a learned policy keeps it on its model)."""
    value = getattr(policy, name, None)
    if value is None:
        value = getattr(getattr(policy, "model", None), name, None)
    return value


def _observer_for(problem: Problem, policy, max_nodes: int) -> TreeObserver:
    """The observer matching what the policy was trained on (its resolution and L)."""
    resolution = _policy_setting(policy, "encoding_resolution") or DEFAULT_RESOLUTION[problem.robot]
    max_path_length = _policy_setting(policy, "max_path_length") or DEFAULT_MAX_PATH_LENGTH
    occupancy = occupancy_grid(Workspace.of(problem), resolution)
    return TreeObserver(problem, occupancy, max_path_length, max_nodes)


def temp(problem: Problem, settings: PlanSettings) -> PlanResult:
    """Plan with a sampling policy (AP, Algorithm 1), then Informed RRT* (CP)."""
    policy = settings.policy
    if policy is None:
        from temp_gym.models.registry import load_policy

        policy = load_policy(problem.robot)
    started = time.perf_counter()
    rng = np.random.default_rng(settings.seed)
    tree = Tree(problem, step_size=settings.step_size)
    observer = _observer_for(problem, policy, settings.max_nodes)
    if "seed" in inspect.signature(policy.reset).parameters:
        policy.reset(problem, seed=settings.seed)  # a stochastic policy: same seed, same plan
    else:
        policy.reset(problem)
    fallback = UniformSampler(problem.bounds)
    log = AnytimeLog()
    first_time: float | None = None
    first_nodes: int | None = None
    time_limit = math.inf if settings.time_limit is None else settings.time_limit
    attention_nodes = settings.attention_nodes
    if attention_nodes is None:  # the policy's own budget n (a shipped one carries it)
        attention_nodes = getattr(policy, "attention_nodes", None)
    if attention_nodes is None:
        attention_nodes = settings.max_nodes

    def out_of_budget() -> bool:
        return (
            tree.num_nodes >= settings.max_nodes
            or tree.samples >= settings.sample_limit
            or time.perf_counter() - started >= time_limit
        )

    # ---- attention-based planning (Algorithm 1)
    propose = getattr(policy, "propose", None)  # a TEMPPolicy reads the path so far alone
    policy_samples = 0
    while tree.best_node < 0 and tree.num_nodes < attention_nodes and not out_of_budget():
        if settings.goal_bias > 0 and rng.random() < settings.goal_bias:
            # the baselines' goal bias (module docstring)
            tree.extend_with_fallback(problem.goal, fallback, rng, MAX_FALLBACK_TRIES)
            continue
        if propose is not None:
            action = propose(*observer.path_so_far(tree))
        else:
            action = policy(observer.observe(tree))
        policy_samples += 1
        # the kernel clips the normalized action and maps it into the bounds
        tree.extend_with_fallback(action, fallback, rng, MAX_FALLBACK_TRIES, normalized=True)
    attention = {
        "solved": tree.best_node >= 0,
        "nodes": tree.num_nodes,
        "time": time.perf_counter() - started,
        "cost": tree.best_cost,
        "samples": tree.samples,
        "policy_samples": policy_samples,
        "sampling_failures": tree.sampling_failures,
    }
    if attention["solved"]:
        first_time, first_nodes = attention["time"], tree.num_nodes
        log.record(tree.num_nodes, first_time, tree.best_cost)

    # ---- classical planning: Informed RRT* on the same tree
    informed = InformedSampler(problem.bounds, problem.start, problem.goal, problem.goal_radius)
    informed.set_best_cost(tree.best_cost)
    sampler = GoalBiasedSampler(informed, problem.goal, settings.goal_bias)
    target = -math.inf if settings.target_cost is None else settings.target_cost
    while not out_of_budget():
        solved = tree.best_node >= 0
        if solved and (settings.stop_at_first or tree.best_cost <= target):
            break
        result = tree.extend(sampler.sample(rng))
        if result.improved:
            elapsed = time.perf_counter() - started
            log.record(tree.num_nodes, elapsed, tree.best_cost)
            if first_time is None:
                first_time, first_nodes = elapsed, tree.num_nodes
            informed.set_best_cost(tree.best_cost)
    return tree_plan_result(
        problem, tree, "temp", settings, started, log, first_time, first_nodes, attention=attention
    )
