import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import temp_gym
from temp_gym import ENV_IDS, Problem, plan
from temp_gym.policies import InformedPolicy, UniformPolicy


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_env_checker_passes_with_rendering(env_id):
    env = gym.make(env_id, render_mode="rgb_array")
    check_env(env.unwrapped)
    env.reset(seed=1)
    image = env.render()
    assert image.ndim == 3 and image.shape[2] == 3 and image.dtype == np.uint8
    env.close()
    env.close()  # idempotent


def test_make_with_module_prefix_works_without_prior_import():
    import subprocess
    import sys

    code = "import gymnasium as g; e = g.make('temp_gym:TEMP-7D-v0'); e.reset(seed=0); print('ok')"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "ok" in out.stdout


def rollout(env_id, seed, actions, **kwargs):
    env = gym.make(env_id, **kwargs)
    observations = [env.reset(seed=seed)[0]]
    for action in actions:
        observation, reward, terminated, truncated, info = env.step(action)
        observations.append(observation)
        if terminated or truncated:
            break
    env.close()
    return observations


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_same_seed_and_actions_same_observations(env_id):
    dim = gym.make(env_id).action_space.shape[0]
    actions = np.random.default_rng(0).uniform(-1, 1, size=(25, dim)).astype(np.float32)
    first = rollout(env_id, 5, actions)
    second = rollout(env_id, 5, actions)
    assert len(first) == len(second)
    for a, b in zip(first, second):
        assert a.keys() == b.keys()
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])
    other = rollout(env_id, 6, actions)
    assert not all(np.array_equal(a["start"], b["start"]) for a, b in zip(first, other))


def test_observations_are_fresh_arrays():
    env = gym.make("TEMP-2D-v0")
    first, _ = env.reset(seed=0)
    second, *_ = env.step(env.action_space.sample())
    for key in first:
        assert not np.shares_memory(first[key], second[key])


def run_policy_episode(env, policy, seed, problem=None):
    options = None if problem is None else {"problem": problem}
    observation, info = env.reset(seed=seed, options=options)
    policy.reset(env.unwrapped.problem)
    while True:
        observation, reward, terminated, truncated, info = env.step(policy(observation))
        if terminated or truncated:
            return info


@pytest.mark.parametrize("env_id", ["TEMP-2D-v0", "TEMP-3D-v0"])
@pytest.mark.parametrize("seed", [0, 3])
def test_uniform_policy_env_equals_rrt_star(env_id, seed):
    env = gym.make(env_id, fallback="none")
    info = run_policy_episode(env, UniformPolicy(seed=seed), seed=seed)
    problem = env.unwrapped.problem
    result = plan(problem, planner="rrt_star", seed=seed, stop_at_first=True, max_nodes=3000)
    assert result.success and info["success"]
    assert result.nodes == info["nodes"]
    assert result.sampling_failures == info["sampling_failures"]
    # Same nodes up to the float rounding of normalizing and denormalizing the action.
    np.testing.assert_allclose(info["path"], result.path, rtol=0, atol=1e-9)
    assert info["best_cost"] == pytest.approx(result.cost, abs=1e-9)


def test_informed_policy_solves_and_samples_inside_the_informed_set(wall):
    problem = Problem.from_dict(wall)
    env = gym.make("TEMP-2D-v0", target_cost=0.0, max_nodes=1500, fallback="none")
    policy = InformedPolicy(seed=0)
    observation, _ = env.reset(seed=0, options={"problem": problem})
    policy.reset(problem)
    best = np.inf
    while True:
        action = policy(observation)
        if best < np.inf:
            sample = temp_gym.worlds.normalization.denormalize(action, problem.bounds)
            focal = np.linalg.norm(sample - problem.start) + np.linalg.norm(sample - problem.goal)
            assert focal <= best + problem.goal_radius + 1e-6
        observation, reward, terminated, truncated, info = env.step(action)
        best = info["best_cost"]
        if terminated or truncated:
            break
    assert info["success"] and truncated


def test_fallback_none_colliding_action_adds_no_node(wall):
    problem = Problem.from_dict(wall)
    env = gym.make("TEMP-2D-v0", fallback="none")
    env.reset(seed=0, options={"problem": problem})
    # Start (2, 10) steers towards (10, 10) by 1.0: free. Then walk into the wall.
    inside_wall = np.array([0.0, 0.0], np.float32)  # normalized centre = (10, 10)
    for _ in range(7):
        _, _, _, _, info = env.step(inside_wall)
    nodes = info["nodes"]
    _, reward, _, _, info = env.step(inside_wall)
    assert info["collided"] and not info["added"] and info["nodes"] == nodes
    assert reward == pytest.approx(-env.unwrapped.step_penalty)


def test_fallback_random_always_adds_a_node_and_counts_failures(wall):
    problem = Problem.from_dict(wall)
    env = gym.make("TEMP-2D-v0", fallback="random")
    env.reset(seed=0, options={"problem": problem})
    inside_wall = np.zeros(2, np.float32)
    failures = 0
    for step in range(1, 20):
        _, _, _, _, info = env.step(inside_wall)
        assert info["added"] and info["nodes"] == step + 1
        failures = info["sampling_failures"]
    assert failures > 0


