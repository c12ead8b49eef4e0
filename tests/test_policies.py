"""Classical policies follow the observation's task, or fail clearly when they cannot."""

import gymnasium as gym
import numpy as np
import pytest

import temp_gym  # noqa: F401  (registers the envs)
from temp_gym.policies import InformedPolicy, UniformPolicy


def test_uniform_policy_follows_a_reset_it_was_not_told_about():
    env = gym.make("TEMP-2D-v0")
    observation, _ = env.reset(seed=0)
    policy = UniformPolicy(seed=0, goal_bias=1.0)
    policy.reset(env.unwrapped.problem)
    np.testing.assert_allclose(policy(observation), observation["goal"], atol=1e-6)
    old_goal = observation["goal"]
    observation, _ = env.reset(seed=1)  # a new task; the policy is not reset
    assert not np.allclose(observation["goal"], old_goal)
    np.testing.assert_allclose(policy(observation), observation["goal"], atol=1e-6)


def test_uniform_policy_without_reset_samples_the_normalized_box():
    env = gym.make("TEMP-2D-v0")
    observation, _ = env.reset(seed=0)
    goal_only = UniformPolicy(seed=0, goal_bias=1.0)
    np.testing.assert_allclose(goal_only(observation), observation["goal"], atol=1e-6)
    uniform = UniformPolicy(seed=0, goal_bias=0.0)
    samples = np.array([uniform(observation) for _ in range(400)])
    assert samples.shape == (400, 2)
    assert samples.min() >= -1 and samples.max() <= 1
    assert samples.min() < -0.9 and samples.max() > 0.9  # spread over the whole box


def test_uniform_policy_follows_in_a_vector_env_with_autoreset():
    envs = gym.vector.SyncVectorEnv([lambda: gym.make("TEMP-2D-v0", max_nodes=5)] * 2)
    observations, _ = envs.reset(seed=0)
    policies = [UniformPolicy(seed=k, goal_bias=1.0) for k in range(2)]
    goals_seen = set()
    for _ in range(20):
        actions = []
        for k, policy in enumerate(policies):
            observation = {key: value[k] for key, value in observations.items()}
            action = policy(observation)
            np.testing.assert_allclose(action, observation["goal"], atol=1e-6)
            goals_seen.add(tuple(np.round(observation["goal"], 4)))
            actions.append(action)
        observations, *_ = envs.step(np.stack(actions))
    envs.close()
    assert len(goals_seen) > 2  # episodes ended and new tasks were followed


def test_informed_policy_names_a_stale_task_and_a_missing_reset():
    env = gym.make("TEMP-2D-v0")
    observation, _ = env.reset(seed=0)
    policy = InformedPolicy(seed=0)
    with pytest.raises(RuntimeError, match="reset"):
        policy(observation)
    policy.reset(env.unwrapped.problem)
    assert policy(observation).shape == (2,)
    observation, _ = env.reset(seed=1)
    with pytest.raises(ValueError, match=r"observation: .*policy.reset\(env.unwrapped.problem\)"):
        policy(observation)
    policy.reset(env.unwrapped.problem)
    assert policy(observation).shape == (2,)


def test_a_missing_observation_is_named():
    with pytest.raises(ValueError, match="observation: expected the env's observation dict"):
        UniformPolicy(seed=0)(None)


@pytest.mark.parametrize("seed", [-1, 1.5, "abc", True])
def test_a_bad_seed_is_refused_by_name(seed):
    with pytest.raises(ValueError, match="^seed: expected"):
        UniformPolicy(seed=seed)


def test_uniform_policy_names_another_robots_or_a_batched_observation():
    two = gym.make("TEMP-2D-v0")
    two.reset(seed=0)
    three_observation, _ = gym.make("TEMP-3D-v0").reset(seed=0)
    policy = UniformPolicy(seed=0)
    policy.reset(two.unwrapped.problem)
    with pytest.raises(ValueError, match=r"expected shape \(2,\), got \(3,\)"):
        policy(three_observation)
    batch, _ = gym.make_vec("TEMP-2D-v0", num_envs=2).reset(seed=0)
    with pytest.raises(ValueError, match="per sub-env of a vector env"):
        UniformPolicy(seed=0)(batch)
