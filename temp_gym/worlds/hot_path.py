"""`hot_path`: how compiled helpers on a checker's hot path are compiled.

numba counts references to arrays. A compiled function that takes several arrays and calls
another, or is inlined into a caller (``inline="always"``), pays atomic reference-count
updates for each array on every call, even when the branch with the inner call is never
taken: with a dozen arrays that is a few hundred nanoseconds per state, more than the forward
kinematics. Helpers compiled without numba's runtime (``_nrt=False``) do no reference counting
at all, and LLVM still inlines the small ones.

Such a helper may only read and write the arrays it is given: it cannot allocate, slice into
a new array or return one. The kernels that allocate (their outputs, scratch space) stay
ordinary ``numba.njit`` functions and call these.
"""

from __future__ import annotations

import numba

hot_path = numba.njit(cache=True, nogil=True, _nrt=False)
"""Decorator: compile a non-allocating helper without reference counting (module docstring)."""

hot_inline = numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
"""`hot_path`, inlined into its callers by numba: for helpers that take many arrays (LLVM
does not inline large functions, and passing a dozen arrays costs more than a short test).
On a hot path, call these only from `hot_path` functions: inlined into a reference-counting
caller, their arrays are counted again (acceptable in a one-off call, such as naming the
colliding pairs of one state)."""

__all__ = ["hot_inline", "hot_path"]
