"""A unit of demonstrations on disk: the solved tasks of one (split, workspace).

`temp_gym.data.generate` plans and writes units; `temp_gym.data.assemble` reads them into a
split's tables. Both take the format from here, so neither imports the other's machinery.
"""

from __future__ import annotations

import zipfile
import zlib
from pathlib import Path

import numpy as np

from temp_gym.files import StoredFileError, atomic_write

STATUS = {"ok": 0, "no_solution": 1, "no_task": 2}
"""Per-task outcome codes stored in each unit."""


def unit_path(root: Path, split: str, workspace: int) -> Path:
    """Where the unit of (split, workspace) is stored."""
    return root / split / "units" / f"{workspace:03d}.npz"


UNIT_KEYS = (
    "status", "start", "goal", "goal_radius", "bounds", "step_size", "cost", "nodes",
    "nodes_to_first_solution", "plan_time", "plan_seed", "path_offsets", "path_points",
    "unit_time",
)  # fmt: skip
"""Arrays every stored unit holds (``unit_cpu_time`` was added later and may be missing)."""

RECOMPUTE_UNIT = "delete it and rerun the same command: that unit is planned again"


def write_unit(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """Write a unit atomically (`temp_gym.files.atomic_write`): a reader sees all or none."""
    with atomic_write(path) as handle:
        np.savez(handle, **arrays)


def read_unit(path: Path) -> dict[str, np.ndarray]:
    """The arrays of a stored unit (never unpickled).

    Raises:
        StoredFileError: the file is truncated, empty or not a unit; the message names it.
    """
    try:
        with np.load(path, allow_pickle=False) as stored:
            arrays = {key: stored[key] for key in stored.files}
    except FileNotFoundError:
        raise StoredFileError(path, "missing", RECOMPUTE_UNIT) from None
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as error:
        reason = str(error) or type(error).__name__
        raise StoredFileError(path, f"damaged ({reason})", RECOMPUTE_UNIT) from None
    missing = [key for key in UNIT_KEYS if key not in arrays]
    if missing:
        raise StoredFileError(path, f"not a unit (no {', '.join(missing)})", RECOMPUTE_UNIT)
    return arrays
