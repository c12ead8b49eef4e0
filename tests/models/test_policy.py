import gymnasium as gym
import numpy as np
import pytest
import torch

from temp_gym import Problem
from temp_gym.models.attention import GROUPS, group_attention, normalized_group_attention
from temp_gym.models.policy import TEMPPolicy
from temp_gym.models.temp import TEMPModel, load_checkpoint
from temp_gym.planning.policy import (
    FAST_PATHS,
    ChunkProposer,
    CompiledProposer,
    Proposer,
    SamplingPolicy,
    fast_path,
    policy_settings,
)
from temp_gym.wrappers.metrics import PlanningMetrics

PROBLEM = Problem.load("examples/point2d.json")


@pytest.fixture
def policy(small_model):
    return TEMPPolicy(small_model, record_attention=True)


def test_is_a_sampling_policy_and_plans_in_the_env(policy):
    assert isinstance(policy, SamplingPolicy)
    env = PlanningMetrics(
        gym.make(
            "TEMP-2D-v0",
            fallback="random",
            max_nodes=60,
            encoding_resolution=16,
            max_path_length=16,
        )
    )
    observation, _ = env.reset(seed=0, options={"problem": PROBLEM})
    policy.reset(PROBLEM)
    for _ in range(60):
        action = policy(observation)
        assert action.dtype == np.float32 and action.shape == (2,)
        assert np.all(np.abs(action) <= 1)
        observation, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    assert "planning" in info
    assert len(policy.attentions) == info["planning"]["steps"]


def test_noise_makes_repeated_calls_differ_and_is_seeded(small_model):
    observation = _observation()
    deterministic = TEMPPolicy(small_model)
    deterministic.reset(PROBLEM)
    np.testing.assert_array_equal(deterministic(observation), deterministic(observation))
    noisy = TEMPPolicy(small_model, noise_std=0.1, seed=3)
    noisy.reset(PROBLEM)
    first, second = noisy(observation), noisy(observation)
    assert not np.array_equal(first, second)
    again = TEMPPolicy(small_model, noise_std=0.1, seed=3)
    again.reset(PROBLEM)
    np.testing.assert_array_equal(again(observation), first)


def test_reset_with_a_seed_restarts_the_noise_as_a_new_policy_with_that_seed(small_model):
    observation = _observation()
    policy = TEMPPolicy(small_model, noise_std=0.1, seed=3)
    policy.reset(PROBLEM)
    policy(observation)  # the generator is made and drawn from
    for seed in (7, 3, 7):
        policy.reset(PROBLEM, seed=seed)
        fresh = TEMPPolicy(small_model, noise_std=0.1, seed=seed)
        fresh.reset(PROBLEM)
        for _ in range(3):
            np.testing.assert_array_equal(policy(observation), fresh(observation))
    policy.reset(PROBLEM, seed=11)
    np.testing.assert_array_equal(policy.rng.random(4), np.random.default_rng(11).random(4))


def test_propose_from_the_path_alone_equals_the_observation_call(small_model):
    env = gym.make("TEMP-2D-v0", fallback="random", encoding_resolution=16, max_path_length=16)
    observation, _ = env.reset(seed=0, options={"problem": PROBLEM})
    rng = np.random.default_rng(0)
    for _ in range(30):  # a path of several rows
        observation, *_ = env.step(rng.uniform(-1, 1, 2))
    length = int(observation["path_length"][0])
    assert length > 1
    for noise in (0.0, 0.1):
        by_observation = TEMPPolicy(small_model, noise_std=noise, seed=5)
        by_path = TEMPPolicy(small_model, noise_std=noise, seed=5)
        by_observation.reset(PROBLEM)
        by_path.reset(PROBLEM)
        for _ in range(3):
            expected = by_observation(observation)
            proposed = by_path.propose(observation["path"], length)
            assert proposed.dtype == np.float32
            np.testing.assert_array_equal(proposed, expected)


def test_checkpoint_round_trip_weights_only(small_model, tmp_path):
    policy = TEMPPolicy(small_model)
    policy.save(tmp_path / "model.pt")
    raw = torch.load(tmp_path / "model.pt", weights_only=True)
    assert raw["robot"] == "point2d" and raw["dim"] == 2 and raw["version"] == 1
    assert raw["encoding_resolution"] == 16 and raw["max_path_length"] == 16
    loaded = TEMPPolicy.from_checkpoint(tmp_path / "model.pt", robot="point2d")
    for key, value in small_model.state_dict().items():
        torch.testing.assert_close(loaded.model.state_dict()[key], value)
    observation = _observation()
    policy.reset(PROBLEM)
    loaded.reset(PROBLEM)
    np.testing.assert_array_equal(policy(observation), loaded(observation))


