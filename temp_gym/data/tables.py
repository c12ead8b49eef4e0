"""Dataset tables on disk: one ``.npy`` file per column, read back without pickle.

A table is a directory with one ``{column}.npy`` per key (rows along the first axis). It is
written with `numpy.lib.format.open_memmap` (filled unit by unit, so a paper-scale buffer is
never held in memory) and read with ``np.load(..., allow_pickle=False, mmap_mode="c")``: no
file of a dataset is ever unpickled, and a copy-on-write map never writes back to the file.

Every file of every table is listed in the dataset card with its size and SHA-256
(`file_manifest`); `verify_table` checks a table against that list before it is read, so a
truncated, replaced, damaged or planted file stops the load with an error naming it.
torchrl's ``ReplayBuffer.loads`` and tensordict's ``load_memmap`` are not used: both may
unpickle files found in the directory.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from temp_gym.files import StoredFileError

SUFFIX = ".npy"
_CHUNK = 1 << 20

REBUILD = (
    "rerun trainers/generate.py with the same config and data.dir: it rebuilds damaged "
    "tables from the planned units"
)
"""What to do about a damaged table file (the units it is built from are kept)."""


def create_table(directory: Path, columns: Mapping[str, tuple[np.dtype, tuple[int, ...]]]):
    """Create one writable memory-mapped ``.npy`` per column; return ``{column: array}``.

    ``columns`` maps a name to ``(dtype, shape)``; fill the arrays, then call `close_table`.
    """
    directory.mkdir(parents=True, exist_ok=True)
    return {
        name: np.lib.format.open_memmap(
            directory / f"{name}{SUFFIX}", mode="w+", dtype=dtype, shape=shape
        )
        for name, (dtype, shape) in columns.items()
    }


def close_table(directory: Path, arrays: Mapping[str, np.ndarray]) -> None:
    """Flush the arrays of `create_table` and fsync their files."""
    for name, array in arrays.items():
        if isinstance(array, np.memmap):
            array.flush()
        descriptor = os.open(directory / f"{name}{SUFFIX}", os.O_RDONLY)
        try:
            os.fsync(descriptor)
        finally:
            os.close(descriptor)


def write_table(directory: Path, columns: Mapping[str, np.ndarray]) -> None:
    """Write whole columns at once (small tables)."""
    arrays = create_table(
        directory, {name: (value.dtype, value.shape) for name, value in columns.items()}
    )
    for name, value in columns.items():
        arrays[name][...] = value
    close_table(directory, arrays)


def file_digest(path: Path) -> dict[str, Any]:
    """``{"bytes": size, "sha256": hex digest}`` of one file."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        while chunk := handle.read(_CHUNK):
            digest.update(chunk)
    return {"bytes": path.stat().st_size, "sha256": digest.hexdigest()}


def file_manifest(root: Path, directories: list[Path]) -> dict[str, dict[str, Any]]:
    """Size and SHA-256 of every file under ``directories``, keyed by path relative to root."""
    manifest = {}
    for directory in directories:
        for path in sorted(p for p in directory.rglob("*") if p.is_file()):
            manifest[path.relative_to(root).as_posix()] = file_digest(path)
    return manifest


def checked_manifest(card_path: Path, card: object, remedy: str) -> dict[str, dict[str, Any]]:
    """The ``files`` list of a card (`file_manifest`'s form), or a `StoredFileError` naming it.

    A card edited by hand, truncated to another JSON value or written by something else must
    stop the load with the card's name, not a ``KeyError`` deep in the reader: every entry
    needs a non-negative integer ``bytes`` and a 64-character ``sha256``.
    """
    files = card.get("files") if isinstance(card, dict) else None
    if not isinstance(files, dict):
        raise StoredFileError(card_path, "damaged (no 'files' list of its tables)", remedy)
    for name, entry in files.items():
        if not (
            isinstance(entry, dict)
            and isinstance(entry.get("bytes"), int)
            and not isinstance(entry.get("bytes"), bool)
            and entry["bytes"] >= 0
            and isinstance(entry.get("sha256"), str)
            and len(entry["sha256"]) == 64
        ):
            raise StoredFileError(
                card_path,
                f"damaged (its entry for {name!r} needs an integer 'bytes' and a 'sha256')",
                remedy,
            )
    return files


def verify_table(root: Path, table: str, manifest: Mapping[str, Mapping[str, Any]]) -> None:
    """Check the files of ``root/table`` against the card's manifest, or raise naming one.

    Raises:
        StoredFileError: a listed file is missing, has another size or checksum, or a file
            the card does not list is present.
    """
    prefix = f"{table}/"
    listed = {name: entry for name, entry in manifest.items() if name.startswith(prefix)}
    directory = root / table
    if not directory.is_dir():
        raise StoredFileError(directory, "missing", REBUILD)
    for path in sorted(p for p in directory.rglob("*") if p.is_file()):
        if path.relative_to(root).as_posix() not in listed:
            raise StoredFileError(
                path,
                "not a file of this dataset (the dataset card does not list it)",
                "delete it; a dataset is read only from the files its card lists",
            )
    for name, entry in sorted(listed.items()):
        path = root / name
        if not path.is_file():
            raise StoredFileError(path, "missing", REBUILD)
        size = path.stat().st_size
        if size != entry["bytes"]:
            raise StoredFileError(
                path, f"{size} bytes where the dataset card says {entry['bytes']}", REBUILD
            )
        if file_digest(path)["sha256"] != entry["sha256"]:
            raise StoredFileError(path, "its SHA-256 differs from the dataset card's", REBUILD)


def read_table(directory: Path, rows: int | None = None) -> dict[str, np.ndarray]:
    """Every column of a (verified) table, memory-mapped copy-on-write, never unpickled.

    Raises:
        StoredFileError: a column is not a plain ``.npy`` array, or its row count differs
            from ``rows`` (when given) or from the other columns'.
    """
    columns = {}
    for path in sorted(directory.glob(f"*{SUFFIX}")):
        try:
            array = np.load(path, mmap_mode="c", allow_pickle=False)
        except (ValueError, OSError, EOFError) as error:
            raise StoredFileError(path, f"not a readable array ({error})", REBUILD) from None
        if array.ndim == 0 or array.dtype.hasobject:
            raise StoredFileError(path, "not a column of plain numbers", REBUILD)
        columns[path.name.removesuffix(SUFFIX)] = array
    counts = {len(array) for array in columns.values()}
    if rows is not None:
        counts.add(rows)
    if len(counts) > 1:
        raise StoredFileError(directory, f"columns of different lengths {sorted(counts)}", REBUILD)
    return columns
