"""Where a dataset lives, which settings made it, and how the trainer reads it back.

The settings that determine a dataset's contents (the ``data:`` section minus ``dir`` and
``workers``, plus the env keys that shape samples) are written to ``{dir}/settings.json`` on
the first run. A later run with different settings refuses to mix them into the same
directory, so resumed units always match the rest of the dataset.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from temp_gym.data.format import SPLITS
from temp_gym.planning.plan import PLANNERS
from temp_gym.problem import ROBOTS
from temp_gym.quiet import torchrl_info_silenced
from temp_gym.worlds.encoding import DEFAULT_RESOLUTION
from temp_gym.worlds.generators import DIFFICULTIES
from temp_gym.worlds.splits import SPLITS as WORKSPACE_POOLS

CARD = "dataset_card.json"
SETTINGS = "settings.json"


def data_dir(config: dict[str, Any]) -> Path:
    """The dataset directory ``data.dir`` (relative paths are taken from the working dir)."""
    return Path(config["data"]["dir"]).expanduser().absolute()


def data_settings(config: dict[str, Any]) -> dict[str, Any]:
    """The validated, JSON-able settings that determine the dataset's contents.

    Raises:
        ValueError: For a missing or invalid ``data``/``env`` key.
    """
    env = config.get("env", {})
    data = config.get("data", {})
    robot = env.get("robot")
    if robot not in ROBOTS:
        raise ValueError(f"env.robot: expected one of {list(ROBOTS)}, got {robot!r}")
    requested = data.get("workspaces") or {}
    workspaces = {split: int(requested.get(split, WORKSPACE_POOLS[split])) for split in SPLITS}
    for split, count in workspaces.items():
        if not 0 <= count <= WORKSPACE_POOLS[split]:
            raise ValueError(
                f"data.workspaces.{split}: expected 0..{WORKSPACE_POOLS[split]}, got {count}"
            )
    settings = {
        "robot": robot,
        "encoding_resolution": int(env.get("encoding_resolution") or DEFAULT_RESOLUTION[robot]),
        "max_path_length": int(env.get("max_path_length", 64)),
        "step_size": env.get("step_size"),
        "seed": int(data.get("seed", 0)),
        "workspaces": workspaces,
        "tasks_per_workspace": int(data.get("tasks_per_workspace", 200)),
        "difficulty": data.get("difficulty", "any"),
        "planner": data.get("planner", "informed_rrt_star"),
        "max_nodes": int(data.get("max_nodes", 2000)),
        "planner_step_size": data.get("planner_step_size"),
        "goal_bias": float(data.get("goal_bias", 0.05)),
    }
    if settings["planner"] not in PLANNERS:
        raise ValueError(f"data.planner: expected one of {sorted(PLANNERS)}")
    if settings["difficulty"] not in DIFFICULTIES:
        raise ValueError(f"data.difficulty: expected one of {list(DIFFICULTIES)}")
    if settings["tasks_per_workspace"] < 1:
        raise ValueError("data.tasks_per_workspace: must be at least 1")
    for key in ("step_size", "planner_step_size"):
        value = settings[key]
        if value is not None and not (isinstance(value, (int, float)) and value > 0):
            raise ValueError(f"{key}: expected a positive number or null, got {value!r}")
    if settings["max_path_length"] < 1:
        raise ValueError("env.max_path_length: must be at least 1")
    return settings


def write_json_atomic(path: Path, payload: Any) -> None:
    """Write JSON to a temporary file beside ``path`` and rename it into place."""
    temporary = path.with_name(f".{path.name}.tmp{os.getpid()}")
    with open(temporary, "w") as handle:
        json.dump(payload, handle, indent=2, sort_keys=True)
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(temporary, path)


def dataset_exists(config: dict[str, Any]) -> bool:
    """Whether ``data.dir`` holds a complete dataset made with this config's settings."""
    root = data_dir(config)
    if not (root / CARD).is_file() or not (root / SETTINGS).is_file():
        return False
    with open(root / SETTINGS) as handle:
        return json.load(handle) == data_settings(config)


def load_workspaces(data_dir: str | Path, split: str):
    """The workspace table of ``split``: ``workspace_id`` and ``occupancy`` per row."""
    from tensordict import TensorDict

    return TensorDict.load_memmap(Path(data_dir) / split / "workspaces")


def load_tasks(data_dir: str | Path, split: str):
    """The task table of ``split`` (`temp_gym.data.format.TASK_KEYS`), one row per attempt."""
    from tensordict import TensorDict

    return TensorDict.load_memmap(Path(data_dir) / split / "tasks")


def load_split(data_dir: str | Path, split: str):
    """The replay buffer and workspace table of ``split``.

    The buffer is a `torchrl.data.ReplayBuffer` over a `LazyMemmapStorage` (restored with
    ``rb.loads``) with a `RandomSampler`: draw a batch with ``rb.sample(batch_size)``, or
    read every sample with ``rb[:]`` / ``rb.storage[i]``. Samples hold a ``workspace_id``;
    the encoding is ``workspaces["occupancy"][sample["workspace_id"]]``.

    Example:
        >>> rb, workspaces = load_split("datasets/2d", "train")
        >>> batch = rb.sample(256)
        >>> occupancy = workspaces["occupancy"][batch["workspace_id"]]  # (256, 32, 32)

    Returns:
        ``(replay_buffer, workspaces)``.
    """
    from torchrl.data import LazyMemmapStorage, ReplayBuffer
    from torchrl.data.replay_buffers.samplers import RandomSampler

    if split not in SPLITS:
        raise ValueError(f"split: expected one of {list(SPLITS)}, got {split!r}")
    root = Path(data_dir)
    buffer_dir = root / split / "buffer"
    if not (root / CARD).is_file() or not buffer_dir.is_dir():
        raise FileNotFoundError(f"{root}: no complete dataset (run trainers/generate.py first)")
    with open(buffer_dir / "storage" / "storage_metadata.json") as handle:
        size = int(json.load(handle)["len"])
    # loads() fills a storage of exactly the saved size.
    with torchrl_info_silenced():
        buffer = ReplayBuffer(storage=LazyMemmapStorage(max(size, 1)), sampler=RandomSampler())
        if size:
            buffer.loads(buffer_dir)
    return buffer, load_workspaces(root, split)