def test_wrong_robot_or_dimension_is_a_clear_error(small_model, tmp_path):
    small_model.save(tmp_path / "model.pt")
    with pytest.raises(ValueError, match="trained for point2d .* d=7"):
        load_checkpoint(tmp_path / "model.pt", dim=7)
    with pytest.raises(ValueError, match="trained for robot 'point2d'"):
        TEMPPolicy.from_checkpoint(tmp_path / "model.pt", robot="kuka_iiwa14")
    policy = TEMPPolicy.from_checkpoint(tmp_path / "model.pt")
    iiwa_env = gym.make("TEMP-7D-v0", split="test")
    iiwa_env.reset(seed=0)
    with pytest.raises(ValueError, match="trained for point2d"):
        policy.reset(iiwa_env.unwrapped.problem)
    with pytest.raises(ValueError, match=r"observation\['occupancy'\]: expected shape \(16, 16\)"):
        policy(iiwa_env.reset(seed=0)[0])


def test_not_a_checkpoint_is_an_error(tmp_path):
    torch.save({"weights": torch.zeros(1)}, tmp_path / "other.pt")
    with pytest.raises(ValueError, match="not a TEMP checkpoint"):
        load_checkpoint(tmp_path / "other.pt")


def test_group_attention_along_a_plan(policy):
    env = gym.make(
        "TEMP-2D-v0", fallback="random", max_nodes=30, encoding_resolution=16, max_path_length=16
    )
    observation, _ = env.reset(seed=0, options={"problem": PROBLEM})
    policy.reset(PROBLEM)
    for _ in range(10):
        observation, *_ = env.step(policy(observation))
    layers, heads = 2, 4
    assert policy.attentions[0].shape[:2] == (layers, heads)
    step = group_attention(policy.attentions[-1], num_sei_tokens=4)
    assert set(step) == set(GROUPS)
    assert 0 < sum(step.values()) <= 1 + 1e-6
    manual = policy.attentions[-1][-1].mean(0)[0]  # Eq. 8 by hand: last layer, output query
    assert step["SEI"] == pytest.approx(manual[1:5].sum(), abs=1e-6)
    weights = normalized_group_attention(policy.attentions, num_sei_tokens=4, layer="mean")
    for group in GROUPS:
        assert weights[group].shape == (10,)
        assert weights[group].min() >= 0 and weights[group].max() <= 1
        if np.ptp(weights["raw_" + group]) > 0:
            assert weights[group].min() == 0 and weights[group].max() == pytest.approx(1)


def test_model_sizes_within_budget():
    from temp_gym.config import load_config

    for name in ("2d", "3d", "7d"):
        config = load_config(f"configs/{name}.yaml")
        env = config.env
        model = TEMPModel.from_config(
            config.model, env.robot, env.encoding_resolution, env.max_path_length
        )
        assert model.num_parameters() * 4 < 10e6 * 0.95, name


def _observation():
    env = gym.make("TEMP-2D-v0", encoding_resolution=16, max_path_length=16)
    observation, _ = env.reset(seed=0, options={"problem": PROBLEM})
    return observation


def test_reset_restores_the_torch_thread_count(small_model):
    # The fast path encodes the workspace on one thread (no OpenMP workers left spinning
    # beside the planner) and must leave the user's setting as it was.
    from temp_gym.worlds.generators import generate_problem

    previous = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        policy = TEMPPolicy(small_model.eval())
        policy.reset(generate_problem("point2d", np.random.default_rng(0)))
        assert torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(previous)


def test_attention_nodes_is_a_checked_setting(small_model):
    assert TEMPPolicy(small_model, attention_nodes=40).attention_nodes == 40
    assert TEMPPolicy(small_model).attention_nodes is None
    with pytest.raises(ValueError, match="attention_nodes"):
        TEMPPolicy(small_model, attention_nodes=0)


def _task_observation(problem, resolution=16):
    env = gym.make("TEMP-2D-v0", encoding_resolution=resolution, max_path_length=16)
    observation, _ = env.reset(seed=0, options={"problem": problem})
    return observation


@pytest.mark.parametrize("backend", ["numba", "torch"])
def test_follows_the_observation_after_an_untold_reset(small_model, backend):
    other = Problem.from_dict(
        {
            **PROBLEM.to_dict(),
            "obstacles": [{"center": [6, 12], "half_extents": [2, 2]}],
            "start": [3, 17],
            "goal": [17, 3],
        }
    )
    same_task_other_walls = Problem.from_dict(
        {**PROBLEM.to_dict(), "obstacles": [{"center": [10, 4], "half_extents": [3, 1]}]}
    )
    stale = TEMPPolicy(small_model, backend=backend)
    stale.reset(PROBLEM)
    first = stale(_task_observation(PROBLEM))
    for problem in (other, same_task_other_walls, PROBLEM):
        observation = _task_observation(problem)
        fresh = TEMPPolicy(small_model, backend=backend)
        fresh.reset(problem)
        expected = fresh(observation)
        np.testing.assert_array_equal(stale(observation), expected)
        assert (problem is PROBLEM) == np.array_equal(expected, first)  # a stale one would not
    np.testing.assert_array_equal(stale(_task_observation(PROBLEM)), first)
    never_reset = TEMPPolicy(small_model, backend=backend)
    np.testing.assert_array_equal(never_reset(_task_observation(PROBLEM)), first)


