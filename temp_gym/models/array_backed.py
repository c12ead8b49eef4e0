"""`ArrayBacked`: the base of the numba inference objects, which run on named numpy arrays.

`temp_gym.models.fast_mpt.FastMPT` and `temp_gym.models.fast_eise.FastEISE` copy a model's
weights into arrays once; a stored snapshot of those arrays (`temp_gym.models.snapshot`)
builds them again without PyTorch.
"""

from __future__ import annotations

import numpy as np


class ArrayBacked:
    """Base of the numba inference objects (`FastMPT`, `FastEISE`): they run on named arrays.

    A subclass names the arrays it reads (``NAMES``) and sets itself up from them in
    ``_load``; `from_arrays` builds one from a stored snapshot, `arrays` returns what it runs on.
    """

    NAMES: tuple[str, ...] = ()
    KIND = "snapshot"

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]):
        """One on a snapshot's arrays (read-only use of them), without PyTorch.

        Raises:
            ValueError: when an array is missing or the shapes do not fit one another.
        """
        made = cls.__new__(cls)
        made._set(arrays)
        return made

    def arrays(self) -> dict[str, np.ndarray]:
        """The named arrays this runs on (do not modify them)."""
        return dict(self._arrays)

    def _set(self, arrays: dict[str, np.ndarray]) -> None:
        missing = [name for name in self.NAMES if name not in arrays]
        if missing:
            raise ValueError(f"{self.KIND}: missing arrays {missing}")
        self._arrays = {name: arrays[name] for name in self.NAMES}
        self._load(self._arrays)

    def _load(self, arrays: dict[str, np.ndarray]) -> None:
        raise NotImplementedError


__all__ = ["ArrayBacked"]
