"""Kernels called by their address: the units of a render's call tree that
compile on their own (compile time, issue 39).

numba links a callee named in a caller's code into the caller's module and
optimises and emits the whole tree again; a caller that calls a kernel
through its address (a first-class function value made from an int64,
:func:`function_at`) compiles without it, and the callee compiles once, as
a tree of its own, whichever callers run it.  That keeps a kernel out of
scenes that never run it (a piano never compiles a sitar bridge's blocks),
and it lets a cold start compile the units of one render in several
processes at once (:mod:`synth.apps.cold_start`): each unit is a separate
entry of numba's cache.

A unit's address is looked up once per process and passed down in the
``addrs`` array (int64, :data:`N_ADDRS` entries, 0 where not loaded) that
the renderers take.  Each unit here has its signature, the types its
callers pass (every array C-contiguous, every scalar int64 unless named);
a caller that passed other types would not compile.

=========== ====================================================== ==========================
index       unit                                                   its callers' scenes
=========== ====================================================== ==========================
A_BIG       :func:`synth.kernels.render.render_coupled_big`        a sitar's bridge, shards
A_SMALL     :func:`synth.kernels.render.render_coupled_small`      a piano key's unison
A_STRING    :func:`synth.kernels.render.render_string`             a string by itself
A_PER       :func:`synth.kernels.unison._coupled_per_sample`       any coupled group per sample
A_BLOCKA    :func:`synth.kernels.render._block_a`                  a big group's blocks, first half
A_TAIL      :func:`synth.kernels.unison._coupled_tail`             a small group's chunk, far half
A_HAMMERS   :func:`synth.kernels.excite._excite_group`             hammers on a coupled group
=========== ====================================================== ==========================

May import: numba only (it is imported by the kernels that call units).
"""

from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

F1 = types.Array(types.float64, 1, "C")
F2 = types.Array(types.float64, 2, "C")
F3 = types.Array(types.float64, 3, "C")
I1 = types.Array(types.int64, 1, "C")
I2 = types.Array(types.int64, 2, "C")
INT = types.int64

#: the units, their index in ``addrs``
A_BIG, A_SMALL, A_STRING, A_PER, A_BLOCKA, A_TAIL, A_HAMMERS = 0, 1, 2, 3, 4, 5, 6
N_ADDRS = 7

#: render_coupled_big(lead, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, iw, ist,
#: po0, psub, pb, tw, ib, nt, addrs)
BIG_SIG = types.none(INT, F1, I2, F2, F2, F1, INT, INT, F2, F3, F1, I1, I1, INT, INT,
                     F3, F2, I1, INT, I1)
#: render_coupled_small(lead, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, iw, ist,
#: po0, psub, addrs)
SMALL_SIG = types.none(INT, F1, I2, F2, F2, F1, INT, INT, F2, F3, F1, I1, I1, INT, INT, I1)
#: render_string(s, ring, ipar, fpar, fst, U, n, o0, mix, probe, scratch, ubx, po0, psub)
STRING_SIG = types.none(INT, F1, I2, F2, F2, F1, INT, INT, F2, F3, F1, F1, INT, INT)
#: _coupled_per_sample(lead, G, ring, ipar, fpar, fst, U, n, o0, mix, probe, one, po0, psub)
PER_SIG = types.none(INT, INT, F1, I2, F2, F2, F1, INT, INT, F2, F3, F1, INT, INT)
#: _block_a(b, ib, G, ring, ipar, fpar, fst, U, C, cw, lock, tw, ubm, fb)
BLOCKA_SIG = types.none(INT, I1, INT, F1, I2, F2, F2, F1, INT, F1, types.boolean, F1,
                        types.float64, F1)
#: _coupled_tail(lead, G, ring, ipar, fpar, fst, U, C, o0, mix, scratch, iw, row)
TAIL_SIG = types.none(INT, INT, F1, I2, F2, F2, F1, INT, INT, F2, F1, I1, INT)
#: _excite_group(ring, ipar, fpar, fst, C, mem, G, scratch, ist)
HAMMERS_SIG = types.none(F1, I2, F2, F2, INT, I1, INT, F1, I1)

#: each unit's signature, by index
SIGS = (BIG_SIG, SMALL_SIG, STRING_SIG, PER_SIG, BLOCKA_SIG, TAIL_SIG, HAMMERS_SIG)
#: the units a unit calls (bits 1 << index): loaded with it
#: (the per-sample path, A_PER, and the hammers, A_HAMMERS, too, but only
#: where a group may take them: :func:`synth.kernels.unison.groups_need`; no
#: note takes the first, no plucked one the second)
NEEDS = (
    1 << A_BLOCKA,      # A_BIG
    1 << A_TAIL,        # A_SMALL
    0, 0, 0, 0, 0,
)


def function_at(sig):
    """An intrinsic that makes, from an int64 address, a numba first-class
    function of signature ``sig`` (its ``jit_addr``: numba's own calling
    convention, arrays as numba passes them, errors propagated)."""
    fn_type = types.FunctionType(sig)

    @intrinsic
    def at(typingctx, addr):
        def codegen(context, builder, signature, args):
            fn = cgutils.create_struct_proxy(fn_type)(context, builder)
            fn.jit_addr = builder.inttoptr(args[0], cgutils.voidptr_t)
            return fn._getvalue()
        return fn_type(types.int64), codegen
    return at


def address_of(dispatcher, sig) -> int:
    """The address of ``dispatcher`` compiled for ``sig``'s arguments
    (loaded from numba's cache, or compiled, under the key a call from
    Python with those types saves), valid for this process."""
    cres = dispatcher.get_compile_result(sig)
    return cres.library.get_pointer_to_function(cres.fndesc.llvm_func_name)


big_at = function_at(BIG_SIG)
small_at = function_at(SMALL_SIG)
string_at = function_at(STRING_SIG)
per_at = function_at(PER_SIG)
blocka_at = function_at(BLOCKA_SIG)
tail_at = function_at(TAIL_SIG)
hammers_at = function_at(HAMMERS_SIG)