def test_an_env_at_another_resolution_needs_a_reset(small_model):
    observation = _task_observation(PROBLEM, resolution=32)
    policy = TEMPPolicy(small_model)
    with pytest.raises(ValueError, match="observation\\['occupancy'\\]"):
        policy(observation)
    policy.reset(PROBLEM)  # the problem's own grid at the model's resolution
    reference = TEMPPolicy(small_model)
    reference.reset(PROBLEM)
    np.testing.assert_array_equal(policy(observation), reference(_task_observation(PROBLEM)))


def test_a_path_only_observation_uses_the_reset_task(small_model):
    full = _task_observation(PROBLEM)
    path_only = {key: full[key] for key in ("path", "path_length")}
    never_reset = TEMPPolicy(small_model)
    with pytest.raises(ValueError, match=r"observation: expected .*'occupancy'"):
        never_reset(path_only)
    policy = TEMPPolicy(small_model)
    policy.reset(PROBLEM)
    np.testing.assert_array_equal(policy(path_only), policy(full))


def test_a_temp_policy_meets_the_contract_with_every_fast_path(small_model):
    policy = TEMPPolicy(small_model, attention_nodes=40)
    for protocol in (SamplingPolicy, Proposer, ChunkProposer, CompiledProposer):
        assert isinstance(policy, protocol)
    assert all(fast_path(policy, name) is not None for name in FAST_PATHS)
    declared = policy_settings(policy)
    assert declared.attention_nodes == 40
    assert declared.encoding_resolution == small_model.encoding_resolution
    assert declared.max_path_length == small_model.max_path_length
    problem = Problem.load("examples/point2d.json")
    policy.reset(problem, seed=0)
    path = np.zeros((policy.max_path_length, 2), np.float32)
    assert policy.propose_chunk(path, 1).shape == (policy.chunk, 2)


@pytest.mark.parametrize("backend", ["numba", "torch"])
def test_a_reset_to_the_problem_it_holds_keeps_the_encoding(small_model, backend, monkeypatch):
    other = Problem.from_dict({**PROBLEM.to_dict(), "start": [3, 17], "goal": [17, 3]})
    observation = _task_observation(PROBLEM)
    policy = TEMPPolicy(small_model, noise_std=0.1, backend=backend)
    policy.reset(PROBLEM, seed=2)
    first = policy(observation)
    encodings = []
    for name in ("sei", "sei_array"):  # the numba path asks for the array alone
        method = getattr(policy.core, name)

        def counted(problem, method=method):
            encodings.append(problem)
            return method(problem)

        monkeypatch.setattr(policy.core, name, counted)
    policy.reset(PROBLEM, seed=2)  # the same problem: no encoding, the noise re-seeded
    np.testing.assert_array_equal(policy(observation), first)
    assert encodings == []
    policy(_task_observation(other))  # followed away to another task ...
    policy.reset(PROBLEM, seed=2)  # ... so the same problem is encoded again
    assert encodings == [PROBLEM]
    np.testing.assert_array_equal(policy(observation), first)


@pytest.mark.parametrize("backend", ["numba", "torch"])
def test_turns_between_two_problems_encode_neither_again(small_model, backend, monkeypatch):
    # The TEMP planner's turns between its tree and the goal tree: the problem and the
    # swapped one, in turn.
    swapped = Problem.from_dict({**PROBLEM.to_dict(), "start": PROBLEM.goal.tolist(),
                                 "goal": PROBLEM.start.tolist()})  # fmt: skip
    path = np.zeros((16, 2), np.float32)
    path[:3] = [[-0.5, -0.5], [-0.4, -0.3], [-0.2, -0.25]]
    fresh = {}
    for problem in (PROBLEM, swapped):
        alone = TEMPPolicy(small_model, backend=backend)
        alone.reset(problem)
        fresh[id(problem)] = alone.propose(path, 3)
    policy = TEMPPolicy(small_model, backend=backend)
    policy.reset(PROBLEM)
    policy.reset(swapped)
    calls = []
    for name in ("sei", "sei_array"):
        method = getattr(policy.core, name)

        def counted(problem, method=method):
            calls.append(problem)
            return method(problem)

        monkeypatch.setattr(policy.core, name, counted)
    prefix = getattr(policy._fast, "prefix", None)
    if prefix is not None:
        monkeypatch.setattr(policy._fast, "prefix", lambda *a: calls.append("prefix") or prefix(*a))
    for problem in (PROBLEM, swapped, PROBLEM, swapped, PROBLEM):
        policy.reset(problem)
        assert policy.problem is problem
        np.testing.assert_array_equal(policy.propose(path, 3), fresh[id(problem)])
    assert calls == []
    policy.forget_workspace(PROBLEM.workspace)  # forgets the other problem's task too
    policy.reset(swapped)
    assert calls[0] == swapped
    np.testing.assert_array_equal(policy.propose(path, 3), fresh[id(swapped)])


