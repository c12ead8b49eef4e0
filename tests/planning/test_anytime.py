import math

import numpy as np
import pytest

from temp_gym.planning import anytime, plan
from temp_gym.planning.anytime import finished, grow_anytime
from temp_gym.planning.result import AnytimeLog, PlanSettings
from temp_gym.planning.tree import Tree


def test_each_stop_rule_ends_the_loop(problem_2d):
    def grown(**changes):
        tree, log = Tree(problem_2d), AnytimeLog()
        grow_anytime(tree, PlanSettings(**changes), np.random.default_rng(0), log, informed=True)
        return tree, log

    tree, log = grown(max_nodes=40)
    assert tree.num_nodes == 40
    tree, log = grown(max_nodes=10_000, max_samples=25)
    assert tree.samples == 25
    tree, log = grown(max_nodes=10_000, stop_at_first=True)
    assert tree.best_node >= 0 and len(log.nodes) == 1 and log.first_nodes == tree.num_nodes
    first_cost = log.costs[0]
    tree, log = grown(max_nodes=10_000, target_cost=0.97 * first_cost)
    assert tree.best_cost <= 0.97 * first_cost and log.costs[-1] == tree.best_cost
    tree, log = grown(max_nodes=10**9, time_limit=0.0)
    assert tree.num_nodes == 1  # out of time before the first extension


def test_improvements_are_logged_in_order_and_the_first_is_the_first_solution(problem_2d):
    result = plan(problem_2d, "informed_rrt_star", seed=3, max_nodes=1500)
    history = result.history
    assert len(history["nodes"]) >= 2
    assert np.all(np.diff(history["best_cost"]) < 0) and np.all(np.diff(history["nodes"]) > 0)
    assert result.nodes_to_first_solution == history["nodes"][0]
    assert result.time_to_first_solution == history["time"][0]


def test_no_sampler_is_built_when_the_loop_would_not_run(problem_2d, monkeypatch):
    built = []
    monkeypatch.setattr(anytime, "InformedSampler", lambda *a: built.append(a))
    tree = Tree(problem_2d.replace(goal=problem_2d.start.tolist()))  # solved at the root
    settings = PlanSettings(stop_at_first=True)
    assert finished(tree, settings, math.inf)
    grow_anytime(tree, settings, np.random.default_rng(0), AnytimeLog(), informed=True)
    assert built == [] and tree.samples == 0


def test_temp_classical_phase_is_the_same_loop(problem_2d):
    # Attention budget 1: the classical phase (Informed RRT* on the same tree) does all the
    # work, so TEMP's tree is Informed RRT*'s from the same generator state.
    class Never:
        def reset(self, problem, seed=None):
            pass

        def __call__(self, observation):
            raise AssertionError("the attention phase should not run")

    temp = plan(problem_2d, "temp", seed=5, max_nodes=600, policy=Never(), attention_nodes=1)
    informed = plan(problem_2d, "informed_rrt_star", seed=5, max_nodes=600)
    assert temp.attention["nodes"] == 1 and temp.nodes == informed.nodes == 600
    np.testing.assert_array_equal(temp.path, informed.path)
    np.testing.assert_array_equal(temp.history["best_cost"], informed.history["best_cost"])


@pytest.mark.parametrize(
    "changes, match",
    [
        ({"seed": True}, "seed"),
        ({"max_nodes": np.float64(3.0)}, "max_nodes"),
        ({"time_limit": -0.5}, "time_limit"),
        ({"goal_bias": -0.1}, "goal_bias"),
        ({"attention_patience": -1}, "attention_patience"),
        ({"attention_uniform": 2.0}, "attention_uniform"),
        ({"policy": object()}, "policy"),
    ],
)
def test_plan_settings_check_themselves(changes, match):
    with pytest.raises(ValueError, match=f"^{match}"):
        PlanSettings(**changes)


def test_plan_settings_normalize_numbers():
    settings = PlanSettings(seed=np.int64(4), max_nodes=np.int32(9), goal_bias=1, time_limit=2)
    assert type(settings.seed) is int and type(settings.max_nodes) is int
    assert type(settings.goal_bias) is float and type(settings.time_limit) is float
    assert (
        settings.attention_patience is None
        and PlanSettings(attention_patience=0).attention_patience == 0
    )
