"""Where a dataset lives, which settings made it, and how the trainer reads it back.

The settings that determine a dataset's contents (the ``data:`` section minus ``dir`` and
``workers``, plus the env keys that shape samples) are written to ``{dir}/settings.json`` on
the first run. A later run with different settings refuses to mix them into the same
directory, so resumed units always match the rest of the dataset.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from temp_gym.config import Config, ConfigError
from temp_gym.data.columns import check_buffer, check_workspaces
from temp_gym.data.format import SPLITS
from temp_gym.data.tables import checked_manifest, read_table, verify_table
from temp_gym.files import StoredFileError, read_json
from temp_gym.planning.plan import PLANNERS
from temp_gym.problem import robot_names
from temp_gym.quiet import torchrl_info_silenced
from temp_gym.worlds.arm.spec import robot_digest
from temp_gym.worlds.generators import DIFFICULTIES
from temp_gym.worlds.robots import robot_spec
from temp_gym.worlds.splits import SPLITS as WORKSPACE_POOLS
from temp_gym.worlds.structured import BOXES, check_family

CARD = "dataset_card.json"
SETTINGS = "settings.json"


def workspace_family(settings: dict[str, Any]) -> str:
    """The workspace family of a dataset's settings (absent: ``boxes``, the default)."""
    return settings.get("workspace_family", BOXES)


def data_dir(config: Config) -> Path:
    """The dataset directory ``data.dir`` (relative paths are taken from the working dir)."""
    return Path(config.data.dir).expanduser().absolute()


def data_settings(config: Config) -> dict[str, Any]:
    """The validated, JSON-able settings that determine the dataset's contents.

    Nulls are resolved (the robot's encoding resolution, a whole workspace pool), so that the
    settings say what was made.

    Raises:
        ConfigError: For an invalid ``data``/``env`` value.
    """
    env, data = config.env, config.data
    robot = env.robot
    if robot not in robot_names():
        raise ConfigError(f"env.robot: expected one of {robot_names()}, got {robot!r}")
    workspaces = {}
    for split in SPLITS:
        count = getattr(data.workspaces, split)
        workspaces[split] = WORKSPACE_POOLS[split] if count is None else count
        if not 0 <= workspaces[split] <= WORKSPACE_POOLS[split]:
            raise ConfigError(
                f"data.workspaces.{split}: expected 0..{WORKSPACE_POOLS[split]}, "
                f"got {workspaces[split]}"
            )
    settings = {
        "robot": robot,
        "encoding_resolution": env.encoding_resolution or robot_spec(robot).encoding_resolution,
        "max_path_length": env.max_path_length,
        "step_size": env.step_size,
        "seed": data.seed,
        "workspaces": workspaces,
        "tasks_per_workspace": data.tasks_per_workspace,
        "difficulty": data.difficulty,
        "planner": data.planner,
        "max_nodes": data.max_nodes,
        "planner_step_size": data.planner_step_size,
        "goal_bias": data.goal_bias,
    }
    if data.attempts < 1:
        raise ConfigError(f"data.attempts: must be at least 1, got {data.attempts}")
    if data.attempts > 1:  # absent means 1: datasets made before the key existed keep theirs
        settings["attempts"] = data.attempts
    if data.expert_reverse:  # absent means False, as for every dataset before the key
        settings["expert_reverse"] = True
    if env.description is not None:  # an arm of a description file: workers register it
        settings["robot_description"] = env.description
        try:  # the arm itself, so that a dataset never mixes a description's edits
            settings["robot_digest"] = robot_digest(env.description)
        except (OSError, ValueError) as error:
            raise ConfigError(f"env.robot: {error}") from None
    try:
        check_family(robot, data.workspace_family, "data.workspace_family")
    except ValueError as error:
        raise ConfigError(str(error)) from None
    if data.workspace_family != BOXES:  # absent means boxes: older datasets keep theirs
        settings["workspace_family"] = data.workspace_family
    if settings["planner"] not in PLANNERS:
        raise ConfigError(f"data.planner: expected one of {sorted(PLANNERS)}")
    if settings["difficulty"] not in DIFFICULTIES:
        raise ConfigError(f"data.difficulty: expected one of {list(DIFFICULTIES)}")
    if settings["tasks_per_workspace"] < 1:
        raise ConfigError("data.tasks_per_workspace: must be at least 1")
    for key, value in (("env.step_size", env.step_size),
                       ("data.planner_step_size", data.planner_step_size)):  # fmt: skip
        if value is not None and not value > 0:
            raise ConfigError(f"{key}: expected a positive number or null, got {value!r}")
    if settings["max_path_length"] < 1:
        raise ConfigError("env.max_path_length: must be at least 1")
    return settings


