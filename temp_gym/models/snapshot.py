"""A checkpoint's inference snapshot: the arrays a CPU policy runs on, stored beside it.

On the CPU a `TEMPPolicy` runs numba kernels (`FastMPT`, `FastEISE`) on numpy copies of the
model's weights; PyTorch is needed only to read the checkpoint. `write_snapshot` stores those
copies once in ``{stem}.kernels.npz`` beside the checkpoint, with the checkpoint file's
SHA-256, the model's sizes (`ModelInfo`) and the checkpoint's other entries (planner
settings, provenance). `read_snapshot` reads it back with ``allow_pickle=False`` and returns
None unless the stored digest is the checkpoint's, so a stale or foreign snapshot is never
used: the checkpoint stays the one source of truth. A snapshot also stores the digest of its
own arrays (`content_digest`), and its weights must be finite and of a trained model's size
(`temp_gym.limits.MAX_WEIGHT_MAGNITUDE`): a damaged one is refused with its file named. The
loaded-policy cache keys by the snapshot's bytes as well as the checkpoint's, so a snapshot
beside one copy of a checkpoint never serves another.

`temp_gym.models.registry` builds a `PolicyCore` from a snapshot when one fits, so a default
``plan(problem)`` or ``temp-plan`` imports no PyTorch at all; the PyTorch model is loaded
when something asks for it (``backend="torch"``, recorded attention, ``policy.model``).
``trainers/ship.py`` writes the snapshots of the shipped policies.

Examples:
    >>> write_snapshot("runs/.../best.pt")          # -> runs/.../best.kernels.npz
    >>> snapshot = read_snapshot("runs/.../best.pt", digest)   # None if it does not fit
"""

from __future__ import annotations

import hashlib
import io
import json
import zipfile
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from temp_gym.files import StoredFileError, atomic_write, read_capped
from temp_gym.limits import MAX_SNAPSHOT_BYTES, MAX_WEIGHT_MAGNITUDE

SNAPSHOT_FORMAT = 1
"""Bumped when the stored arrays change meaning; a snapshot of another format is ignored."""

SUFFIX = ".kernels.npz"


@dataclass(frozen=True)
class ModelInfo:
    """What a policy needs to know of its model besides the weights."""

    robot: str
    dim: int
    encoding_resolution: int
    max_path_length: int
    chunk: int
    grid_shape: tuple[int, ...]
    num_sei_tokens: int

    @classmethod
    def of(cls, model: Any) -> ModelInfo:
        """The info of a `temp_gym.models.temp.TEMPModel`."""
        return cls(
            robot=model.robot,
            dim=int(model.dim),
            encoding_resolution=int(model.encoding_resolution),
            max_path_length=int(model.max_path_length),
            chunk=int(model.mpt.chunk),
            grid_shape=tuple(int(size) for size in model.eise.grid_shape),
            num_sei_tokens=int(model.mpt.num_sei_tokens),
        )


@dataclass(frozen=True)
class Snapshot:
    """A checkpoint's inference snapshot as `read_snapshot` returns it."""

    info: ModelInfo
    mpt: dict[str, np.ndarray]
    """`temp_gym.models.fast_mpt.mpt_arrays` of the checkpoint's MPT."""
    eise: dict[str, np.ndarray]
    """`temp_gym.models.fast_eise.eise_arrays` of its EISE encoder."""
    meta: dict[str, Any]
    """The checkpoint's entries other than its weights (robot, planner, provenance)."""
    digest: str
    """SHA-256 of the checkpoint file it was made from."""


def snapshot_path(checkpoint: str | Path) -> Path:
    """Where the snapshot of ``checkpoint`` is stored: ``{stem}.kernels.npz`` beside it."""
    checkpoint = Path(checkpoint)
    return checkpoint.with_name(checkpoint.stem + SUFFIX)


