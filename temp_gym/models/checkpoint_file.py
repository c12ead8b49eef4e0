"""What a checkpoint file may be before PyTorch reads it: a regular file of bounded size.

Without PyTorch, so that the snapshot path of `temp_gym.models.registry` checks a file the same
way `temp_gym.models.temp.load_checkpoint` does.
"""

from __future__ import annotations

from pathlib import Path

from temp_gym.files import StoredFileError, read_capped
from temp_gym.limits import MAX_CHECKPOINT_BYTES


class CheckpointError(StoredFileError):
    """A file that is not a loadable TEMP checkpoint; the message names it and why."""


NOT_A_CHECKPOINT = "use a checkpoint written by trainers/bc.py or trainers/ship.py"


def read_checkpoint_bytes(path: str | Path) -> bytes:
    """A checkpoint file's bytes: at most `temp_gym.limits.MAX_CHECKPOINT_BYTES` of a regular file.

    Raises:
        CheckpointError: a device, a pipe, or a file too large (``/dev/zero`` is refused
            before a byte is read).
        OSError: the file cannot be opened.
    """
    try:
        return read_capped(path, MAX_CHECKPOINT_BYTES, "a checkpoint", NOT_A_CHECKPOINT)
    except CheckpointError:
        raise
    except StoredFileError as error:
        raise CheckpointError(error.path, error.problem, error.remedy) from None
