"""A numpy Generator handed to compiled code by its address instead of as an object.

numba unboxes a ``np.random.Generator`` argument on every call of a compiled function: it
reads the bit generator's ctypes interface (which numpy builds on first use, per generator)
and casts three function pointers through ``ctypes.cast``. That is several microseconds per
generator per call, paid once per slice of the compiled loops: on small problems a visible
share of a whole ``plan`` call, twice over for TEMP (the planner's generator and the policy's
noise generator).

So the loops take `address` (an int) and rebuild numba's Generator inside with `generator_at`.
The address is that of numpy's ``bitgen_t`` (numpy's C API, ``numpy/random/bitgen.h``: the
state pointer, then the ``next_uint64``, ``next_uint32`` and ``next_double`` function
pointers), read from the bit generator's capsule. The rebuilt Generator points at the same
state and the same functions that numba's own unboxing reads, so it draws the same numbers
and leaves the state where numba's own unboxing would (tested).

The Generator must stay alive while the compiled call runs: callers hold it in a variable.
"""

from __future__ import annotations

import ctypes

import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

_CAPSULE_NAME = b"BitGenerator"
_capsule_pointer = ctypes.PYFUNCTYPE(ctypes.c_void_p, ctypes.py_object, ctypes.c_char_p)(
    ("PyCapsule_GetPointer", ctypes.pythonapi)
)
_BIT_GENERATOR_TYPE = types.NumPyRandomBitGeneratorType("bit_generator")
_FIELDS = ("state", "fnptr_next_uint64", "fnptr_next_uint32", "fnptr_next_double")
"""numba's names for the first four words of ``bitgen_t``, in their order there."""


def address(rng: np.random.Generator) -> int:
    """The address of ``rng``'s ``bitgen_t``, for `generator_at` in compiled code."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng: expected a numpy.random.Generator, got {type(rng).__name__}")
    return _capsule_pointer(rng.bit_generator.capsule, _CAPSULE_NAME)


@intrinsic
def generator_at(typingctx, bitgen_address):
    """A numba Generator over the ``bitgen_t`` at ``bitgen_address`` (from `address`)."""
    if not isinstance(bitgen_address, types.Integer):
        return None
    signature = types.npy_rng(bitgen_address)

    def codegen(context, builder, sig, args):
        word = context.get_value_type(types.uintp)
        raw = context.cast(builder, args[0], sig.args[0], types.uintp)
        base = builder.inttoptr(raw, word.as_pointer())
        bit_generator = cgutils.create_struct_proxy(_BIT_GENERATOR_TYPE)(context, builder)
        bit_generator.parent = cgutils.get_null_value(bit_generator.parent.type)
        for index, name in enumerate(_FIELDS):
            value = builder.load(builder.gep(base, [ir.Constant(ir.IntType(32), index)]))
            setattr(bit_generator, name, value)
        bit_generator.state_address = bit_generator.state
        bit_generator.bit_generator = raw
        generator = cgutils.create_struct_proxy(sig.return_type)(context, builder)
        generator.bit_generator = bit_generator._getvalue()
        generator.meminfo = cgutils.get_null_value(generator.meminfo.type)
        generator.parent = cgutils.get_null_value(generator.parent.type)
        return generator._getvalue()

    return signature, codegen


__all__ = ["address", "generator_at"]
