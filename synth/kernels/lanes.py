"""Four float64 lanes for the numba kernels: several strings' recurrences in lockstep.

A string's loop filter (loss, allpass sections, biquads) is a chain of
recurrences: each sample waits on the one before, so one string's filter
runs on scalar instructions whatever the CPU.  The strings of a piano key
(a coupled group) are filtered over the same chunk; with their states as
the lanes of one vector, every instruction advances up to four strings.
numba exposes no vector type and does not run LLVM's SLP vectoriser
(``NUMBA_SLP_VECTORIZE`` is off by default), so this module gives the
kernels one: ``f64x4``, an LLVM ``<4 x double>`` value, with the
constructor :func:`v4`, :func:`splat4`, :func:`lane`, the operators
``+ - *`` and :func:`load4` / :func:`store4` (four consecutive samples of a
1-D array).  Values of it live in registers (vector phis across a loop),
never in memory unless LLVM spills them.

The arithmetic carries the fast-math flags of the serial kernels
(:data:`synth.kernels.config.FASTMATH_SERIAL`: contraction into FMA, no
re-association), so a lane written as the scalar code is written computes
the same operations in the same order: the same samples, bit for bit
(``tests/test_strings.py`` compares them).  An AVX2 or AVX-512 build
holds a vector in one ymm register; a plain x86-64 (SSE2) build in two xmm
registers (two instructions per operation, still half of four scalar
ones).  Only the AVX-512 build could hold eight lanes; four keep the
AVX2 and SSE2 builds the same code.
"""

from __future__ import annotations

import operator

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, models, overload, register_model

from .config import FASTMATH_SERIAL

#: LLVM fast-math flags of the lanes' arithmetic (those of the serial kernels)
_FLAGS = tuple(sorted(FASTMATH_SERIAL))
_VT = ir.VectorType(ir.DoubleType(), 4)
_I32 = ir.IntType(32)


class F64x4(types.Type):
    """Four float64 lanes (an LLVM ``<4 x double>``)."""

    def __init__(self):
        super().__init__(name="f64x4")


f64x4 = F64x4()


@register_model(F64x4)
class _F64x4Model(models.PrimitiveModel):
    def __init__(self, dmm, fe_type):
        super().__init__(dmm, fe_type, _VT)


@intrinsic
def v4(typingctx, a, b, c, d):
    """The lanes (a, b, c, d)."""
    sig = f64x4(types.float64, types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        v = ir.Constant(_VT, ir.Undefined)
        for k, x in enumerate(args):
            v = builder.insert_element(v, x, ir.Constant(_I32, k))
        return v

    return sig, codegen


@intrinsic
def splat4(typingctx, a):
    """Four lanes of a."""
    sig = f64x4(types.float64)

    def codegen(context, builder, signature, args):
        v = ir.Constant(_VT, ir.Undefined)
        for k in range(4):
            v = builder.insert_element(v, args[0], ir.Constant(_I32, k))
        return v

    return sig, codegen


@intrinsic
def lane(typingctx, v, k):
    """Lane k (0..3) of v."""
    sig = types.float64(f64x4, types.intp)

    def codegen(context, builder, signature, args):
        return builder.extract_element(args[0], builder.trunc(args[1], _I32))

    return sig, codegen


def _contiguous(arr):
    return (isinstance(arr, types.Array) and arr.ndim == 1 and arr.layout == "C"
            and arr.dtype == types.float64)


def _array_ptr(context, builder, aty, arr, idx):
    a = context.make_array(aty)(context, builder, arr)
    p = builder.gep(a.data, [idx])
    return builder.bitcast(p, _VT.as_pointer())


@intrinsic
def load4(typingctx, arr, i):
    """arr[i:i+4] as four lanes (arr: a contiguous 1-D float64 array; no
    bounds check: the caller's)."""
    if not _contiguous(arr):
        return None
    sig = f64x4(arr, types.intp)

    def codegen(context, builder, signature, args):
        p = _array_ptr(context, builder, signature.args[0], args[0], args[1])
        ld = builder.load(p)
        ld.align = 8
        return ld

    return sig, codegen


@intrinsic
def store4(typingctx, arr, i, v):
    """arr[i:i+4] = the lanes of v (arr as :func:`load4`)."""
    if not _contiguous(arr):
        return None
    sig = types.void(arr, types.intp, f64x4)

    def codegen(context, builder, signature, args):
        p = _array_ptr(context, builder, signature.args[0], args[0], args[1])
        st = builder.store(args[2], p)
        st.align = 8
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def abs4(typingctx, v):
    """|v| lane by lane."""
    sig = f64x4(f64x4)

    def codegen(context, builder, signature, args):
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(_VT, [_VT]),
                                            "llvm.fabs.v4f64")
        return builder.call(fn, [args[0]])

    return sig, codegen


@intrinsic
def max4(typingctx, p, a):
    """Lane by lane ``a if a > p else p``: the scalar kernels' running
    maximum (a NaN in ``a`` never wins), so four running maxima over the
    lanes, combined by :func:`hmax4`, give the scalar loop's value."""
    sig = f64x4(f64x4, f64x4)

    def codegen(context, builder, signature, args):
        gt = builder.fcmp_ordered(">", args[1], args[0])
        return builder.select(gt, args[1], args[0])

    return sig, codegen


def _binop(name):
    @intrinsic
    def op(typingctx, a, b):
        sig = f64x4(f64x4, f64x4)

        def codegen(context, builder, signature, args):
            return getattr(builder, name)(args[0], args[1], flags=_FLAGS)

        return sig, codegen

    return op


_add = _binop("fadd")
_sub = _binop("fsub")
_mul = _binop("fmul")


def _overload(op, impl):
    def ol(a, b):
        if isinstance(a, F64x4) and isinstance(b, F64x4):
            return lambda a, b: impl(a, b)
        return None

    overload(op)(ol)


_overload(operator.add, _add)
_overload(operator.sub, _sub)
_overload(operator.mul, _mul)

__all__ = ["F64x4", "f64x4", "v4", "splat4", "lane", "load4", "store4", "abs4", "max4"]
