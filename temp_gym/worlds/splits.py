"""Fixed, seeded pools of workspaces: the train / val / test split.

Workspace ``i`` of split ``s`` for robot ``r`` is drawn from its own generator, seeded by
``SeedSequence([SPLIT_ENTROPY, r's seed code (RobotSpec.seed_code), split code, i])``; so it
never changes, does not depend on which other workspaces were drawn, and the same ids serve
demonstration generation (train, val), training, and evaluation (test). A config uses the first
N of a pool. The paper has 80 training and 20 validation workspaces (our configs' default); the
training pool holds 320, because a policy trained on 320 workspaces x 50 tasks generalizes
better to unseen ones than on the paper's 80 x 200 (the shipped 2D policy; its model card gives
the figures). Growing a pool leaves its first workspaces as they were. The test pool is
disjoint from both.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from temp_gym.problem import Workspace
from temp_gym.worlds.robots import robot_spec

SPLITS = {"train": 320, "val": 20, "test": 50}
"""Number of workspaces in each split."""
SPLIT_ENTROPY = 20241122
_SPLIT_CODES = {name: code for code, name in enumerate(SPLITS)}


def _check(split: str, index: int) -> None:
    if split not in SPLITS:
        raise ValueError(f"split: expected one of {list(SPLITS)}, got {split!r}")
    if not 0 <= index < SPLITS[split]:
        raise ValueError(
            f"index: split {split!r} has workspaces 0..{SPLITS[split] - 1}, not {index}"
        )


def workspace_rng(robot: str, split: str, index: int) -> np.random.Generator:
    """The generator that draws workspace ``index`` of ``split``."""
    spec = robot_spec(robot)
    _check(split, index)
    sequence = np.random.SeedSequence([SPLIT_ENTROPY, spec.seed_code, _SPLIT_CODES[split], index])
    return np.random.default_rng(sequence)


@lru_cache(maxsize=256)
def split_workspace(robot: str, split: str, index: int) -> Workspace:
    """Workspace ``index`` of ``split`` for ``robot`` (cached; always the same one)."""
    return robot_spec(robot).generate_workspace(workspace_rng(robot, split, index))
