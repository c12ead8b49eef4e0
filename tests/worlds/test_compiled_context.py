import numba
import numpy as np
import pytest

from temp_gym.worlds.collision import compiled
from temp_gym.worlds.collision.point import PointBoxChecker


@numba.njit
def _always_free(context, start, end):
    return True


def test_a_context_layout_is_typed_once_per_kernel(monkeypatch):
    typed = []
    typeof = numba.typeof
    monkeypatch.setattr(compiled.numba, "typeof", lambda value: typed.append(1) or typeof(value))
    # a layout no real checker has: bool arrays and an int
    context = (np.zeros(3, dtype=np.bool_), np.zeros((2, 2), dtype=np.bool_), 7)
    compiled.register_motion_kernel(context, _always_free)
    assert len(typed) == 1
    same_layout = (np.ones(5, dtype=np.bool_), np.ones((4, 3), dtype=np.bool_), 9)
    compiled.register_motion_kernel(same_layout, _always_free)
    assert len(typed) == 1  # remembered
    fortran = (np.zeros(3, dtype=np.bool_), np.asfortranarray(np.zeros((2, 3), np.bool_)), 7)
    compiled.register_motion_kernel(fortran, _always_free)
    assert len(typed) == 2  # another numba type: typed and registered on its own
    assert compiled._KERNELS[typeof(fortran)] is _always_free


def test_another_kernel_for_a_taken_type_is_still_refused():
    checker = PointBoxChecker(
        np.array([[0.0, 0.0], [1.0, 1.0]]), np.zeros((0, 2)), np.zeros((0, 2))
    )
    context = checker.compiled_context()
    with pytest.raises(ValueError, match="already served"):
        compiled.register_motion_kernel(context, _always_free)
