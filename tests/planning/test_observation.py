"""The env's observation against a plain numpy reference, step by step.

The observer keeps its state between calls (it is updated only when the tree grows) and every
observation is a fresh block of views, so these tests check the values after failed and
successful extensions, with the path-so-far truncated to L rows and shrinking, and that an
observation neither shares memory with another nor is affected by a caller writing into one.
"""

import copy
import itertools

import gymnasium as gym
import numpy as np
import pytest

from temp_gym import Problem
from temp_gym.planning.observation import MAX_RATIO, TreeObserver
from temp_gym.planning.tree import Tree
from temp_gym.worlds.encoding import occupancy_grid
from temp_gym.worlds.normalization import half_range, normalize


def reference_observation(env) -> dict[str, np.ndarray]:
    """What the observation of the env's tree must hold, built without the kernels."""
    env = env.unwrapped
    tree, problem, length = env.tree, env.problem, env.max_path_length
    path = normalize(tree.path_so_far()[-length:], problem.bounds).astype(np.float32)
    padded = np.zeros((length, problem.dim), np.float32)
    padded[: len(path)] = path
    solved = tree.best_node >= 0
    distance = max(float(np.linalg.norm(problem.goal - problem.start)), 1e-12)
    radius = min(problem.goal_radius / half_range(problem.bounds).mean(), MAX_RATIO)
    return {
        "occupancy": occupancy_grid(problem.workspace, env.resolution).astype(np.float32),
        "start": normalize(problem.start, problem.bounds).astype(np.float32),
        "goal": normalize(problem.goal, problem.bounds).astype(np.float32),
        "goal_radius": np.array([radius], np.float32),
        "path": padded,
        "path_length": np.array([len(path)], np.int64),
        "best_cost": np.array([min(tree.best_cost / distance, MAX_RATIO) if solved else 0.0]),
        "solved": np.array([1.0 if solved else 0.0], np.float32),
        "progress": np.array([min(tree.num_nodes / env.max_nodes, 1.0)], np.float32),
    }


def assert_observation(observation, expected, space) -> None:
    assert observation.keys() == expected.keys()
    assert observation in space
    for key, value in observation.items():
        assert value.dtype == space[key].dtype and value.shape == space[key].shape, key
        np.testing.assert_array_equal(value, expected[key].astype(value.dtype), err_msg=key)


@pytest.mark.parametrize(
    ("env_id", "max_path_length"), [("TEMP-2D-v0", 4), ("TEMP-2D-v0", 64), ("TEMP-3D-v0", 8)]
)
def test_observation_matches_reference_after_every_step(env_id, max_path_length, wall):
    env = gym.make(env_id, fallback="none", max_path_length=max_path_length, max_nodes=400)
    options = {"problem": Problem.from_dict(wall)} if env_id == "TEMP-2D-v0" else None
    observation, _ = env.reset(seed=3, options=options)
    assert_observation(observation, reference_observation(env), env.observation_space)
    rng = np.random.default_rng(0)
    dim = env.action_space.shape[0]
    lengths, added = [], []
    for _ in range(250):
        # Half the actions aim at the centre of the bounds, often into an obstacle.
        action = rng.uniform(-1, 1, dim) if rng.random() < 0.5 else rng.normal(0, 0.05, dim)
        observation, _, terminated, truncated, info = env.step(action)
        assert_observation(observation, reference_observation(env), env.observation_space)
        lengths.append(int(observation["path_length"][0]))
        added.append(info["added"])
        for value in observation.values():  # a caller scribbling on it changes nothing later
            value[...] = 7
        if terminated or truncated:
            break
    assert not all(added) and any(added)  # failed and successful extensions were both seen
    assert any(b < a for a, b in itertools.pairwise(lengths))  # the path got shorter
    if max_path_length < 10:
        assert max(lengths) == max_path_length  # and was truncated to L rows


def test_entries_of_one_observation_are_disjoint_and_writable():
    env = gym.make("TEMP-3D-v0")
    observation, _ = env.reset(seed=0)
    observation, *_ = env.step(env.action_space.sample())
    for (name_a, a), (name_b, b) in itertools.combinations(observation.items(), 2):
        assert not np.shares_memory(a, b), (name_a, name_b)
    assert all(value.flags.writeable for value in observation.values())


def test_failed_step_observation_equals_the_previous_one_but_is_fresh(wall):
    env = gym.make("TEMP-2D-v0", fallback="none")
    env.reset(seed=0, options={"problem": Problem.from_dict(wall)})
    inside_wall = np.zeros(2)  # normalized centre = (10, 10), inside the wall
    for _ in range(7):
        before, *_ = env.step(inside_wall)
    after, _, _, _, info = env.step(inside_wall)
    assert info["collided"] and not info["added"]
    for key in before:
        np.testing.assert_array_equal(before[key], after[key])
        assert not np.shares_memory(before[key], after[key])


def test_observer_follows_a_new_tree_with_as_many_nodes(wall):
    problem = Problem.from_dict(wall)
    occupancy = occupancy_grid(problem.workspace, 32)
    observer = TreeObserver(problem, occupancy, 8, 100)
    first, second = Tree(problem), Tree(problem)
    first.extend(np.array([3.0, 10.0]))
    second.extend(np.array([3.0, 11.0]))  # same node count, another tree
    a, b = observer.observe(first), observer.observe(second)
    assert not np.array_equal(a["path"], b["path"])
    fresh = TreeObserver(problem, occupancy, 8, 100).observe(second)
    for key in b:
        np.testing.assert_array_equal(b[key], fresh[key])


def test_deep_copied_env_steps_like_the_original():
    env = gym.make("TEMP-2D-v0", fallback="random").unwrapped
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(50):
        env.step(rng.uniform(-1, 1, 2))
    twin = copy.deepcopy(env)
    for action in rng.uniform(-1, 1, (100, 2)):
        first, second = env.step(action), twin.step(action)
        assert first[1:4] == second[1:4] and first[4].keys() == second[4].keys()
        for key, value in first[0].items():
            np.testing.assert_array_equal(value, second[0][key])
            assert not np.shares_memory(value, second[0][key])


def test_path_so_far_is_the_path_entry_of_observe(wall):
    # The TEMP planner's fast path reads only these two entries; they must be what a full
    # observation of the same tree holds, with the path growing, shrinking and truncated to L.
    problem = Problem.from_dict(wall)
    occupancy = occupancy_grid(problem.workspace, 32)
    fast, full = TreeObserver(problem, occupancy, 4, 300), TreeObserver(problem, occupancy, 4, 300)
    tree = Tree(problem, step_size=1.0)
    rng = np.random.default_rng(0)
    lengths = set()
    for _ in range(300):  # the root alone first, then after each extension
        path, length = fast.path_so_far(tree)
        observation = full.observe(tree)
        tree.extend(rng.uniform(0.0, 20.0, 2))
        assert length == int(observation["path_length"][0])
        np.testing.assert_array_equal(path, observation["path"])
        lengths.add(length)
    assert lengths == {1, 2, 3, 4}
