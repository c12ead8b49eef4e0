"""Planning episodes for the trainers' evaluations.

Tasks drawn by the env, an env episode with a policy, a ``plan`` run to the first solution,
and the summaries (nodes, success, paired comparison with a baseline).
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict
from typing import Any

import gymnasium as gym
import numpy as np

from temp_gym.config import Config, TEMPConfig, TrainEvalConfig
from temp_gym.evaluation.statistics import bootstrap_interval
from temp_gym.planning.plan import plan
from temp_gym.planning.temp_planner import DEFAULTS, attention_solved_both_ways
from temp_gym.planning.temp_settings import TEMPSettings, resolve
from temp_gym.problem import Problem
from temp_gym.worlds.structured import BOXES
from temp_gym.wrappers.metrics import INFO_KEY, PlanningMetrics


def make_env(
    config: Config,
    fallback: str = "random",
    split: str = "test",
    workspace_family: str = BOXES,
    policy: Any = None,
) -> gym.Env:
    """The planning env of the ``env`` section, with ``train_eval``'s tasks and budget.

    Its tasks are drawn in ``split``'s workspaces of ``workspace_family`` (the paper's
    protocol: ``boxes``). Its fallback draws ``train_eval.temp.attention_local_fallback``
    replacements near a colliding action, else as many as ``policy`` carries (the one that
    will step it), else none, as the ``temp`` planner would with that policy. Wrapped in
    `PlanningMetrics`.
    """
    env_config, eval_config = config.env, config.train_eval
    name = "attention_local_fallback"
    local = resolve(temp_settings(eval_config.temp), policy, name, DEFAULTS[name])
    env = gym.make(
        env_config.id,
        difficulty=eval_config.difficulty,
        max_nodes=eval_config.max_nodes,
        step_size=env_config.step_size,
        fallback=fallback,
        attention_local_fallback=local,
        encoding_resolution=env_config.encoding_resolution,
        split=split,
        workspace_family=workspace_family,
        max_path_length=env_config.max_path_length,
        disable_env_checker=True,
    )
    return PlanningMetrics(env)


def draw_problems(
    config: Config, split: str, count: int, seed: int, workspace_family: str = BOXES
) -> list[Problem]:
    """``count`` tasks drawn by the env from ``split``'s workspaces, task i with seed+i."""
    env = make_env(config, fallback="none", split=split, workspace_family=workspace_family)
    problems = []
    for index in range(count):
        env.reset(seed=seed + index)
        problems.append(env.unwrapped.problem)
    env.close()
    return problems


def run_episode(
    env: gym.Env, policy: Any, problem: Problem, seed: int
) -> tuple[dict[str, float], dict[str, Any]]:
    """Plan ``problem`` in ``env`` with ``policy`` until the first solution or the budget.

    Returns ``info["planning"]`` (`PlanningMetrics`) plus ``time`` (wall seconds, policy
    included), and the final info (with the tree still in ``env.unwrapped``).
    """
    began = time.perf_counter()
    observation, info = env.reset(seed=seed, options={"problem": problem})
    policy.reset(problem)
    while True:
        observation, _, terminated, truncated, info = env.step(policy(observation))
        if terminated or truncated:
            break
    episode = {key: float(value) for key, value in info[INFO_KEY].items()}
    episode["time"] = time.perf_counter() - began
    return episode, info


def evaluate_planner(
    env: gym.Env, policy: Any, problems: list[Problem], seed: int
) -> list[dict[str, float]]:
    """`run_episode` over ``problems`` (episode i seeded ``seed + i``)."""
    return [run_episode(env, policy, problem, seed + i)[0] for i, problem in enumerate(problems)]


def nodes_or_budget(episodes: list[dict[str, float]], max_nodes: int) -> np.ndarray:
    """Nodes to the first solution per episode, ``max_nodes`` for a failed one."""
    return np.array([run["nodes"] if run["success"] > 0 else max_nodes for run in episodes])


def paired_nodes(
    episodes: list[dict[str, float]],
    baseline: list[dict[str, float]],
    max_nodes: int,
    resamples: int = 2000,
    seed: int = 0,
) -> dict[str, float]:
    """Nodes to the first solution of two planners on the same tasks, compared task by task.

    A failure counts as the whole budget, as in `summarize`. Returns the share of tasks where
    ``episodes`` needed fewer nodes than ``baseline``, the mean difference (``episodes`` minus
    ``baseline``) and its 95% paired bootstrap interval (``resamples`` resamplings of the
    tasks, seeded): the means of heavy-tailed node counts move a lot between task sets, and
    the interval says whether a difference is more than that.
    """
    if len(episodes) != len(baseline) or not episodes:
        raise ValueError(
            f"expected the same non-empty task list, got {len(episodes)} and {len(baseline)}"
        )
    difference = nodes_or_budget(episodes, max_nodes) - nodes_or_budget(baseline, max_nodes)
    low, high = bootstrap_interval(difference, np.mean, resamples=resamples, seed=seed)
    return {
        "fewer": float(np.mean(difference < 0)),
        "difference": float(difference.mean()),
        "low": float(low),
        "high": float(high),
    }


def summarize(episodes: list[dict[str, float]], max_nodes: int) -> dict[str, float]:
    """Success rate, nodes to the first solution, cost, samples and time of a planner.

    Nodes: mean over all episodes (a failure counts as the whole budget) and median; cost:
    mean over successful episodes; samples and time: means over all episodes.
    """
    success = np.array([episode["success"] for episode in episodes]) > 0
    nodes = nodes_or_budget(episodes, max_nodes)
    costs = np.array([episode["cost"] for episode, ok in zip(episodes, success) if ok])
    return {
        "success": float(success.mean()),
        "nodes_mean": float(nodes.mean()),
        "nodes_median": float(np.median(nodes)),
        "cost": float(costs.mean()) if len(costs) else math.inf,
        "samples": float(np.mean([episode["samples"] for episode in episodes])),
        "time": float(np.mean([episode["time"] for episode in episodes])),
    }


def temp_settings(
    section: TEMPConfig, policy: Any = None, where: str = "train_eval.temp"
) -> TEMPSettings:
    """The `TEMPSettings` of a config's ``temp`` section (and ``policy``), checked.

    Null keys stay None: the policy's own, else the planner's defaults. A bad key's error
    names it ``{where}.{key}``.
    """
    return TEMPSettings.at(where, policy=policy, **asdict(section))


def plan_episode(
    problem: Problem, planner: str, seed: int, eval_config: TrainEvalConfig, policy=None
) -> dict:
    """One `temp_gym.plan` run up to the first solution, as a `summarize` episode.

    ``eval_config`` gives the budget and, for ``temp``, the planner's settings (its ``temp``
    section, `TEMPSettings`); its null ones take the policy's own.
    """
    settings = None
    if planner == "temp":
        settings = temp_settings(eval_config.temp, policy)
    result = plan(
        problem,
        planner,
        settings,
        seed=seed,
        max_nodes=eval_config.max_nodes,
        stop_at_first=True,
    )
    episode = {
        "success": float(result.success),
        "nodes": float(result.nodes_to_first_solution or result.nodes),
        "cost": result.cost,
        "samples": float(result.samples),
        "time": result.time_to_first_solution or result.wall_time,
    }
    if planner == "temp":
        episode["attention_solved"] = float(result.attention["solved"])
        episode["attention_solved_both_ways"] = float(attention_solved_both_ways(result.attention))
    return episode