def file_digest(path: str | Path) -> str:
    """SHA-256 of a file's bytes (the digest the loaded-checkpoint cache keys by)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def snapshot_bytes(checkpoint: str | Path) -> bytes | None:
    """The bytes of the snapshot file beside ``checkpoint`` (None: there is none).

    Raises:
        ValueError: it is not a regular file, or larger than `MAX_SNAPSHOT_BYTES` (named).
    """
    path = snapshot_path(checkpoint)
    try:
        return read_capped(path, MAX_SNAPSHOT_BYTES, "a snapshot", REWRITE)
    except (FileNotFoundError, NotADirectoryError):
        return None
    except StoredFileError as error:
        raise ValueError(
            f"{path}: a damaged inference snapshot ({error.problem}); {REWRITE}"
        ) from None
    except OSError as error:  # a folder, no permission: one line, with what to do
        reason = (error.strerror or type(error).__name__).lower()
        raise ValueError(
            f"{path}: an unreadable inference snapshot ({reason}); {REWRITE}"
        ) from None


def content_digest(arrays: dict[str, np.ndarray]) -> str:
    """SHA-256 of a snapshot's arrays (names, dtypes, shapes, bytes), ``content`` excluded.

    Stored in the snapshot and checked when it is read: a damaged file, or one edited without
    recomputing it, is refused, naming the file.
    """
    digest = hashlib.sha256()
    for name in sorted(arrays):
        if name == "content":
            continue
        array = np.ascontiguousarray(arrays[name])
        digest.update(f"{name}|{array.dtype.str}|{array.shape}|".encode())
        digest.update(array.tobytes())
    return digest.hexdigest()


def write_snapshot(checkpoint: str | Path, out: str | Path | None = None) -> Path:
    """Write the inference snapshot of ``checkpoint`` (default: `snapshot_path`); return it.

    Raises:
        temp_gym.models.temp.CheckpointError: ``checkpoint`` is not a usable TEMP checkpoint.
        RuntimeError: the file changed while it was read.
    """
    from temp_gym.models.fast_eise import eise_arrays
    from temp_gym.models.fast_mpt import mpt_arrays
    from temp_gym.models.temp import load_checkpoint

    digest = file_digest(checkpoint)
    model, loaded = load_checkpoint(checkpoint)
    if file_digest(checkpoint) != digest:
        raise RuntimeError(f"{checkpoint}: the file changed while it was read; write again")
    meta = {key: value for key, value in loaded.items() if key != "state_dict"}
    arrays = {f"mpt.{name}": value for name, value in mpt_arrays(model.mpt).items()}
    arrays.update((f"eise.{name}", value) for name, value in eise_arrays(model.eise).items())
    arrays["info"] = np.array(json.dumps(asdict(ModelInfo.of(model))))
    arrays["meta"] = np.array(json.dumps(meta))
    arrays["digest"] = np.array(digest)
    arrays["format"] = np.array(SNAPSHOT_FORMAT)
    arrays["content"] = np.array(content_digest(arrays))
    out = snapshot_path(checkpoint) if out is None else Path(out)
    with atomic_write(out) as handle:
        np.savez(handle, **arrays)
    return out


def read_snapshot(
    checkpoint: str | Path, digest: str, data: bytes | None = None
) -> Snapshot | None:
    """The snapshot stored beside ``checkpoint``, if it was made from a file of ``digest``.

    None when there is none, or it was made from other bytes or in another format. ``data``,
    when given, is the snapshot file's bytes already read (`snapshot_bytes`).

    Raises:
        ValueError: the snapshot file is damaged (it names the file: delete it, or write it
            again with `write_snapshot`).
    """
    path = snapshot_path(checkpoint)
    try:
        if data is None:
            data = read_capped(path, MAX_SNAPSHOT_BYTES, "a snapshot", REWRITE)
        with np.load(io.BytesIO(data), allow_pickle=False) as stored:
            if str(stored["digest"]) != digest or int(stored["format"]) != SNAPSHOT_FORMAT:
                return None
            arrays = {name: stored[name] for name in stored.files}
        _check_arrays(arrays)
        info = json.loads(str(arrays.pop("info")))
        info["grid_shape"] = tuple(info["grid_shape"])
        return Snapshot(
            info=ModelInfo(**info),
            mpt=_part(arrays, "mpt."),
            eise=_part(arrays, "eise."),
            meta=json.loads(str(arrays["meta"])),
            digest=digest,
        )
    except (FileNotFoundError, NotADirectoryError):
        return None
    except StoredFileError as error:
        raise ValueError(
            f"{path}: a damaged inference snapshot ({error.problem}); {REWRITE}"
        ) from None
    except (KeyError, TypeError, ValueError, OSError, EOFError, zipfile.BadZipFile) as error:
        first = (str(error).splitlines() or [type(error).__name__])[0][:160]
        raise ValueError(f"{path}: a damaged inference snapshot ({first}); {REWRITE}") from None


REWRITE = (
    "delete it (the checkpoint is then read with PyTorch) or write it again with "
    "temp_gym.models.snapshot.write_snapshot"
)
"""What to do about a damaged snapshot."""


def _check_arrays(arrays: dict[str, np.ndarray]) -> None:
    """Refuse arrays that do not match their stored digest, or weights no training makes.

    Raises:
        ValueError: naming the first array at fault.
    """
    stored = arrays.get("content")
    if stored is None:  # every snapshot is written with one (`write_snapshot`)
        raise ValueError("it holds no digest of its arrays")
    if str(stored) != content_digest(arrays):
        raise ValueError("its arrays do not match their stored digest")
    for name, array in arrays.items():
        if not name.startswith(("mpt.", "eise.")) or array.dtype.kind != "f":
            continue
        if not np.all(np.isfinite(array)):
            raise ValueError(f"{name} holds NaN or inf")
        if array.size and float(np.max(np.abs(array))) > MAX_WEIGHT_MAGNITUDE:
            raise ValueError(f"{name} holds weights beyond {MAX_WEIGHT_MAGNITUDE:g}")


def _part(arrays: dict[str, np.ndarray], prefix: str) -> dict[str, np.ndarray]:
    return {name[len(prefix) :]: value for name, value in arrays.items() if name.startswith(prefix)}


__all__ = [
    "ModelInfo",
    "Snapshot",
    "content_digest",
    "file_digest",
    "read_snapshot",
    "snapshot_bytes",
    "snapshot_path",
    "write_snapshot",
]