FORMAT_VERSION = 2
"""Version of the on-disk layout in the card's ``format``. 2: tables of ``.npy`` columns with
sizes and SHA-256 in the card (1: torchrl ``dumps``, which pickles, and no checksums)."""

TABLES = ("buffer", "workspaces", "tasks")
"""The tables of a split, each a directory of columns (`temp_gym.data.tables`)."""


def read_card(root: str | Path) -> dict[str, Any]:
    """The dataset card of a dataset directory, checked for the current format.

    Raises:
        StoredFileError: no card, a damaged one, or one of an older format.
    """
    path = Path(root) / CARD
    card = read_json(path, f"no complete dataset in {root}: {GENERATE}")
    rebuild = f"{GENERATE}: it keeps the planned units and rebuilds the tables"
    if not isinstance(card, dict):
        raise StoredFileError(path, "damaged (not a JSON object)", rebuild)
    version = card.get("format", 1)
    if version != FORMAT_VERSION:
        if isinstance(version, int) and not isinstance(version, bool) and version > FORMAT_VERSION:
            problem = (
                f"written by a newer temp-gym (format {version} where {FORMAT_VERSION} is read)"
            )
            raise StoredFileError(path, problem, "update temp-gym, or " + rebuild)
        if version == 1:
            problem = (
                f"written by an older temp-gym (format 1 where {FORMAT_VERSION} is read; its "
                "replay buffer was saved with pickle and it lists no checksums)"
            )
        else:
            problem = f"damaged (format {version!r} where {FORMAT_VERSION} is read)"
        raise StoredFileError(path, problem, rebuild)
    checked_manifest(path, card, rebuild)
    return card


GENERATE = "rerun trainers/generate.py with the same config and data.dir"


def incomplete_reason(root: Path, settings: dict[str, Any]) -> str | None:
    """Why ``root`` does not hold a complete dataset of ``settings`` (None: it does).

    Cheap: the card, the settings and the size of every file the card lists; checksums are
    verified when a table is read (`load_split`).
    """
    if not (root / CARD).is_file():
        return "no dataset card"
    try:
        card = read_card(root)
    except StoredFileError as error:
        return str(error)
    if card.get("settings") != settings:
        return "its card was written with other settings"
    for name, entry in card["files"].items():  # `read_card` checked the list
        path = root / name
        if not path.is_file():
            return f"{path} is missing"
        if path.stat().st_size != entry["bytes"]:
            return f"{path} has {path.stat().st_size} bytes, the card says {entry['bytes']}"
    listed = {tuple(name.split("/", 2)[:2]) for name in card["files"]}
    for split in SPLITS:
        for table in TABLES:
            if (split, table) not in listed:
                return f"its card lists no files of {split}/{table}"
    return None


def upgraded_settings(stored: dict[str, Any], settings: dict[str, Any]) -> dict[str, Any]:
    """``stored`` settings of an older temp-gym, in today's layout for comparing to ``settings``.

    A described arm's dataset made before ``robot_digest`` was recorded takes today's digest:
    what robot made it cannot be known, and refusing it would throw its units away.
    """
    if "robot_description" in stored and "robot_digest" not in stored:
        if "robot_digest" in settings:
            return {**stored, "robot_digest": settings["robot_digest"]}
    return stored


