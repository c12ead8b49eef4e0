"""FastEISE (numba) against the PyTorch EISE, and the policy core that uses it."""

import numpy as np
import pytest
import torch

from temp_gym import Problem
from temp_gym.models.eise import EISE
from temp_gym.models.fast_eise import FastEISE
from temp_gym.models.policy import PolicyCore, TEMPPolicy
from temp_gym.models.temp import TEMPModel
from temp_gym.worlds.encoding import occupancy_grid

TOLERANCE = 1e-5


def _eise(grid_shape, hidden=48, seed=0) -> EISE:
    """A random EISE whose biases are spread out, so that both ReLUs cut many units."""
    torch.manual_seed(seed)
    eise = EISE(grid_shape, hidden=hidden, num_tokens=4, token_dim=16).eval()
    with torch.no_grad():
        for layer in (eise.encoder[0], eise.encoder[2]):
            layer.bias.normal_(0.0, 0.5)
    return eise


def _torch(eise, grid) -> np.ndarray:
    with torch.inference_mode():
        return eise(torch.from_numpy(grid).unsqueeze(0))[0].numpy()


@pytest.mark.parametrize("grid_shape", [(8, 8), (32, 32), (6, 6, 6), (16, 16, 16)])
@pytest.mark.parametrize("density", [0.0, 0.1, 0.5, 1.0])
def test_matches_torch_on_occupancy_grids(grid_shape, density):
    eise = _eise(grid_shape)
    fast = FastEISE(eise)
    rng = np.random.default_rng(7)
    grid = (rng.random(grid_shape) < density).astype(np.float32)
    expected = _torch(eise, grid)
    got = fast(grid)
    assert got.dtype == np.float32 and got.shape == expected.shape == (4, 16)
    np.testing.assert_allclose(got, expected, atol=TOLERANCE, rtol=TOLERANCE)
    # The ReLU zeros are exact zeros, as torch's (compared where torch is clearly nonzero).
    assert np.all(got[expected == 0] <= TOLERANCE)
    assert np.all(got[np.abs(expected) > 1e-3] != 0)


def test_matches_torch_on_any_grid_values():
    """A grid of fractions, negatives and zeros (not what the planner feeds, but a grid)."""
    eise = _eise((10, 10), seed=3)
    grid = np.random.default_rng(3).normal(size=(10, 10)).astype(np.float32)
    grid[grid < 0.2] = 0.0
    np.testing.assert_allclose(FastEISE(eise)(grid), _torch(eise, grid), atol=1e-4, rtol=1e-5)


def test_nan_spreads_as_in_torch():
    eise = _eise((8, 8))
    grid = np.zeros((8, 8), np.float32)
    grid[2, 3] = np.nan
    assert np.isnan(_torch(eise, grid)).all()
    assert np.isnan(FastEISE(eise)(grid)).all()


def test_wrong_grid_shape_is_a_clear_error():
    fast = FastEISE(_eise((8, 8)))
    with pytest.raises(ValueError, match=r"expected a grid of shape \(8, 8\)"):
        fast(np.zeros((8, 9), np.float32))


def test_weights_are_a_snapshot():
    eise = _eise((8, 8))
    fast = FastEISE(eise)
    grid = np.ones((8, 8), np.float32)
    before = fast(grid).copy()
    with torch.no_grad():
        eise.encoder[0].weight.add_(1.0)
    np.testing.assert_array_equal(fast(grid), before)


def test_fast_core_and_torch_core_give_the_same_sei():
    torch.manual_seed(0)
    sizes = {"token_dim": 32, "num_heads": 4, "num_layers": 1, "ffn_dim": 32}
    model = TEMPModel("point2d", encoding_resolution=16, max_path_length=8, **sizes)
    problem = Problem.load("examples/point2d.json")
    fast_tensor, fast_array = PolicyCore(model, fast=True).sei(problem)
    slow_tensor, slow_array = PolicyCore(model, fast=False).sei(problem)
    np.testing.assert_allclose(fast_array, slow_array, atol=TOLERANCE, rtol=TOLERANCE)
    np.testing.assert_array_equal(fast_tensor.numpy()[0], fast_array)
    assert fast_tensor.shape == slow_tensor.shape == (1, model.mpt.num_sei_tokens, 32)


