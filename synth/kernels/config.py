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
"""

FASTMATH = {"reassoc", "contract", "nsz", "arcp"}

JIT_OPTS = dict(nogil=True, cache=True, fastmath=FASTMATH, _nrt=False)
