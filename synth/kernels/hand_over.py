"""A string's loop handed over from a finer grid to a coarser one (numba).

:func:`hand_over_loop` resamples one string's ring onto the coarser grid
and fits the coarser loop filter's state, by least squares, to the outputs
the finer filter would have gone on with (:func:`far_end_run`).
:meth:`synth.dsp.bank.StringBank.hand_over` calls it per string; its
scratch is :func:`synth.dsp.sizing.hand_over_buffer_length` samples.

May import: :mod:`~synth.kernels.config`, :mod:`~synth.kernels.layout`,
:mod:`~synth.kernels.ring`, :mod:`~synth.kernels.far_end`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .config import SERIAL_OPTS
from .far_end import far_end_run
from .ring import _ring_get, _ring_put


@njit(inline="always", **SERIAL_OPTS)
def _lerp(a, n, f):
    """a[0:n] linearly interpolated at the (fractional) index f, clamped."""
    i = int(np.floor(f))
    if i < 0:
        return a[0]
    if i >= n - 1:
        return a[n - 1]
    w = f - i
    return a[i] + w * (a[i + 1] - a[i])


@njit(inline="always", **SERIAL_OPTS)
def _dot(a, b, n):
    """sum of a[k] b[k], k < n, in order."""
    s = 0.0
    for k in range(n):
        s += a[k] * b[k]
    return s


@njit(**SERIAL_OPTS)
def hand_over_loop(ring, off, Nf, pm, st_f, fp_f, xdel_f, nd_f, nb_f, r, Nc, pmc,
                   st_c, fp_c, xdel_c, nd_c, nb_c, T, m, H, ub, buf, At, R, one):
    """One string's loop from a finer grid (``Nf`` cells, position ``pm``,
    its ``fst`` and ``fpar`` rows ``st_f``, ``fp_f``) to one ``r`` times
    coarser (``Nc`` cells, position ``pmc``, rows ``st_c``, ``fp_c``), in
    the ring at ``off`` (the finer ring's 2 Nf slots are cleared, the
    coarser's 2 Nc written).

    The ring holds the waves that will arrive at the far end, in order;
    the coarser ring's arrival k is the finer one's r k + delta + (r - 1)
    / 2 (linear interpolation; delta = Nf - r Nc keeps the termination's
    place; a coarser step stands for the mean of r finer ones).  The finer
    far-end filter, run on from its state over its next arrivals
    (:func:`far_end_run`), gives the outputs the coarser filter must go on
    with: its state is the least-squares fit, over ``H`` outputs, of the
    ``m`` free directions ``T[:, 0:m]`` (chained states: the fast path
    reads each stage's input history from the stage before), added into
    ``st_c`` (whose filter columns are zero on entry).  ``ub``: the
    bridge's displacement (the ring holds the filter's output less it).
    ``buf`` (:func:`hand_over_buffer_length`), ``At`` (>= m x H), ``R``
    (>= m x m): scratch; ``one``: one value."""
    Pf = 2 * Nf
    Pc = 2 * Nc
    ns = st_f.shape[0]
    n_run = r * H + r + 2
    nX = Pf + n_run
    X = buf[0:nX]
    q = nX
    yf = buf[q:q + n_run]
    q += n_run
    tmp = buf[q:q + ns]
    q += ns
    res = buf[q:q + H]
    q += H
    zero = buf[q:q + H]
    q += H
    tgt = buf[q:q + H]
    q += H
    xc = buf[q:q + Pc]
    q += Pc
    sol = buf[q:q + m]
    q += m
    keep = buf[q:q + m]
    # the finer ring's arrivals, then the outputs its filter goes on with
    j0 = pm + 1 - Nf
    if j0 < 0:
        j0 += Pf
    _ring_get(ring, off, Pf, j0, X[0:Pf], 1.0)
    for i in range(ns):
        tmp[i] = st_f[i]
    far_end_run(tmp, fp_f, xdel_f, nd_f, nb_f, X[0:n_run], yf, one)
    for t in range(n_run):
        X[Pf + t] = yf[t] - ub
    delta = Nf - r * Nc
    phase = 0.5 * (r - 1)
    for k in range(Pc):
        xc[k] = _lerp(X, nX, r * k + delta + phase)
    for k in range(H):
        tgt[k] = _lerp(X, nX, r * k - delta + phase + Pf) + ub
        zero[k] = 0.0
    for i in range(Pf):
        ring[off + i] = 0.0
    j0 = pmc + 1 - Nc
    if j0 < 0:
        j0 += Pc
    _ring_put(ring, off, Pc, j0, xc, 1.0)
    # the coarser filter from zero on the new arrivals, and each free
    # direction's zero-input response
    for i in range(ns):
        tmp[i] = st_c[i]
    far_end_run(tmp, fp_c, xdel_c, nd_c, nb_c, xc[0:H], res, one)
    for k in range(H):
        res[k] = tgt[k] - res[k]
    for j in range(m):
        for i in range(ns):
            tmp[i] = T[i, j]
        far_end_run(tmp, fp_c, xdel_c, nd_c, nb_c, zero, At[j, 0:H], one)
    # least squares: modified Gram-Schmidt, twice, dropping a direction the
    # others already span (the chained state has one more value than the
    # filter's order)
    big = 0.0
    for j in range(m):
        big = max(big, np.sqrt(_dot(At[j], At[j], H)))
    for j in range(m):
        for i in range(m):
            R[i, j] = 0.0
        for rep in range(2):
            for i in range(j):
                if keep[i] == 0.0:
                    continue
                c = _dot(At[i], At[j], H)
                R[i, j] += c
                for k in range(H):
                    At[j, k] -= c * At[i, k]
        s = np.sqrt(_dot(At[j], At[j], H))
        if s <= 1e-9 * big:
            keep[j] = 0.0
            R[j, j] = 0.0
        else:
            keep[j] = 1.0
            R[j, j] = s
            for k in range(H):
                At[j, k] /= s
    for j in range(m - 1, -1, -1):
        if keep[j] == 0.0:
            sol[j] = 0.0
            continue
        c = _dot(At[j], res, H)
        for i in range(j + 1, m):
            c -= R[j, i] * sol[i]
        sol[j] = c / R[j, j]
    for i in range(ns):
        s = 0.0
        for j in range(m):
            s += T[i, j] * sol[j]
        st_c[i] += s
