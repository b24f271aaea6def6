"""Compilation flags shared by every numba kernel (the one place they are set).

``FASTMATH`` is an explicit flag set rather than ``fastmath=True``: it allows
re-association (so reductions vectorise), contraction into FMA, ignoring the
sign of zero and reciprocal approximations, but keeps ``nnan``/``ninf`` off so
NaN and infinity checks (and +-inf profile values meaning "no contact") keep
their meaning.
"""

FASTMATH = {"reassoc", "contract", "nsz", "arcp"}

JIT_OPTS = dict(nogil=True, cache=True, fastmath=FASTMATH)
