"""Compilation flags shared by every numba kernel (the one place they are set).

``FASTMATH`` is an explicit flag set rather than ``fastmath=True``: it allows
re-association (so reductions vectorise), contraction into FMA, ignoring the
sign of zero and reciprocal approximations, but keeps ``nnan``/``ninf`` off so
NaN and infinity checks (and +-inf profile values meaning "no contact") keep
their meaning.

``_nrt=False`` compiles the kernels without numba's reference-counted
runtime.  The kernels never allocate (arrays in, write into ``out``), so
they do not need it, and with it every slice view taken inside a kernel
cost an atomic increment and decrement of the array's reference count (a
call each): about 70 ns per pass of the termination region, which halved
the speed of 200-sample chunks.  A kernel that tried to allocate now fails
to compile, which enforces the rule.

``SERIAL_OPTS`` drops re-association for the kernels whose loops are
recurrences written in the order that keeps the loop-carried path short:
a first-order allpass y = c x + x1 - c y1 has one multiply-add on its
recurrence (4 cycles a sample), but re-associated to c (x - y1) + x1 (which
LLVM does when it may) it has a subtraction and a multiply-add, and such a
loop ran at 2.1 instead of 1.1 ns a sample (AVX2 build, Zen 5 host).
Contraction into FMA stays allowed.  The pitch-bend line
(``bend._bend_line`` and ``bend._bend_chunk``) uses it too: while a
tune-out decays, both compute each sample's delay and taps with the same
operations, and re-association let LLVM rewrite the chunk loop's (strength
reduction of ``tog * to`` along the loop), so that a render's last bits
depended on where its blocks began (2e-14 of full scale on the sitar;
``tests/test_live.py`` asks for the same samples exactly).

``error_model="numpy"``: a float division by zero gives inf or NaN instead
of raising ZeroDivisionError, so numba emits no test and exception path
per division (the kernels never raise; their callers validate inputs).
"""

FASTMATH = {"reassoc", "contract", "nsz", "arcp"}
FASTMATH_SERIAL = {"contract", "nsz", "arcp"}

JIT_OPTS = dict(nogil=True, cache=True, fastmath=FASTMATH, _nrt=False, error_model="numpy")
SERIAL_OPTS = dict(nogil=True, cache=True, fastmath=FASTMATH_SERIAL, _nrt=False,
                   error_model="numpy")
#: IEEE arithmetic, as Python computes it: the kernels that do what a
#: Python method did, to the bit (no re-association, no contraction of a
#: product into a sum: ``u - dt V`` rounds the product first, as Python does)
EXACT_OPTS = dict(nogil=True, cache=True, _nrt=False, error_model="numpy")
#: the few kernels whose loops run on several threads (``prange``:
#: :mod:`synth.kernels.render` only); numba's threading layer is chosen by
#: :func:`prefer_openmp`
PAR_OPTS = dict(JIT_OPTS, parallel=True)


def prefer_openmp() -> None:
    """Ask numba for its OpenMP threading layer first (then TBB, then its
    own workqueue), unless ``NUMBA_THREADING_LAYER`` or
    ``NUMBA_THREADING_LAYER_PRIORITY`` is set.  Measured on a 2-core Xeon
    (numba 0.68): a ``prange`` over two tasks costs 1.8 us with OpenMP,
    whose threads spin a while between loops, and 130 us with the
    workqueue, which wakes its threads each time (the workqueue also aborts
    when two threads launch loops at once).  numba's default order tries
    TBB first, which needs the ``tbb`` package; without it the order is the
    same.  :mod:`synth.dsp.threads` refuses the workqueue for more than one
    thread."""
    import os

    if "NUMBA_THREADING_LAYER" in os.environ or "NUMBA_THREADING_LAYER_PRIORITY" in os.environ:
        return
    from numba.core import config as nbconfig

    nbconfig.THREADING_LAYER_PRIORITY = ["omp", "tbb", "workqueue"]


prefer_openmp()


def _target_features() -> list[str] | None:
    """numba's target features as it reads them (``NUMBA_CPU_FEATURES`` if
    set, else the host's; an empty string, as ``NUMBA_CPU_NAME=generic``
    gives, is no feature), or None if they cannot be read."""
    try:
        from numba.core import config as nbconfig
        from numba.core.codegen import get_host_cpu_features

        feats = nbconfig.CPU_FEATURES
        if feats is None:
            feats = get_host_cpu_features()
    except Exception:  # pragma: no cover - numba without these names
        return None
    return str(feats).split(",")


def _vector_registers() -> int:
    """Vector registers of numba's code target: 32 with AVX-512 (zmm0-31,
    and ymm/xmm16-31 usable by AVX-512VL code), else 16.  Read as numba
    reads its target (``NUMBA_CPU_FEATURES`` if set, else the host's
    features; an empty feature string, as ``NUMBA_CPU_NAME=generic`` gives,
    counts 16).  The kernels that differ by it compute the same operations
    in the same order either way; only how they split a loop differs."""
    feats = _target_features()
    if feats is None:  # pragma: no cover
        return 16
    return 32 if "+avx512f" in feats else 16


#: vector registers of the code target (see :func:`_vector_registers`)
VECTOR_REGS = _vector_registers()


def _lanes() -> int:
    """Lanes of the lockstep filters (:mod:`synth.kernels.lanes`): four (a
    ymm or zmm register) if numba's target has AVX, else two: an SSE2
    build's xmm register holds two, a ``<4 x double>`` took two registers
    and two instructions an operation, so a group of one or two strings
    paid for four lanes and a four-lane loop for twice the registers (its
    states on the stack).  Two lanes compute the same operations in each
    lane as four (the same samples)."""
    feats = _target_features()
    return 4 if feats is not None and "+avx" in feats else 2


#: lanes of the lockstep filters of the code target (see :func:`_lanes`)
LANES = _lanes()
