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

The ``tune`` pool (100 workspaces, disjoint from the others) is for choosing planner settings
(`trainers/tune_planner.py --split tune`). The env draws a task's workspace uniformly from its
split's pool, so growing ``val`` would redraw every validation task measured before; and 20
workspaces are too few to estimate a failure rate of half a percent when failures cluster in a
few workspaces (a narrow pocket), which is what the 2D policy's do.

**Workspace families** (`temp_gym.worlds.structured`): the pools above are the default family,
``boxes`` (the robot's own generator), and never change. Any other family, ``mixed`` included,
has pools of its own: its name joins the seed sequence (``SeedSequence([..., i,
family code])``, the code being the name's bytes read as an integer), so its workspaces depend
on neither the default pools nor another family's. Evaluation uses the default test pool.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from temp_gym.problem import Workspace
from temp_gym.worlds.generators import generate_workspace
from temp_gym.worlds.robots import robot_spec
from temp_gym.worlds.structured import BOXES, check_family

SPLITS = {"train": 320, "val": 20, "test": 50, "tune": 100}
"""Number of workspaces in each split (new splits join at the end: a split's code is its place)."""
SPLIT_ENTROPY = 20241122
_SPLIT_CODES = {name: code for code, name in enumerate(SPLITS)}


def _check(split: str, index: int) -> None:
    if split not in SPLITS:
        raise ValueError(f"split: expected one of {list(SPLITS)}, got {split!r}")
    if not 0 <= index < SPLITS[split]:
        raise ValueError(
            f"index: split {split!r} has workspaces 0..{SPLITS[split] - 1}, not {index}"
        )


def family_code(family: str) -> int:
    """A family's entry in the seed sequence: its name's bytes as an integer (stable, unique)."""
    return int.from_bytes(family.encode("utf-8"), "big")


def workspace_rng(robot: str, split: str, index: int, family: str = BOXES) -> np.random.Generator:
    """The generator that draws workspace ``index`` of ``split`` (of a workspace ``family``)."""
    spec = robot_spec(robot)
    _check(split, index)
    check_family(robot, family)
    entropy = [SPLIT_ENTROPY, spec.seed_code, _SPLIT_CODES[split], index]
    if family != BOXES:  # the default family keeps the pools drawn before families existed
        entropy.append(family_code(family))
    return np.random.default_rng(np.random.SeedSequence(entropy))


@lru_cache(maxsize=256)
def split_workspace(robot: str, split: str, index: int, family: str = BOXES) -> Workspace:
    """Workspace ``index`` of ``split`` for ``robot`` (cached; always the same one).

    ``family`` names a workspace family (`temp_gym.worlds.structured`); the default,
    ``boxes``, is the robot's own generator, whose pools datasets and checkpoints were made
    from.

    Examples:
        >>> maze = split_workspace("point2d", "train", 0, "maze")
    """
    rng = workspace_rng(robot, split, index, family)
    return generate_workspace(robot, rng, family)