def test_bad_actions_documented_behaviour():
    env = gym.make("TEMP-2D-v0", fallback="none")
    env.reset(seed=0)
    tree = env.unwrapped.tree
    for bad in ([np.nan, 0.0], [0.0, np.inf]):
        with pytest.raises(ValueError, match="finite"):
            env.step(np.array(bad, np.float32))
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(3, np.float32))
    assert tree.num_nodes == 1 and tree.samples == 0  # nothing corrupted
    # Out of range is clipped: the same as stepping the clipped action.
    clipped = rollout("TEMP-2D-v0", 0, [np.array([0.9, 1.0])], fallback="none")
    outside = rollout("TEMP-2D-v0", 0, [np.array([0.9, 7.5])], fallback="none")
    for key in clipped[-1]:
        np.testing.assert_array_equal(clipped[-1][key], outside[-1][key])


def test_step_before_reset_and_bad_options(wall):
    env = gym.make("TEMP-2D-v0").unwrapped
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(2, np.float32))
    with pytest.raises(ValueError, match="robot"):
        env.reset(
            options={
                "problem": Problem.from_dict(
                    {
                        **wall,
                        "robot": "point3d",
                        "bounds": [[0, 0, 0], [20, 20, 20]],
                        "obstacles": [],
                        "start": [1, 1, 1],
                        "goal": [5, 5, 5],
                    }
                )
            }
        )
    with pytest.raises(ValueError, match="options"):
        env.reset(options={"problme": None})
    with pytest.raises(ValueError, match="difficulty"):
        gym.make("TEMP-2D-v0", difficulty="hard")


def test_target_cost_option_keeps_refining_after_first_solution(wall):
    problem = Problem.from_dict({**wall, "obstacles": []})
    env = gym.make("TEMP-2D-v0", fallback="none", max_nodes=3000)
    policy = UniformPolicy(seed=1)
    first = run_policy_episode(env, policy, seed=1, problem=problem)
    target = 1.02 * 16.0 - problem.goal_radius
    observation, _ = env.reset(seed=1, options={"problem": problem, "target_cost": target})
    policy.reset(problem)
    while True:
        observation, _, terminated, truncated, info = env.step(policy(observation))
        if terminated or truncated:
            break
    assert terminated and info["best_cost"] <= target < first["best_cost"]
    assert info["nodes"] > first["nodes"]


def test_reward_is_step_penalty_plus_success_bonus(wall):
    problem = Problem.from_dict({**wall, "obstacles": []})
    env = gym.make("TEMP-2D-v0", fallback="none")
    env.reset(seed=0, options={"problem": problem})
    goal = np.array([0.8, 0.0], np.float32)  # (18, 10)
    total = 0.0
    for _ in range(30):
        _, reward, terminated, _, info = env.step(goal)
        total += reward
        if terminated:
            break
    assert terminated and info["success"]
    assert total == pytest.approx(1.0 - 0.01 * info["nodes"] + 0.01, abs=1e-9)
    assert info["path"][0].tolist() == problem.start.tolist()


def test_torchrl_gymenv_7d_specs_and_rollout():
    torchrl_envs = pytest.importorskip("torchrl.envs")
    from torchrl.envs.utils import check_env_specs

    env = torchrl_envs.GymEnv("TEMP-7D-v0", max_nodes=50)
    env.set_seed(0)
    check_env_specs(env)
    data = env.rollout(10)
    assert data["next", "path"].shape[-2:] == (64, 7)
    env.close()


@pytest.mark.parametrize("difficulty", ["easy", "challenging", "mixed"])
def test_difficulty_and_split_draws(difficulty):
    from temp_gym.worlds.splits import SPLITS, split_workspace

    for split in SPLITS:
        env = gym.make("TEMP-2D-v0", difficulty=difficulty, split=split)
        env.reset(seed=0)
        assert env.unwrapped.problem.robot == "point2d"
        pool = [split_workspace("point2d", split, index) for index in range(SPLITS[split])]
        assert env.unwrapped.problem.workspace in pool


@pytest.mark.parametrize(("env_id", "family"), [("TEMP-2D-v0", "maze"), ("TEMP-3D-v0", "traps")])
def test_tasks_are_drawn_in_the_workspaces_of_the_asked_family(env_id, family):
    from temp_gym.worlds.splits import SPLITS, split_workspace

    env = gym.make(env_id, split="val", workspace_family=family)
    env.reset(seed=3)
    workspace = env.unwrapped.problem.workspace
    robot = env.unwrapped.robot
    pool = [split_workspace(robot, "val", index, family) for index in range(SPLITS["val"])]
    boxes = [split_workspace(robot, "val", index) for index in range(SPLITS["val"])]
    assert workspace in pool and workspace not in boxes


def test_an_unknown_family_is_refused_when_the_env_is_made():
    with pytest.raises(ValueError, match="workspace_family: expected one of"):
        gym.make("TEMP-2D-v0", workspace_family="forest")
    with pytest.raises(ValueError, match="workspace_family: expected one of"):
        gym.make("TEMP-7D-v0", workspace_family="forest")


def test_the_arm_env_draws_tasks_in_its_structured_family():
    from temp_gym.worlds.splits import split_workspace

    env = gym.make("TEMP-7D-v0", workspace_family="maze", split="val")
    env.reset(seed=3)
    workspace = env.unwrapped.problem.workspace
    pool = [split_workspace("kuka_iiwa14", "val", i, "maze") for i in range(20)]
    assert any(workspace == candidate for candidate in pool)
    assert all(workspace != split_workspace("kuka_iiwa14", "val", i) for i in range(20))
    env.close()
