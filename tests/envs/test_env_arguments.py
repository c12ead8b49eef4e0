"""Hostile env arguments and actions: a clear error, never a silent default or a dropped part."""

import gymnasium as gym
import numpy as np
import pytest

import temp_gym  # noqa: F401  (registers the envs)


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"goal_radius": 0.0}, "goal_radius"),  # was silently the default radius
        ({"goal_radius": float("nan")}, "goal_radius"),
        ({"goal_radius": 1e-300}, "goal_radius"),  # refused only at reset()
        ({"encoding_resolution": 0}, "encoding_resolution"),  # was silently the default
        ({"encoding_resolution": 2.5}, "encoding_resolution"),
        ({"encoding_resolution": 1}, "encoding_resolution"),  # failed at reset() instead
        ({"max_samples": 0}, "max_samples"),
        ({"max_samples": 10.5}, "max_samples"),
        ({"max_nodes": float("inf")}, "max_nodes"),  # was an OverflowError
        ({"max_nodes": 3000.0}, "max_nodes"),
        ({"target_cost": float("nan")}, "target_cost"),  # was ignored
        ({"step_size": float("inf")}, "step_size"),
        ({"max_fallback_tries": float("nan")}, "max_fallback_tries"),  # failed at the first step
        ({"max_fallback_tries": -3}, "max_fallback_tries"),
        ({"attention_local_fallback": -1}, "attention_local_fallback"),
        ({"attention_local_fallback": 2.5}, "attention_local_fallback"),
        ({"step_penalty": float("nan")}, "step_penalty"),  # gave NaN rewards
        ({"success_reward": "1"}, "success_reward"),
    ],
)
def test_bad_constructor_arguments_are_rejected_by_name(kwargs, field):
    with pytest.raises(ValueError, match=f"^{field}"):
        gym.make("TEMP-2D-v0", **kwargs)


def test_a_nan_target_cost_option_is_rejected():
    env = gym.make("TEMP-2D-v0").unwrapped
    with pytest.raises(ValueError, match=r"options\['target_cost'\]"):
        env.reset(seed=0, options={"target_cost": float("nan")})


def test_complex_actions_are_rejected_not_truncated():
    env = gym.make("TEMP-2D-v0", fallback="none").unwrapped
    env.reset(seed=0)
    for action in (np.array([0.5 + 0.5j, 0.1]), [0.5, 1j]):
        with pytest.raises(ValueError, match="action: must be real"):
            env.step(action)
    assert env.tree.num_nodes == 1 and env.tree.samples == 0


def test_actions_that_are_not_numbers_are_rejected_not_converted():
    env = gym.make("TEMP-2D-v0", fallback="none").unwrapped
    env.reset(seed=0)
    for action in (np.array(["0.5", "0.5"]), {"a": 1}, [True, False], [[0.5], [0.5, 0.1]]):
        with pytest.raises(ValueError, match=r"^action: expected 2 numbers"):
            env.step(action)
    assert env.tree.num_nodes == 1 and env.tree.samples == 0
    env.step(np.array([0.5, 0.5], dtype=np.float32))  # any real dtype is a number
    assert env.tree.samples == 1


def test_a_numpy_integer_seed_seeds_as_the_same_int():
    env = gym.make("TEMP-2D-v0")
    first, _ = env.reset(seed=np.int64(3))
    again, _ = env.reset(seed=3)
    assert all(np.array_equal(first[key], again[key]) for key in first)


def test_explicit_valid_values_are_used_not_replaced():
    env = gym.make("TEMP-2D-v0", goal_radius=0.25, encoding_resolution=8, max_nodes=50).unwrapped
    observation, _ = env.reset(seed=0)
    assert env.problem.goal_radius == 0.25
    assert observation["occupancy"].shape == (8, 8)
    assert env.max_nodes == 50


def test_options_that_are_not_a_dict_are_rejected_as_such():
    env = gym.make("TEMP-2D-v0").unwrapped
    with pytest.raises(ValueError, match="^options: expected a dict"):
        env.reset(seed=0, options="problem")  # was "unknown keys ['b', 'e', ...]"


def test_an_episode_of_colliding_actions_is_truncated_by_the_sample_budget():
    problem = temp_gym.Problem.load("examples/point2d.json")
    inside = problem.workspace.obstacle_centers[0]  # the tree grows to the box, then stops
    low, high = problem.bounds
    action = (2.0 * (inside - low) / (high - low) - 1.0).astype(np.float32)
    env = gym.make("TEMP-2D-v0", fallback="none", max_nodes=50, max_samples=60).unwrapped
    env.reset(seed=0, options={"problem": problem})
    for step in range(1, 61):
        _, _, terminated, truncated, info = env.step(action)
        assert not terminated and info["samples"] == step
        assert truncated == (step == 60)
    assert info["nodes"] < 50 and not info["added"]  # the node budget never ended it
    default = gym.make("TEMP-2D-v0", max_nodes=50).unwrapped
    assert default.max_samples == 5000


def test_replacements_near_the_action_are_drawn_as_the_planner_draws_them():
    """With ``attention_local_fallback`` the env's fallback is `Tree.extend_with_fallback`'s
    with that many tries near the action, the attention phase's."""
    from temp_gym.planning.samplers import UniformSampler
    from temp_gym.planning.tree import Tree

    env = gym.make("TEMP-2D-v0", attention_local_fallback=5).unwrapped
    env.reset(seed=3)
    tree = Tree(env.problem, step_size=env.tree.step_size)
    sampler, rng = UniformSampler(env.problem.bounds), np.random.default_rng(11)
    env.np_random = np.random.default_rng(11)
    actions = np.random.default_rng(0).uniform(-1, 1, (40, 2)).astype(np.float32)
    for action in actions:
        env.step(action)
        tree.extend_with_fallback(action, sampler, rng, 1000, normalized=True, local_tries=5)
    n = tree.num_nodes
    assert env.tree.num_nodes == n and env.tree.sampling_failures == tree.sampling_failures
    np.testing.assert_array_equal(env.tree.positions[:n], tree.positions[:n])


def test_the_trainers_env_takes_the_local_fallback_of_the_policy_that_steps_it():
    from temp_gym import load_policy
    from temp_gym.config import load_config
    from temp_gym.training import make_env

    config = load_config("configs/2d.yaml")
    policy = load_policy("TEMP-2D-v0")
    assert make_env(config, policy=policy).unwrapped.local_fallback == 5  # what it carries
    assert make_env(config).unwrapped.local_fallback == 0  # no policy: Algorithm 1
    told = load_config("configs/2d.yaml", ["train_eval.temp.attention_local_fallback=2"])
    assert make_env(told, policy=policy).unwrapped.local_fallback == 2
