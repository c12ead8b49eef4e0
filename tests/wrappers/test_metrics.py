"""PlanningMetrics and TensorBoardMetrics stacked with Gymnasium's standard wrappers."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.wrappers import RecordEpisodeStatistics, TimeLimit

import temp_gym  # noqa: F401  (registers the envs)
from temp_gym.wrappers import EPISODE_KEYS, INFO_KEY, PlanningMetrics, TensorBoardMetrics


def run_episode(env: gym.Env, seed: int = 0) -> dict:
    env.reset(seed=seed)
    env.action_space.seed(seed)
    while True:
        _, _, terminated, truncated, info = env.step(env.action_space.sample())
        if terminated or truncated:
            return info


def make(max_nodes: int = 40) -> gym.Env:
    return gym.make("TEMP-2D-v0", max_nodes=max_nodes)


STACKS = {
    "planning_inside": lambda: RecordEpisodeStatistics(PlanningMetrics(make())),
    "planning_outside": lambda: PlanningMetrics(RecordEpisodeStatistics(make())),
    "tensorboard_inside": lambda log: RecordEpisodeStatistics(
        TensorBoardMetrics(make(), log_dir=log)
    ),
    "tensorboard_outside": lambda log: TensorBoardMetrics(
        RecordEpisodeStatistics(make()), log_dir=log
    ),
}


@pytest.mark.parametrize("name", list(STACKS))
def test_stacks_with_record_episode_statistics_in_either_order(name, tmp_path):
    build = STACKS[name]
    env = build(tmp_path) if name.startswith("tensorboard") else build()
    info = run_episode(env)
    planning, standard = info[INFO_KEY], info["episode"]
    assert INFO_KEY == "planning" and set(planning) == set(EPISODE_KEYS)
    # Both wrappers measured the same episode.
    assert planning["steps"] == standard["l"]
    assert planning["return"] == pytest.approx(standard["r"])
    assert planning["nodes"] == info["nodes"]
    env.close()


def test_tensorboard_logs_each_episode_when_stacked(tmp_path):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    env = TensorBoardMetrics(RecordEpisodeStatistics(TimeLimit(make(), 25)), log_dir=tmp_path)
    for seed in range(3):
        run_episode(env, seed)
    env.close()
    events = EventAccumulator(str(tmp_path))
    events.Reload()
    assert [event.step for event in events.Scalars("eval/nodes")] == [0, 1, 2]


def test_planning_metrics_twice_is_named():
    env = PlanningMetrics(PlanningMetrics(make()))
    with pytest.raises(ValueError, match="PlanningMetrics twice"):
        run_episode(env)


def test_vector_env_masks_planning_and_episode_separately():
    def build():
        return RecordEpisodeStatistics(PlanningMetrics(make(max_nodes=30)))

    envs = gym.vector.SyncVectorEnv([build, build])
    envs.reset(seed=0)
    envs.action_space.seed(0)
    finished = 0
    for _ in range(80):
        _, _, _, _, infos = envs.step(envs.action_space.sample())
        if INFO_KEY in infos:
            mask = infos[f"_{INFO_KEY}"]
            np.testing.assert_array_equal(mask, infos["_episode"])
            np.testing.assert_array_equal(
                infos[INFO_KEY]["steps"][mask], infos["episode"]["l"][mask]
            )
            finished += int(mask.sum())
    envs.close()
    assert finished >= 2


@pytest.mark.parametrize("vector_cls", [gym.vector.SyncVectorEnv, gym.vector.AsyncVectorEnv])
def test_vector_envs_roll_out_with_metrics(vector_cls):
    def make():
        return PlanningMetrics(gym.make("TEMP-2D-v0", max_nodes=60))

    envs = vector_cls([make, make])
    envs.reset(seed=0)
    finished = 0
    for _ in range(150):
        _, _, terminated, truncated, infos = envs.step(envs.action_space.sample())
        if "planning" in infos:
            mask = infos["_planning"]
            finished += int(mask.sum())
            assert np.all(infos["planning"]["nodes"][mask] >= 2)
    envs.close()
    assert finished >= 2


def test_tensorboard_wrapper_writes_events(tmp_path):
    env = TensorBoardMetrics(gym.make("TEMP-2D-v0", max_nodes=30), log_dir=tmp_path)
    env.reset(seed=0)
    for _ in range(100):
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            env.reset()
    assert env.episodes >= 1
    env.close()
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = EventAccumulator(str(tmp_path))
    events.Reload()
    tags = events.Tags()["scalars"]
    assert "eval/nodes" in tags and "eval/success" in tags
