"""Every value of a config within its bounds: sizes, rates, names and env ids.

`temp_gym.config.load_config` calls `check_config` after the overrides, so each command that
reads a config refuses an out-of-range value in one line before it writes anything or sizes
an array by it. The bounds come from `temp_gym.limits` (the one home of the supported
sizes); the few checks that need a robot (the occupancy grid's cells in 2D or 3D) or the file
system (`check_output_dir`) are made where those are known.

A count a section declares and `RANGES` does not list is bounded by ``0..MAX_COUNT``, and
every number must be finite, so no value a user can set escapes a bound.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
from pathlib import Path
from typing import Any

from temp_gym.config.errors import ConfigError
from temp_gym.config.typed import dotted
from temp_gym.jobs import brief
from temp_gym.limits import (
    MAX_BATCH_SIZE,
    MAX_CHUNK,
    MAX_COUNT,
    MAX_EPOCHS,
    MAX_MODEL_LAYERS,
    MAX_MODEL_WIDTH,
    MAX_NAME_LENGTH,
    MAX_PATH_LENGTH,
    MAX_SEI_TOKENS,
    MAX_TASKS,
    MAX_TASKS_PER_WORKSPACE,
    MAX_WORKERS,
    MIN_ENCODING_RESOLUTION,
    NAME_CHARACTERS,
)

INF = math.inf

RANGES: dict[str, tuple[float, float]] = {
    "env.encoding_resolution": (MIN_ENCODING_RESOLUTION, 512),
    "env.max_path_length": (2, MAX_PATH_LENGTH),
    "data.workers": (0, MAX_WORKERS),
    "data.tasks_per_workspace": (1, MAX_TASKS_PER_WORKSPACE),
    "data.max_nodes": (1, MAX_COUNT),
    "data.goal_bias": (0.0, 1.0),
    "data.attempts": (1, 1000),
    "model.token_dim": (1, MAX_MODEL_WIDTH),
    "model.num_heads": (1, MAX_MODEL_LAYERS),
    "model.num_layers": (1, MAX_MODEL_LAYERS),
    "model.ffn_dim": (1, MAX_MODEL_WIDTH),
    "model.num_sei_tokens": (1, MAX_SEI_TOKENS),
    "model.eise_hidden": (1, MAX_MODEL_WIDTH),
    "model.dropout": (0.0, 0.999),
    "model.chunk": (1, MAX_CHUNK),
    "optim.betas": (0.0, 0.9999999),
    "optim.lr_factor": (1e-6, 0.999999),
    "train.threads": (1, 4096),
    "train.batch_size": (1, MAX_BATCH_SIZE),
    "train.max_epochs": (1, MAX_EPOCHS),
    "train_eval.tasks": (0, MAX_TASKS),
    "train_eval.periodic_tasks": (0, MAX_TASKS),
    "train_eval.max_nodes": (2, MAX_COUNT),  # the planning env's least (a root and a node)
    "evaluation.tasks": (1, MAX_TASKS),
    "evaluation.max_nodes": (1, MAX_COUNT),
    "evaluation.curve_tasks": (0, MAX_TASKS),
    "evaluation.curve_nodes": (1, MAX_COUNT),
    "evaluation.horizon": (1, MAX_CHUNK),
    "evaluation.workers": (0, MAX_WORKERS),
    **{
        f"{section}.temp.{key}": bounds
        for section in ("train_eval", "evaluation")
        for key, bounds in {
            "attention_nodes": (1, MAX_COUNT),
            "attention_uniform": (0.0, 1.0),
            "attention_near_goal_factor": (1.0, INF),
            "attention_follow_fallback": (0.0, 1.0),
            "attention_resume_growth": (1.0, INF),
        }.items()
    },
}
"""Dotted key -> its inclusive ``(least, most)`` (each item of a list). A null stays allowed
where the section declares the key optional."""

POSITIVE = {"env.step_size", "data.planner_step_size", "model.offset_scale", "optim.lr",
            "optim.eps", "evaluation.time_limit"}  # fmt: skip
"""Numbers that must be above 0 (and finite)."""

CHOICES: dict[str, tuple[str, ...]] = {
    "train.monitor": ("loss", "semantic", "recons"),
    "logger.backend": ("tensorboard", ""),
    "train_eval.difficulty": ("mixed", "any", "easy", "challenging"),
}
"""Dotted key -> the values it may take (the home of these choices: the trainer and the logger
read them from here)."""

NAMES = ("train.exp_name",)
"""Keys that name a run: one path component of `NAME_CHARACTERS`, at most `MAX_NAME_LENGTH`."""

FOLDERS = ("data.dir", "logger.dir")
"""Keys that name a folder: a path, not empty."""

NAME = re.compile(r"^[A-Za-z0-9_-][A-Za-z0-9._-]*$")
"""A run name (`NAME_CHARACTERS`): one path component that cannot climb (``..``) or hide."""


def check_name(value: str, key: str) -> str:
    """``value`` if it can name a run folder, else a `ConfigError` saying what is allowed."""
    if len(value) > MAX_NAME_LENGTH:
        raise ConfigError(
            f"{key}: {len(value)} characters, at most {MAX_NAME_LENGTH} (it names a folder)"
        )
    if not NAME.match(value):
        raise ConfigError(f"{key}: {brief(value)} is not a run name; use {NAME_CHARACTERS}")
    return value


def check_config(config: Any) -> None:
    """Check every value of a built `temp_gym.config.Config` against its bounds.

    Raises:
        ConfigError: the first value out of bounds, naming the key, the value and the bound.
    """
    check_section(config, "")
    for key, choices in CHOICES.items():
        section, name = key.split(".")
        value = getattr(getattr(config, section), name)
        if value not in choices:
            raise ConfigError(f"{key}: expected one of {list(choices)}, got {brief(value)}")
    for key in NAMES:
        section, name = key.split(".")
        check_name(getattr(getattr(config, section), name), key)
    for key in FOLDERS:
        section, name = key.split(".")
        if not str(getattr(getattr(config, section), name)).strip():
            raise ConfigError(f"{key}: empty; give a folder")
    _check_env_id(config.env.id, config.env.robot)


def check_section(section: Any, where: str) -> None:
    """Check every value of one section (a dataclass) against its bounds, as `check_config`."""
    for field in dataclasses.fields(section):
        key = dotted(where, field.name)
        value = getattr(section, field.name)
        if dataclasses.is_dataclass(value):
            check_section(value, key)
        elif isinstance(value, list):
            for index, item in enumerate(value):
                _check_value(item, key, f"{key}[{index}]")
        else:
            _check_value(value, key, key)


def _check_value(value: Any, key: str, shown: str) -> None:
    if value is None or isinstance(value, bool):
        return
    if isinstance(value, str):
        if "\x00" in value:
            raise ConfigError(f"{shown}: holds a NUL character")
        return
    if not isinstance(value, (int, float)):
        return
    if isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(f"{shown}: expected a finite number, got {value}")
    least, most = RANGES.get(key, (0, MAX_COUNT) if isinstance(value, int) else (-INF, INF))
    if key in POSITIVE and not value > 0:
        raise ConfigError(f"{shown}: must be positive, got {value}")
    if key not in POSITIVE and isinstance(value, float) and key not in RANGES:
        least = 0.0  # rates, weights, noise and factors: none is negative
    if value < least:
        raise ConfigError(f"{shown}: must be at least {_number(least)}, got {_number(value)}")
    if value > most:
        raise ConfigError(f"{shown}: must be at most {_number(most)}, got {_number(value)}")


def _number(value: float) -> str:
    """A bound or value as a reader writes it: ``100000``, ``0.5``, ``1e+30``."""
    if isinstance(value, int) or (math.isfinite(value) and value.is_integer() and value < 1e15):
        return str(int(value))
    return f"{value:g}"


def registered_env_robots() -> dict[str, str | None]:
    """``{env id: robot}`` of every registered temp-gym env (what `import temp_gym` registers)."""
    from gymnasium.envs.registration import registry

    return {
        name: spec.kwargs.get("robot")
        for name, spec in registry.items()
        if str(spec.entry_point).startswith("temp_gym.")
    }


def _check_env_id(env_id: str, robot: str) -> None:
    """``env.id`` is a registered temp-gym env, and ``env.robot`` is its robot."""
    ours = registered_env_robots()
    if env_id not in ours:
        close = [name for name in ours if name.lower() == str(env_id).lower()]
        hint = f" (did you mean {close[0]}?)" if close else ""
        raise ConfigError(
            f"env.id: {brief(env_id)} is not a temp-gym env{hint}; expected one of {sorted(ours)}"
        )
    if ours[env_id] != robot:
        raise ConfigError(
            f"env.robot: {brief(robot)} is not the robot of {env_id} ({ours[env_id]}); give both "
            "of the same world"
        )


PATH_SHOWN = 300
"""Most characters of a path quoted in a message (paths are longer than other values)."""

SYSTEM_FOLDERS = ("/proc", "/sys", "/dev")
"""Folders of the kernel's: nothing of ours is written there."""


