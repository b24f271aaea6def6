"""The ring's windows: contiguous copies of a string's ring slots (numba).

A string's ring (:mod:`synth.kernels.strings`) is read and written by the
fast path's steps a window at a time: :func:`_ring_get` copies the slots
j, j+1, ... (mod P) to contiguous scratch (times +-1), :func:`_ring_put`
writes them back and :func:`_ring_add` adds to them, each as two loops
split at the ring's wrap; :func:`_ring_get_in` and :func:`_ring_put_in`
are the same inlined into their caller.  Also :func:`_hmax4`, the running
maximum over a vector's lanes, which the far end's force output and the
region's reach test share.

May import: :mod:`~synth.kernels.config` and :mod:`~synth.kernels.lanes`
(every step module of the string kernels imports this one).
"""

from __future__ import annotations

from numba import njit

from .config import JIT_OPTS, SERIAL_OPTS
from .lanes import lane


@njit(inline="always", **JIT_OPTS)
def _ring_get_in(ring, off, P, j, dst, sc):
    """dst = sc * the ring slots j, j+1, ... (mod P); 0 <= j < P,
    len(dst) <= P; ``sc`` is +-1 (exact).  Two contiguous loops split at
    the wrap (no wrap test per element), over slice views with the bare
    loop index: an index such as d0 + a, whose sign numba cannot know, gets
    a negative-index fix-up per element that stops the loop vectorising.
    (The ring helpers take no constant arguments: numba compiles a separate
    copy of a function for every literal constant passed to it.)

    Inlined into its caller (``inline="always"``): the per-chunk callers
    of the fast path take it so (a call passes each array as its fields,
    and a slice argument costs as much again); :func:`_ring_get` is the
    same as a function.  One multiply by
    +-1 per element: the caller's fast-math flags cannot change it."""
    n = dst.shape[0]
    n1 = P - j
    if n1 > n:
        n1 = n
    r = ring[off + j:off + j + n1]
    d = dst[0:n1]
    for a in range(n1):
        d[a] = sc * r[a]
    r = ring[off:off + n - n1]
    d = dst[n1:n]
    for a in range(n - n1):
        d[a] = sc * r[a]


@njit(**JIT_OPTS)
def _ring_get(ring, off, P, j, dst, sc):
    """:func:`_ring_get_in` as a function (for the callers outside the
    per-chunk fast path, and the serial ones)."""
    _ring_get_in(ring, off, P, j, dst, sc)


@njit(inline="always", **JIT_OPTS)
def _ring_put_in(ring, off, P, j, src, sc):
    """The ring slots j, j+1, ... (mod P) = sc * src (see
    :func:`_ring_get_in`; inlined)."""
    n = src.shape[0]
    n1 = P - j
    if n1 > n:
        n1 = n
    r = ring[off + j:off + j + n1]
    d = src[0:n1]
    for a in range(n1):
        r[a] = sc * d[a]
    r = ring[off:off + n - n1]
    d = src[n1:n]
    for a in range(n - n1):
        r[a] = sc * d[a]


@njit(**JIT_OPTS)
def _ring_put(ring, off, P, j, src, sc):
    """:func:`_ring_put_in` as a function."""
    _ring_put_in(ring, off, P, j, src, sc)


@njit(**JIT_OPTS)
def _ring_add(ring, off, P, j, src, sc):
    """The ring slots j, j+1, ... (mod P) += sc * src (see :func:`_ring_get`)."""
    n = src.shape[0]
    n1 = P - j
    if n1 > n:
        n1 = n
    r = ring[off + j:off + j + n1]
    d = src[0:n1]
    for a in range(n1):
        r[a] += sc * d[a]
    r = ring[off:off + n - n1]
    d = src[n1:n]
    for a in range(n - n1):
        r[a] += sc * d[a]


@njit(inline="always", **SERIAL_OPTS)
def _hmax4(v, peak):
    """The running maximum ``a if a > peak else peak`` over the lanes of v
    (comparisons only: inlined, the caller's fast-math flags change
    nothing)."""
    for k in range(4):
        a = lane(v, k)
        peak = a if a > peak else peak
    return peak
