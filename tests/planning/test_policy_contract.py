"""The policy contract (`temp_gym.planning.policy`): what a third-party policy needs, and that
the built-in policies meet it."""

import numpy as np
import pytest

from temp_gym import Problem, plan
from temp_gym.planning.policy import (
    FAST_PATHS,
    ChunkProposer,
    CompiledProposer,
    PolicySettings,
    Proposer,
    SamplingPolicy,
    fast_path,
    policy_settings,
)
from temp_gym.policies import InformedPolicy, UniformPolicy


class Minimal:
    """A third-party policy: reset and __call__, nothing else."""

    def __init__(self):
        self.resets = []

    def reset(self, problem, seed=None):
        self.resets.append(seed)

    def __call__(self, observation):
        return observation["goal"]


class ProblemOnly:
    """The older form of the contract: reset takes the problem alone."""

    def reset(self, problem):
        self.problem = problem

    def __call__(self, observation):
        return observation["goal"]


def test_a_minimal_third_party_policy_plans(wall):
    problem = Problem.from_dict(wall)
    policy = Minimal()
    assert isinstance(policy, SamplingPolicy)
    assert not isinstance(policy, (Proposer, ChunkProposer, CompiledProposer))
    assert policy_settings(policy) == PolicySettings()
    assert all(fast_path(policy, name) is None for name in FAST_PATHS)
    result = plan(problem, planner="temp", policy=policy, seed=7, max_nodes=2000)
    assert result.success and result.attention["policy_samples"] > 0
    assert policy.resets[-1] == 7  # the planner's seed reaches the policy
    again = plan(problem, planner="temp", policy=Minimal(), seed=7, max_nodes=2000)
    assert again.cost == result.cost and again.nodes == result.nodes


def test_a_problem_only_reset_still_plans_with_a_deprecation_warning(wall):
    problem = Problem.from_dict(wall)
    with pytest.warns(DeprecationWarning, match="seed=None"):
        result = plan(problem, planner="temp", policy=ProblemOnly(), seed=0, max_nodes=2000)
    reference = plan(problem, planner="temp", policy=Minimal(), seed=0, max_nodes=2000)
    assert result.cost == reference.cost and result.nodes == reference.nodes


def test_what_is_not_a_policy_is_refused(wall):
    problem = Problem.from_dict(wall)
    with pytest.raises(ValueError, match="SamplingPolicy"):
        plan(problem, planner="temp", policy=object())
    with pytest.raises(ValueError, match="fast_path|name"):
        fast_path(Minimal(), "sample")


def test_declared_settings_are_read_from_attributes():
    policy = Minimal()
    policy.attention_nodes, policy.max_path_length = 50, 8
    assert policy_settings(policy) == PolicySettings(attention_nodes=50, max_path_length=8)


@pytest.mark.parametrize(
    "name, value, words",
    [("max_path_length", -3, "expected an integer from 2 to 4096"),
     ("max_path_length", True, "got True"), ("max_path_length", 1.5, "got 1.5"),
     ("max_path_length", "8", "got '8'"), ("max_path_length", 10**6, "got 1000000"),
     ("encoding_resolution", 0, "expected at least"),
     ("encoding_resolution", "16", "expected an integer")],
)  # fmt: skip
def test_declared_observation_settings_are_checked_as_the_envs_check_them(wall, name, value, words):
    """They used to be read as given: 1.5 became 1, 0 the default, -3 a crash deep inside."""
    policy = Minimal()
    setattr(policy, name, value)
    with pytest.raises(ValueError, match=f"^policy.{name}: .*{words}"):
        plan(Problem.from_dict(wall), planner="temp", policy=policy, seed=0, max_nodes=50)


class EmptyChunk(Minimal):
    def propose_chunk(self, path, length):
        return np.zeros((0, 2), np.float32)


class ListPropose(Minimal):
    def propose(self, path, length):
        return [0.0, 0.0]  # a list, as __call__ may return


def test_a_fast_path_is_held_to_what_call_may_return_and_an_empty_chunk_is_named(wall):
    problem = Problem.from_dict(wall)
    with pytest.raises(ValueError, match=r"^policy.propose_chunk: expected \(k, 2\) proposals"):
        plan(problem, planner="temp", policy=EmptyChunk(), seed=0, max_nodes=50)
    result = plan(problem, planner="temp", policy=ListPropose(), seed=0, max_nodes=50)
    assert result.nodes >= 1


class OddCompiled(Minimal):
    def compiled_proposer(self):
        return (1, 2, 3)


def test_a_compiled_proposer_of_the_wrong_shape_is_named(wall):
    with pytest.raises(ValueError, match=r"^policy.compiled_proposer: expected None or the 8"):
        plan(Problem.from_dict(wall), planner="temp", policy=OddCompiled(), seed=0, max_nodes=50)


def test_the_built_in_policies_meet_the_contract():
    for policy in (UniformPolicy(seed=0), InformedPolicy(seed=0)):
        assert isinstance(policy, SamplingPolicy)