def check_output_dir(path: str | os.PathLike, key: str) -> Path:
    """``path`` if a command can make or use it as its output folder; nothing is created.

    Refused: an existing file or device (``/dev/null``), a path under a system folder
    (``/proc/x``), a path whose nearest existing parent is a file or cannot be written.

    Raises:
        ConfigError: naming ``key`` (a config key or a flag) and the reason.
    """
    text = os.fspath(path)
    if not str(text).strip():
        raise ConfigError(f"{key}: empty; give a folder")
    if "\x00" in str(text):
        raise ConfigError(f"{key}: holds a NUL character")
    folder = Path(text).expanduser().absolute()
    shown = brief(str(text), PATH_SHOWN)
    if folder.exists() and not folder.is_dir():
        raise ConfigError(f"{key}: {shown} is a file, not a folder")
    resolved = Path(os.path.realpath(folder))
    for system in SYSTEM_FOLDERS:
        if resolved == Path(system) or Path(system) in resolved.parents:
            raise ConfigError(f"{key}: {shown} is in {system}, a system folder; choose your own")
    parent = folder
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise ConfigError(
            f"{key}: {shown} cannot be made: {brief(str(parent), PATH_SHOWN)} is a file"
        )
    if not folder.exists() and not os.access(parent, os.W_OK | os.X_OK):
        raise ConfigError(
            f"{key}: {shown} cannot be made: {brief(str(parent), PATH_SHOWN)} is not writable"
        )
    return folder
