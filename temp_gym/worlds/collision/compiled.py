"""Motion validity callable from compiled code: what lets a numba planner loop use a checker.

A planner loop written in numba cannot call a checker's Python methods without a round trip
through the interpreter per edge. A checker that also offers a compiled path has a method
``compiled_context()`` returning a tuple of arrays (its boxes, bounds, robot model, scratch
space), and registers, once, a numba kernel ``kernel(context, start, end) -> bool`` for the
numba type of that tuple (`register_motion_kernel`). Compiled code then calls

    motion_free(context, start, end)

and numba picks the kernel registered for ``context``'s type when it compiles the caller.
Dispatch is by type at compile time, so it costs nothing at run time, and the callers stay
cacheable (`numba.njit(cache=True)`), which passing kernels as arguments would prevent.

Kernels keep the checker's contract: ``True`` means the straight motion ``start -> end``
(float64 ``(d,)`` arrays), endpoints included, is free and within the bounds. A checker
without a compiled path returns None from ``compiled_context()`` (or lacks the method); the
planners then drive it from Python (`compiled_context_of`).
"""

from __future__ import annotations

from collections.abc import Callable

import numba
import numpy as np
from numba.core import types
from numba.extending import overload

_KERNELS: dict[types.Type, Callable] = {}
_REGISTERED: set[tuple] = set()
"""``(kernel, _layout(context))`` pairs already registered: ``numba.typeof`` of a tuple of
arrays costs tens of microseconds, paid again by every checker a planner builds otherwise."""


def _layout(value: object) -> tuple | type | None:
    """What numba's type of ``value`` depends on, cheaply; None when unsure (then not cached)."""
    if isinstance(value, np.ndarray):
        flags = value.flags
        return (value.dtype.str, value.ndim, flags.c_contiguous, flags.f_contiguous,
                flags.writeable, flags.aligned)  # fmt: skip
    if isinstance(value, tuple):
        parts = tuple(_layout(item) for item in value)
        return None if any(part is None for part in parts) else parts
    if type(value) in (bool, int, float):
        return type(value)
    return None


def register_motion_kernel(context: tuple, kernel: Callable) -> None:
    """Register ``kernel`` (a numba function) for contexts of ``context``'s numba type.

    Raises:
        ValueError: another kernel is already registered for that type (two checkers whose
            contexts have the same array signature: give one a distinguishing element).
    """
    layout = _layout(context)
    if layout is not None and (kernel, layout) in _REGISTERED:
        return
    key = numba.typeof(context)
    known = _KERNELS.get(key)
    if known is not None and known is not kernel:
        raise ValueError(f"compiled context {key}: already served by {known}")
    _KERNELS[key] = kernel
    if layout is not None:
        _REGISTERED.add((kernel, layout))


def compiled_context_of(checker: object) -> tuple | None:
    """The checker's compiled context, or None when it has no compiled path."""
    method = getattr(checker, "compiled_context", None)
    return None if method is None else method()


def motion_free(context: tuple, start, end) -> bool:
    """Whether the motion ``start -> end`` is free, by the kernel registered for ``context``.

    Only callable from numba-compiled code; Python code calls the checker's ``edge_free``.
    """
    raise TypeError("motion_free is only callable from numba-compiled code")


@overload(motion_free, jit_options={"cache": True, "nogil": True})
def _motion_free_overload(context, start, end):
    kernel = _KERNELS.get(context)
    if kernel is None:
        raise numba.core.errors.TypingError(f"no motion kernel registered for {context}")

    def implementation(context, start, end):
        return kernel(context, start, end)

    return implementation


__all__ = ["compiled_context_of", "motion_free", "register_motion_kernel"]
