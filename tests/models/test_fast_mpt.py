"""FastMPT (numba) against the PyTorch MPT, and TEMPPolicy's backends."""

import numpy as np
import pytest
import torch

from temp_gym import Problem, plan
from temp_gym.models.fast_mpt import FastMPT
from temp_gym.models.policy import TEMPPolicy
from temp_gym.models.temp import TEMPModel

TOLERANCE = 1e-5
PROBLEM = Problem.load("examples/point2d.json")


def _model(robot, prediction="offset", seed=0, **sizes) -> TEMPModel:
    """A randomly initialised model whose LayerNorms are perturbed (not the identity)."""
    torch.manual_seed(seed)
    config = {"token_dim": 32, "num_heads": 4, "num_layers": 2, "ffn_dim": 64}
    config |= {"num_sei_tokens": 4, "eise_hidden": 32, "prediction": prediction, **sizes}
    model = TEMPModel(robot, encoding_resolution=8, max_path_length=16, **config).eval()
    with torch.no_grad():
        for module in model.mpt.modules():
            if isinstance(module, torch.nn.LayerNorm):
                module.weight.add_(0.3 * torch.randn_like(module.weight))
                module.bias.add_(0.3 * torch.randn_like(module.bias))
        # Larger positional encodings and output token than the init's std 0.02.
        for parameter in (model.mpt.position, model.mpt.path_position, model.mpt.output_token):
            parameter.normal_(0.0, 0.5)
    return model


def _inputs(mpt, rng):
    d = mpt.dim
    width = mpt.output_token.shape[-1]
    return (
        torch.tensor(rng.normal(size=(1, mpt.num_sei_tokens, width)), dtype=torch.float32),
        torch.tensor(rng.uniform(-1, 1, (1, d)), dtype=torch.float32),
        torch.tensor([[rng.uniform(0.01, 0.2)]], dtype=torch.float32),
        torch.tensor(rng.uniform(-1, 1, (1, d)), dtype=torch.float32),
    )


def _torch_sample(mpt, sei, goal, radius, start, path, length):
    with torch.inference_mode():
        sample, _ = mpt(sei, goal, radius, start, path[None, :length], torch.tensor([length]))
    return sample[0].numpy()


@pytest.mark.parametrize("prediction", ["offset", "absolute"])
@pytest.mark.parametrize(
    ("robot", "layers", "chunk"),
    [("point2d", 1, 1), ("point2d", 3, 1), ("point2d", 2, 4), ("point3d", 2, 1),
     ("point3d", 2, 3), ("kuka_iiwa14", 2, 1), ("kuka_iiwa14", 1, 2)],
)  # fmt: skip
def test_matches_torch_for_every_path_length(robot, layers, chunk, prediction):
    model = _model(robot, prediction, num_layers=layers, chunk=chunk)
    mpt = model.mpt
    fast = FastMPT(mpt)
    rng = np.random.default_rng(layers)
    sei, goal, radius, start = _inputs(mpt, rng)
    prefix = fast.prefix(sei[0].numpy(), goal[0].numpy(), float(radius), start[0].numpy())
    path = torch.tensor(rng.uniform(-1, 1, (mpt.max_path_length, mpt.dim)), dtype=torch.float32)
    for length in range(1, mpt.max_path_length + 1):
        expected = _torch_sample(mpt, sei, goal, radius, start, path, length)
        got = fast.predict(prefix, path.numpy(), length)  # rows after `length`: ignored
        assert got.dtype == np.float32 and got.shape == (chunk, mpt.dim)
        np.testing.assert_allclose(got, expected, rtol=0, atol=TOLERANCE, err_msg=f"{length}")
        trimmed = fast.forward(sei, goal, radius, start, path[:length].numpy(), length)
        np.testing.assert_allclose(trimmed, expected, rtol=0, atol=TOLERANCE)