def test_clear_encodings_makes_the_next_reset_encode_the_workspace_again(small_model, monkeypatch):
    core = TEMPPolicy(small_model).core
    first = TEMPPolicy(None, core=core)
    first.reset(PROBLEM)
    grids = []
    encode = core._encode_workspace

    def counted(workspace):
        grids.append(workspace)
        return encode(workspace)

    monkeypatch.setattr(core, "_encode_workspace", counted)
    second = TEMPPolicy(None, core=core)
    second.reset(PROBLEM)  # the workspace's encoding is cached in the shared core
    assert grids == []
    core.clear_encodings()
    third = TEMPPolicy(None, core=core)
    third.reset(PROBLEM)
    assert len(grids) == 1
    np.testing.assert_array_equal(third._sei_array, first._sei_array)


def test_forget_workspace_makes_the_next_reset_encode_it_again(small_model, monkeypatch):
    from temp_gym.worlds import encoding

    other = Problem.from_dict({**PROBLEM.to_dict(), "start": [3, 17], "goal": [17, 3]})
    policy = TEMPPolicy(small_model)
    policy.reset(PROBLEM)
    kept = policy._sei_array.copy()
    encodings = []
    encode = policy.core._encode_workspace

    def counted_encode(workspace):
        encodings.append(workspace)
        return encode(workspace)

    monkeypatch.setattr(policy.core, "_encode_workspace", counted_encode)
    policy.reset(other)  # the same workspace: its encoding is remembered
    assert encodings == []
    policy.forget_workspace(PROBLEM.workspace)
    assert encoding._grid.cache_info().currsize == 0  # the grids are forgotten too
    policy.reset(other)  # a problem in the forgotten workspace: encoded again
    assert encodings == [PROBLEM.workspace]
    policy.forget_workspace(PROBLEM.workspace)
    policy.reset(other)  # even the problem the policy holds
    assert len(encodings) == 2
    np.testing.assert_array_equal(policy._sei_array, kept)


def test_observations_a_policy_cannot_read_are_named_not_crashed_on(small_model):
    policy = TEMPPolicy(small_model)
    observation = _observation()
    cases = [
        ([1, 2], "expected the env's observation dict"),
        ({k: v for k, v in observation.items() if k != "path"}, r"no \['path'\]"),
        ({**observation, "path": np.full_like(observation["path"], np.nan)}, "must be finite"),
        ({**observation, "path_length": np.array([0])}, "path_length"),
        ({**observation, "goal": np.zeros(3, np.float32)}, r"observation\['goal'\].*another robot"),
        (
            {
                **observation,
                "occupancy": np.stack([observation["occupancy"]] * 2),
                "goal": np.stack([observation["goal"]] * 2),
            },
            "a batch of 2 grids",
        ),
    ]
    for bad, message in cases:
        with pytest.raises(ValueError, match=message):
            policy(bad)
    assert policy(observation).shape == (2,)  # the policy still plans after the refusals


def test_the_planner_settings_a_policy_carries_are_checked_as_the_planner_checks_them(
    small_model,
):
    with pytest.raises(TypeError, match=r"unknown settings \['attention_patiense'\]"):
        TEMPPolicy(small_model, attention_patiense=3)
    with pytest.raises(ValueError, match="^attention_rounds: expected an integer"):
        TEMPPolicy(small_model, attention_rounds=-1)
    policy = TEMPPolicy(small_model, attention_rounds=2)
    assert policy.planner_settings()["attention_rounds"] == 2
    assert policy.fresh().attention_rounds == 2 and policy.fresh().attention_patience is None


def test_from_checkpoint_applies_the_settings_a_checkpoint_carries_as_the_registry_does():
    from temp_gym.models import registry
    from temp_gym.models.policy import TEMPPolicy
    from temp_gym.planning.policy import policy_settings

    path = registry.shipped_checkpoint("point2d")
    direct = TEMPPolicy.from_checkpoint(path)
    assert policy_settings(direct) == policy_settings(registry.policy_from_checkpoint(path))
    assert direct.attention_patience is not None  # the shipped policy carries one
    assert TEMPPolicy.from_checkpoint(path, attention_patience=7).attention_patience == 7
