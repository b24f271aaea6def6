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

``f64x2`` is the same for two lanes (an LLVM ``<2 x double>``: one xmm
register, the width of an SSE2 build's vector unit).  The functions whose
first argument is a vector of either type (:func:`vec`, :func:`splat`,
:func:`loadv`, :func:`width`) give a value of that type, so one kernel
written with them compiles to two or four lanes by the type of the vector
it is handed (:data:`synth.kernels.config.LANES`); each lane computes the
same operations in either.
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
_VT2 = ir.VectorType(ir.DoubleType(), 2)
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


class F64x2(types.Type):
    """Two float64 lanes (an LLVM ``<2 x double>``)."""

    def __init__(self):
        super().__init__(name="f64x2")


f64x2 = F64x2()


@register_model(F64x2)
class _F64x2Model(models.PrimitiveModel):
    def __init__(self, dmm, fe_type):
        super().__init__(dmm, fe_type, _VT2)


def _isvec(t):
    return isinstance(t, (F64x4, F64x2))


def _vtype(t):
    """The LLVM vector type of a lanes type."""
    return _VT if isinstance(t, F64x4) else _VT2


def _build(builder, vt, xs):
    """An LLVM vector of type ``vt`` whose lane k is xs[k]."""
    v = ir.Constant(vt, ir.Undefined)
    for k in range(vt.count):
        v = builder.insert_element(v, xs[k], ir.Constant(_I32, k))
    return v


@intrinsic
def v4(typingctx, a, b, c, d):
    """The lanes (a, b, c, d)."""
    sig = f64x4(types.float64, types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        return _build(builder, _VT, args)

    return sig, codegen


@intrinsic
def splat4(typingctx, a):
    """Four lanes of a."""
    sig = f64x4(types.float64)

    def codegen(context, builder, signature, args):
        return _build(builder, _VT, [args[0]] * 4)

    return sig, codegen


@intrinsic
def splat2(typingctx, a):
    """Two lanes of a."""
    sig = f64x2(types.float64)

    def codegen(context, builder, signature, args):
        return _build(builder, _VT2, [args[0]] * 2)

    return sig, codegen


@intrinsic
def vec(typingctx, z, a, b, c, d):
    """The lanes (a, b, c, d) as z's type: (a, b) if z is an ``f64x2``."""
    if not _isvec(z):
        return None
    sig = z(z, types.float64, types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        return _build(builder, _vtype(signature.return_type), args[1:])

    return sig, codegen


@intrinsic
def splat(typingctx, z, a):
    """All lanes of z's type a."""
    if not _isvec(z):
        return None
    sig = z(z, types.float64)

    def codegen(context, builder, signature, args):
        vt = _vtype(signature.return_type)
        return _build(builder, vt, [args[1]] * vt.count)

    return sig, codegen


@intrinsic
def width(typingctx, z):
    """The lanes of z's type (2 or 4), a constant of the compiled code."""
    if not _isvec(z):
        return None
    sig = types.intp(z)

    def codegen(context, builder, signature, args):
        return context.get_constant(types.intp, _vtype(signature.args[0]).count)

    return sig, codegen


@intrinsic
def lane(typingctx, v, k):
    """Lane k (0..3; 0..1 of an ``f64x2``, whose k is taken modulo 2) of v."""
    if not _isvec(v):
        return None
    sig = types.float64(v, types.intp)

    def codegen(context, builder, signature, args):
        k = args[1]
        n = _vtype(signature.args[0]).count
        if n < 4:
            k = builder.and_(k, ir.Constant(k.type, n - 1))
        return builder.extract_element(args[0], builder.trunc(k, _I32))

    return sig, codegen


def _contiguous(arr):
    return (isinstance(arr, types.Array) and arr.ndim == 1 and arr.layout == "C"
            and arr.dtype == types.float64)


def _array_ptr(context, builder, aty, arr, idx, vt=_VT):
    a = context.make_array(aty)(context, builder, arr)
    p = builder.gep(a.data, [idx])
    return builder.bitcast(p, vt.as_pointer())


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
def loadv(typingctx, z, arr, i):
    """arr[i:i+w] as the w lanes of z's type (arr as :func:`load4`)."""
    if not (_isvec(z) and _contiguous(arr)):
        return None
    sig = z(z, arr, types.intp)

    def codegen(context, builder, signature, args):
        p = _array_ptr(context, builder, signature.args[1], args[1], args[2],
                       _vtype(signature.return_type))
        ld = builder.load(p)
        ld.align = 8
        return ld

    return sig, codegen


@intrinsic
def store4(typingctx, arr, i, v):
    """arr[i:i+w] = the w lanes of v (an ``f64x4`` or ``f64x2``; arr as
    :func:`load4`)."""
    if not (_contiguous(arr) and _isvec(v)):
        return None
    sig = types.void(arr, types.intp, v)

    def codegen(context, builder, signature, args):
        p = _array_ptr(context, builder, signature.args[0], args[0], args[1],
                       _vtype(signature.args[2]))
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
        if not (_isvec(a) and a == b):
            return None
        sig = a(a, b)

        def codegen(context, builder, signature, args):
            return getattr(builder, name)(args[0], args[1], flags=_FLAGS)

        return sig, codegen

    return op


_add = _binop("fadd")
_sub = _binop("fsub")
_mul = _binop("fmul")


def _overload(op, impl):
    def ol(a, b):
        if _isvec(a) and a == b:
            return lambda a, b: impl(a, b)
        return None

    overload(op)(ol)


_overload(operator.add, _add)
_overload(operator.sub, _sub)
_overload(operator.mul, _mul)

__all__ = ["F64x4", "f64x4", "F64x2", "f64x2", "v4", "splat4", "splat2", "vec", "splat", "width",
           "lane", "load4", "loadv", "store4", "abs4", "max4"]