@pytest.mark.parametrize("robot", ["point2d", "kuka_iiwa14"])
def test_matches_torch_at_the_configured_sizes(robot):
    """The shipped configs' sizes (token width 64, L = 64), a few lengths."""
    from temp_gym.config import load_config

    config = load_config("configs/2d.yaml" if robot == "point2d" else "configs/7d.yaml")
    torch.manual_seed(1)
    model = TEMPModel.from_config(config.model, robot, 8, config.env.max_path_length)
    mpt = model.eval().mpt
    fast = FastMPT(mpt)
    rng = np.random.default_rng(1)
    sei, goal, radius, start = _inputs(mpt, rng)
    prefix = fast.prefix(sei, goal, float(radius), start)
    for length in (1, 2, 9, 30, mpt.max_path_length):
        path = torch.tensor(rng.uniform(-1, 1, (length, mpt.dim)), dtype=torch.float32)
        expected = _torch_sample(mpt, sei, goal, radius, start, path, length)
        got = fast.predict(prefix, path.numpy(), length)
        np.testing.assert_allclose(got, expected, rtol=0, atol=TOLERANCE)


def test_saturated_offsets_are_clipped_like_torch():
    model = _model("point2d")
    with torch.no_grad():
        model.mpt.head.bias.fill_(50.0)  # tanh -> 1: the offset pushes past the bounds
    fast = FastMPT(model.mpt)
    rng = np.random.default_rng(0)
    sei, goal, radius, start = _inputs(model.mpt, rng)
    path = torch.full((3, 2), 0.9)
    got = fast.forward(sei, goal, radius, start, path.numpy(), 3)
    np.testing.assert_array_equal(got, [[1.0, 1.0]])
    np.testing.assert_allclose(
        got, _torch_sample(model.mpt, sei, goal, radius, start, path, 3), atol=TOLERANCE
    )


def test_chunk_rows_continue_from_one_another_and_saturate_like_torch():
    model = _model("point2d", chunk=3)
    with torch.no_grad():
        model.mpt.head.bias.copy_(torch.tensor([50.0, -50.0] * 3))  # +0.5, -0.5 per row
    fast = FastMPT(model.mpt)
    sei, goal, radius, start = _inputs(model.mpt, np.random.default_rng(0))
    path = torch.tensor([[0.2, -0.1]])
    got = fast.forward(sei, goal, radius, start, path.numpy(), 1)
    np.testing.assert_allclose(got, [[0.7, -0.6], [1.0, -1.0], [1.0, -1.0]], atol=1e-6)
    np.testing.assert_allclose(
        got, _torch_sample(model.mpt, sei, goal, radius, start, path, 1), atol=TOLERANCE
    )


def test_bad_path_lengths_are_errors():
    model = _model("point2d")
    fast = FastMPT(model.mpt)
    prefix = fast.prefix(np.zeros((4, 32)), np.zeros(2), 0.1, np.zeros(2))
    path = np.zeros((16, 2), np.float32)
    for length in (0, 17):
        with pytest.raises(ValueError, match="path_length"):
            fast.predict(prefix, path, length)
    with pytest.raises(ValueError, match="path_length"):
        fast.predict(prefix, path[:3], 4)
    with pytest.raises(ValueError, match="path"):
        fast.predict(prefix, np.zeros((16, 3), np.float32), 2)


def test_weights_are_a_snapshot():
    model = _model("point2d")
    fast = FastMPT(model.mpt)
    rng = np.random.default_rng(0)
    sei, goal, radius, start = _inputs(model.mpt, rng)
    path = np.zeros((2, 2), np.float32)
    before = fast.forward(sei, goal, radius, start, path, 2)
    with torch.no_grad():
        model.mpt.head.bias.add_(1.0)
    np.testing.assert_array_equal(fast.forward(sei, goal, radius, start, path, 2), before)


# ---- TEMPPolicy backends ---------------------------------------------------------------------


class Recorder:
    """Wraps a policy and keeps every sample it returns."""

    def __init__(self, policy):
        self.policy = policy
        self.encoding_resolution = policy.encoding_resolution  # what the planner encodes
        self.max_path_length = policy.max_path_length
        self.samples = []

    def reset(self, problem, seed=None):
        self.policy.reset(problem, seed=seed)

    def __call__(self, observation):
        sample = self.policy(observation)
        self.samples.append(sample)
        return sample


