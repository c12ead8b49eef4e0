"""Every column of a dataset table within its range, checked against the card when loaded.

The card's checksums prove that the files are the ones it lists, not that the values make
sense: a card rewritten to match edited columns passes them. So `check_columns` reads each
column of a table once more, in blocks of rows (bounded memory on a paper-scale buffer), and
refuses, naming the file, a value that no generator writes: a ``workspace_id`` missing from
the workspace table, a ``path_length`` outside ``1..L``, a coordinate that is not finite or
outside the normalized ``[-1, 1]``, an occupancy that is not 0 or 1, a shape that is not the
card's. The trainer then never meets an index out of range or a NaN target.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from temp_gym.data.format import sample_shapes
from temp_gym.files import StoredFileError
from temp_gym.worlds.robots import robot_spec

BLOCK_ROWS = 2**16
"""Rows read per block: a block of the widest column (the 7D paths) is about 100 MB."""

NORMALIZED_SLACK = 1e-5
"""How far past [-1, 1] a normalized float32 coordinate may round."""

REMEDY = (
    "the dataset was edited or damaged after it was made; delete data.dir and rerun "
    "trainers/generate.py"
)
"""What to do about a value out of range (its card's checksums were rewritten to match)."""


def _blocks(array: np.ndarray):
    for start in range(0, len(array), BLOCK_ROWS):
        yield np.asarray(array[start : start + BLOCK_ROWS])


def _refuse(path: Path, problem: str) -> None:
    raise StoredFileError(path, problem, REMEDY)


def _check_shape(path: Path, array: np.ndarray, dtype: str, shape: tuple[int, ...]) -> None:
    if array.dtype != np.dtype(dtype) or array.shape[1:] != shape:
        _refuse(path, f"a column of {array.dtype} {array.shape[1:]}, the card's format is "
                      f"{dtype} {shape}")  # fmt: skip


def _check_range(path: Path, array: np.ndarray, low: float, high: float, what: str) -> None:
    """Every value finite and within ``[low, high]``."""
    for block in _blocks(array):
        if block.size == 0:
            continue
        if block.dtype.kind == "f" and not np.all(np.isfinite(block)):
            _refuse(path, f"holds NaN or inf ({what} must be finite)")
        smallest, largest = block.min(), block.max()
        if smallest < low or largest > high:
            bad = smallest if smallest < low else largest
            _refuse(path, f"holds {bad}, outside {what}'s range [{low:g}, {high:g}]")


def check_buffer(
    directory: Path, columns: Mapping[str, np.ndarray], settings: Mapping[str, Any],
    workspace_ids: np.ndarray,
) -> None:  # fmt: skip
    """The sample columns of ``{split}/buffer`` against the card's settings.

    Raises:
        StoredFileError: a missing column, or a value or shape out of range (naming the file).
    """
    spec = robot_spec(settings["robot"])
    length = int(settings["max_path_length"])
    shapes = sample_shapes(spec.dim, length)
    for key, (dtype, shape) in shapes.items():
        if key not in columns:
            _refuse(directory / f"{key}.npy", "missing (a column of every sample)")
        _check_shape(directory / f"{key}.npy", columns[key], dtype, shape)
    tasks = int(max(settings["workspaces"].values()) * settings["tasks_per_workspace"])
    path = directory / "workspace_id.npy"
    for block in _blocks(columns["workspace_id"]):
        if block.size and not np.all(np.isin(block, workspace_ids)):
            missing = block[~np.isin(block, workspace_ids)][0]
            _refuse(path, f"a sample refers to workspace {missing}, which the table lacks")
    _check_range(directory / "task_id.npy", columns["task_id"], 0, max(tasks - 1, 0), "task_id")
    _check_range(directory / "step.npy", columns["step"], 0, np.iinfo(np.int64).max, "step")
    _check_range(directory / "path_length.npy", columns["path_length"], 1, length, "path_length")
    bound = 1.0 + NORMALIZED_SLACK
    for key in ("start", "goal", "path", "target"):
        _check_range(directory / f"{key}.npy", columns[key], -bound, bound, key)
    _check_range(directory / "goal_radius.npy", columns["goal_radius"], 0.0, np.inf, "goal_radius")


def check_workspaces(
    directory: Path, columns: Mapping[str, np.ndarray], settings: Mapping[str, Any]
) -> np.ndarray:
    """The workspace table against the card's settings; returns its ``workspace_id`` column.

    Raises:
        StoredFileError: a missing column, a repeated or negative id, an occupancy grid of
            another shape or with values other than 0 and 1 (naming the file).
    """
    spec = robot_spec(settings["robot"])
    grid = (int(settings["encoding_resolution"]),) * spec.workspace_dim
    for key in ("workspace_id", "occupancy"):
        if key not in columns:
            _refuse(directory / f"{key}.npy", "missing (a column of the workspace table)")
    ids = np.asarray(columns["workspace_id"])
    _check_shape(directory / "workspace_id.npy", ids, "int64", ())
    _check_shape(directory / "occupancy.npy", columns["occupancy"], "float32", grid)
    if len(np.unique(ids)) != len(ids) or (ids.size and ids.min() < 0):
        _refuse(directory / "workspace_id.npy", "repeated or negative workspace ids")
    path = directory / "occupancy.npy"
    for block in _blocks(columns["occupancy"]):
        if block.size and not np.all((block == 0.0) | (block == 1.0)):
            _refuse(path, "holds values other than 0 and 1 (an occupancy grid)")
    return ids


__all__ = ["check_buffer", "check_workspaces"]