def dataset_exists(config: Config) -> bool:
    """Whether ``data.dir`` holds a complete dataset made with this config's settings."""
    root = data_dir(config)
    try:
        stored = read_json(root / SETTINGS, "")
    except StoredFileError:
        return False
    settings = data_settings(config)
    if upgraded_settings(stored, settings) != settings:
        return False
    return incomplete_reason(root, settings) is None


def _table(root: Path, split: str, table: str) -> dict[str, np.ndarray]:
    """The verified columns of one table of ``split``."""
    if split not in SPLITS:
        raise ValueError(f"split: expected one of {list(SPLITS)}, got {split!r}")
    card = read_card(root)
    verify_table(root, f"{split}/{table}", card["files"])
    return read_table(root / split / table)


def _tensordict(columns: dict[str, np.ndarray]):
    import torch
    from tensordict import TensorDict

    rows = len(next(iter(columns.values()))) if columns else 0
    return TensorDict({k: torch.from_numpy(v) for k, v in columns.items()}, batch_size=[rows])


def load_workspaces(data_dir: str | Path, split: str):
    """The workspace table of ``split``: ``workspace_id`` and ``occupancy`` per row."""
    return _tensordict(_table(Path(data_dir), split, "workspaces"))


def load_tasks(data_dir: str | Path, split: str):
    """The task table of ``split`` (`temp_gym.data.format.TASK_KEYS`), one row per attempt."""
    return _tensordict(_table(Path(data_dir), split, "tasks"))


def load_split(data_dir: str | Path, split: str):
    """The replay buffer and workspace table of ``split``, verified against the card.

    The buffer is a `torchrl.data.ReplayBuffer` over a `TensorStorage` of the memory-mapped
    sample columns, with a `RandomSampler`: draw a batch with ``rb.sample(batch_size)``, or
    read every sample with ``rb[:]`` / ``rb.storage[i]``. Samples hold a ``workspace_id``;
    the encoding is ``workspaces["occupancy"][sample["workspace_id"]]``. No file is
    unpickled, every file must match the size and SHA-256 the card lists, and every value
    must lie in its range (`temp_gym.data.columns`: ids, lengths, finite normalized
    coordinates, occupancy in {0, 1}).

    Examples:
        >>> rb, workspaces = load_split("datasets/2d", "train")
        >>> batch = rb.sample(256)
        >>> occupancy = workspaces["occupancy"][batch["workspace_id"]]  # (256, 32, 32)

    Returns:
        ``(replay_buffer, workspaces)``.

    Raises:
        StoredFileError: the dataset is incomplete, of an older format, or a file is damaged
            or holds a value out of range (the message names the file and what to do).
    """
    from torchrl.data import ReplayBuffer, TensorStorage
    from torchrl.data.replay_buffers.samplers import RandomSampler

    root = Path(data_dir)
    settings = _card_settings(root)
    workspaces = _table(root, split, "workspaces")
    ids = check_workspaces(root / split / "workspaces", workspaces, settings)
    columns = _table(root, split, "buffer")
    check_buffer(root / split / "buffer", columns, settings, ids)
    samples = _tensordict(columns)
    with torchrl_info_silenced():
        buffer = ReplayBuffer(storage=TensorStorage(samples), sampler=RandomSampler())
    return buffer, _tensordict(workspaces)


def _card_settings(root: Path) -> dict[str, Any]:
    """The settings the card says made the dataset, which its columns are checked against."""
    card = read_card(root)
    settings = card.get("settings")
    keys = ("robot", "max_path_length", "encoding_resolution", "workspaces", "tasks_per_workspace")
    if not isinstance(settings, dict) or any(key not in settings for key in keys):
        raise StoredFileError(root / CARD, "damaged (no settings that made the dataset)", GENERATE)
    if settings["robot"] not in robot_names():
        raise StoredFileError(root / CARD, f"an unknown robot {settings['robot']!r}", GENERATE)
    return settings