@pytest.mark.parametrize("noise_std", [0.0, 0.05])
def test_policy_backends_plan_the_same_episode(noise_std):
    model = _model("point2d", num_layers=3)
    runs = {}
    for backend in ("torch", "numba"):
        policy = Recorder(TEMPPolicy(model, noise_std=noise_std, seed=5, backend=backend))
        result = plan(
            PROBLEM, planner="temp", policy=policy, seed=3, max_nodes=150, attention_nodes=120
        )
        runs[backend] = (result, np.array(policy.samples))
    (torch_result, torch_samples), (numba_result, numba_samples) = runs.values()
    assert len(torch_samples) == len(numba_samples) > 50
    np.testing.assert_allclose(numba_samples, torch_samples, rtol=0, atol=TOLERANCE)
    assert numba_result.nodes == torch_result.nodes
    assert numba_result.attention["nodes"] == torch_result.attention["nodes"]
    assert numba_result.success == torch_result.success
    if torch_result.success:
        np.testing.assert_allclose(numba_result.path, torch_result.path, atol=1e-4)


def test_policy_backend_choice():
    model = _model("point2d")
    with pytest.raises(ValueError, match="backend"):
        TEMPPolicy(model, backend="jax")
    with pytest.raises(ValueError, match="numba"):
        TEMPPolicy(model, backend="numba", record_attention=True)
    assert TEMPPolicy(model, backend="torch")._fast is None
    observation = {"path": np.zeros((16, 2), np.float32), "path_length": np.array([1])}
    observation["path"][0] = [-0.8, -0.8]
    # "auto": the fast path, but PyTorch whenever attention is recorded (switchable).
    policy = TEMPPolicy(model)
    assert isinstance(policy._fast, FastMPT)
    policy.reset(PROBLEM)
    fast_sample = policy(observation)
    assert policy.attentions == []
    policy.record_attention = True
    np.testing.assert_allclose(policy(observation), fast_sample, atol=TOLERANCE)
    assert len(policy.attentions) == 1
    strict = TEMPPolicy(model, backend="numba")
    strict.reset(PROBLEM)
    np.testing.assert_array_equal(strict(observation), fast_sample)
    strict.record_attention = True
    with pytest.raises(ValueError, match="attention"):
        strict(observation)


@pytest.mark.parametrize("robot", ["point2d", "point3d", "kuka_iiwa14"])
def test_task_prefix_equals_the_numpy_steps_and_prefix(robot):
    """One compiled call gives bit for bit the task `normalize` and `prefix` make, any bounds."""
    from temp_gym.worlds.normalization import goal_radius_ratio, normalize

    fast = FastMPT(_model(robot, chunk=2).mpt)
    rng = np.random.default_rng(3)
    width = fast.width
    for _ in range(50):
        d = fast.dim
        low = rng.uniform(-7.0, 3.0, d)
        bounds = np.stack([low, low + rng.uniform(0.1, 13.0, d)])
        start, goal = rng.uniform(bounds[0], bounds[1], (2, d))
        radius = float(rng.uniform(1e-3, 2.0))
        sei = rng.normal(size=(fast.num_sei_tokens, width)).astype(np.float32)
        ratio = goal_radius_ratio(radius, bounds)
        (goal32, ratio32, start32), prefix = fast.task_prefix(sei, start, goal, bounds, ratio)
        expected_goal, expected_start = normalize(np.array([goal, start]), bounds)
        np.testing.assert_array_equal(goal32, expected_goal.astype(np.float32))
        np.testing.assert_array_equal(start32, expected_start.astype(np.float32))
        np.testing.assert_array_equal(ratio32, np.array([ratio], np.float32))
        expected = fast.prefix(sei, goal32, ratio32, start32)
        np.testing.assert_array_equal(prefix.goal, expected.goal)
        np.testing.assert_array_equal(prefix.z, expected.z)
        np.testing.assert_array_equal(prefix.qkv, expected.qkv)