def test_policy_follows_a_new_grid_with_the_fast_encoder():
    """An observation of another workspace (a vector env's reset) is encoded by `FastEISE`."""
    torch.manual_seed(1)
    sizes = {"token_dim": 32, "num_heads": 4, "num_layers": 1, "ffn_dim": 32}
    model = TEMPModel("point2d", encoding_resolution=16, max_path_length=8, **sizes)
    problem = Problem.load("examples/point2d.json")
    fast = TEMPPolicy(model, backend="numba")
    torch_policy = TEMPPolicy(model, backend="torch")
    grid = occupancy_grid(problem.workspace, 16)
    other = np.ascontiguousarray(grid[::-1])  # another workspace's grid, same task
    observation = {
        "occupancy": other,
        "goal": np.zeros(2, np.float32),
        "goal_radius": np.array([0.05], np.float32),
        "start": np.full(2, -0.5, np.float32),
        "path": np.full((8, 2), -0.5, np.float32),
        "path_length": np.array([1]),
    }
    np.testing.assert_allclose(fast(observation), torch_policy(observation), atol=1e-4)
    np.testing.assert_allclose(
        fast._sei_array, torch_policy._sei.numpy()[0], atol=TOLERANCE, rtol=TOLERANCE
    )


@pytest.mark.parametrize("robot", ["point2d", "point3d", "kuka_iiwa14"])
def test_encode_workspace_equals_encoding_its_occupancy_grid(robot):
    """One compiled call gives bit for bit `FastEISE(occupancy_grid(...))`, on every family."""
    from temp_gym.worlds.splits import split_workspace

    resolution = 16 if robot == "kuka_iiwa14" else 24
    dims = 3 if robot != "point2d" else 2
    fast = FastEISE(_eise((resolution,) * dims, seed=5))
    for family in ("boxes", "mixed"):
        for index in range(6):
            workspace = split_workspace(robot, "val", index, family)
            grid = occupancy_grid(workspace, resolution)
            np.testing.assert_array_equal(fast.encode_workspace(workspace), fast(grid))


def test_encode_workspace_equals_encoding_its_occupancy_grid_for_every_obstacle_kind():
    """Rotated boxes, cylinders and spheres: the compiled path marks what the Python one does."""
    from scipy.spatial.transform import Rotation

    from temp_gym.problem import Workspace
    from temp_gym.problem.obstacles import Box, Cylinder, Sphere
    from temp_gym.worlds.robots import robot_spec

    rng = np.random.default_rng(2)
    for robot, resolution in (("point2d", 24), ("point3d", 16), ("kuka_iiwa14", 16)):
        spec = robot_spec(robot)
        dims = spec.workspace_dim
        bounds = (
            spec.joint_limits() if spec.joint_limits else np.array([[0.0] * dims, [20.0] * dims])
        )
        region = spec.region(bounds)
        scale = float(np.max(region[1] - region[0])) / 8
        fast = FastEISE(_eise((resolution,) * dims, seed=6))
        for _ in range(4):
            obstacles = []
            for i in range(9):
                center = tuple(rng.uniform(region[0], region[1]))
                turn = tuple(Rotation.random(random_state=rng).as_quat())
                if i % 3 == 0:
                    half = tuple(rng.uniform(0.05, 1.0, dims) * scale)
                    obstacles.append(Box(center, half, turn if dims == 3 else float(turn[0])))
                elif i % 3 == 1 and dims == 3:
                    obstacles.append(Cylinder(center, 0.5 * scale, 1.5 * scale, turn))
                else:
                    obstacles.append(Sphere(center, float(rng.uniform(0.1, 0.8)) * scale))
            workspace = Workspace.from_obstacles(robot, bounds, obstacles)
            grid = occupancy_grid(workspace, resolution)
            assert 0 < grid.sum() < grid.size
            np.testing.assert_array_equal(fast.encode_workspace(workspace), fast(grid))


def test_encode_workspace_of_another_dimension_is_a_clear_error():
    fast = FastEISE(_eise((8, 8)))
    workspace = Problem.load("examples/point3d.json").workspace
    with pytest.raises(ValueError, match=r"no occupancy grid of the encoder's shape \(8, 8\)"):
        fast.encode_workspace(workspace)
