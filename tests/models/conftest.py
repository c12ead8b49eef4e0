"""Synthetic demonstrations with the keys of temp_gym.data.format, for model tests."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from temp_gym.models.temp import TEMPModel

SMALL = {
    "token_dim": 32,
    "num_heads": 4,
    "num_layers": 2,
    "ffn_dim": 64,
    "num_sei_tokens": 4,
    "eise_hidden": 64,
}


def synthetic_batch(
    count: int, dim: int = 2, grid: tuple[int, ...] = (16, 16), length: int = 16, seed: int = 0
) -> dict[str, torch.Tensor]:
    """Straight-line "expert" paths from start to goal; the target is the next point."""
    rng = np.random.default_rng(seed)
    start = rng.uniform(-0.9, 0.9, (count, dim))
    goal = rng.uniform(-0.9, 0.9, (count, dim))
    steps = 20
    last = rng.integers(0, min(length, steps), count)  # index k of the prefix's last node
    path = np.zeros((count, length, dim))
    target = np.zeros((count, dim))
    for i, k in enumerate(last):
        points = start[i] + np.linspace(0, 1, steps + 1)[:, None] * (goal[i] - start[i])
        path[i, : k + 1] = points[: k + 1]
        target[i] = points[k + 1]
    lengths = last + 1
    occupancy = (rng.random((count, *grid)) < 0.2).astype(np.float32)
    return {
        "occupancy": torch.from_numpy(occupancy),
        "start": torch.tensor(start, dtype=torch.float32),
        "goal": torch.tensor(goal, dtype=torch.float32),
        "goal_radius": torch.full((count, 1), 0.05),
        "path": torch.tensor(path, dtype=torch.float32),
        "path_length": torch.tensor(lengths, dtype=torch.int64).reshape(count, 1),
        "target": torch.tensor(target, dtype=torch.float32),
    }


@pytest.fixture
def small_model() -> TEMPModel:
    torch.manual_seed(0)
    return TEMPModel("point2d", encoding_resolution=16, max_path_length=16, **SMALL)


@pytest.fixture
def make_batch():
    return synthetic_batch


@pytest.fixture
def small_config() -> dict:
    return dict(SMALL)


@pytest.fixture(autouse=True)
def one_thread():
    # Tiny models: threads only add synchronisation (and stall badly on a busy machine).
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)
