"""The pitch-bend line after the far end's loop filter (numba).

A string with a bend line (``I_BLEN`` > 0) passes its loop filter's output
through a delay line read with third-order Lagrange interpolation
(:func:`_lagrange3`) at a gliding delay plus a decaying tune-out (the
contact's pitch rise, undone) plus the tension's modulation (``S_TM``,
:mod:`synth.kernels.tension`: negative, down to a delay of 1; 0 adds
nothing; it moves in equal steps ``S_TMD`` from one reading to the next):
sample by sample (:func:`_bend_line`, the per-sample path) or over a
fast-path chunk (:func:`_bend_chunk`), the same operations for the same
samples.  Compiled without re-association
(``SERIAL_OPTS``, :mod:`synth.kernels.config` says why).

May import: :mod:`~synth.kernels.config`, :mod:`~synth.kernels.layout`,
:mod:`~synth.kernels.ring`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .config import SERIAL_OPTS
from .layout import S_BD, S_BW, S_TM, S_TMD, S_TO
from .ring import _ring_get, _ring_put

#: a tune-out (``S_TO``) under this (samples, at gain 1) is 0: the bend line
#: sets it so as it decays, and :meth:`synth.dsp.bank.StringBank.set_tune_out`
#: stores a smaller one as 0, so that every run starts with 0 or at least this
TO_FLOOR = 1e-9


@njit(**SERIAL_OPTS)
def _lagrange3(f):
    """Third-order Lagrange taps for the fraction f of a delay i + f, at
    delays i-1 .. i+2 (one function, so that the bend line's per-sample and
    chunk paths compute them with the same operations)."""
    return (-f * (f - 1.0) * (f - 2.0) / 6.0, (f + 1.0) * (f - 1.0) * (f - 2.0) / 2.0,
            -(f + 1.0) * f * (f - 2.0) / 2.0, (f + 1.0) * f * (f - 1.0) / 6.0)


@njit(**SERIAL_OPTS)
def _bend_line(y, st, U, boff, blen, bdt, bds, tor, tog):
    """Pitch-bend line: write y, read at the (gliding) delay plus the
    (decaying) tune-out tog S_TO with third-order Lagrange interpolation
    (taps at delays i-1 .. i+2)."""
    w = int(st[S_BW])
    U[boff + w] = y
    D = st[S_BD] + bds * (bdt - st[S_BD])
    if abs(bdt - D) < 1e-9:
        D = bdt                   # at rest: the fast path's block FIR takes over
    st[S_BD] = D
    to = st[S_TO]
    D += tog * to
    tm = st[S_TM]
    if tm != 0.0:
        # the tension's modulation (synth.kernels.tension): shorter, down to 1
        D += tm
        if D < 1.0:
            D = 1.0
    st[S_TM] = tm + st[S_TMD]     # on to the next reading's, step by step
    to *= tor
    if abs(to) < TO_FLOOR:
        to = 0.0
    st[S_TO] = to
    i = int(D)
    f = D - i
    h0, h1, h2, h3 = _lagrange3(f)
    r = w - i + 1
    if r < 0:
        r += blen
    out = h0 * U[boff + r]
    r -= 1
    if r < 0:
        r += blen
    out += h1 * U[boff + r]
    r -= 1
    if r < 0:
        r += blen
    out += h2 * U[boff + r]
    r -= 1
    if r < 0:
        r += blen
    out += h3 * U[boff + r]
    w += 1
    if w == blen:
        w = 0
    st[S_BW] = w
    return out


@njit(**SERIAL_OPTS)
def _bend_chunk(yb, b, n, st, U, boff, blen, bdt, bds, tor, tog, hb):
    """The pitch-bend line over yb[b:b+n], in place.  While the delay glides,
    sample by sample (:func:`_bend_line`); at rest (the usual case) its
    third-order Lagrange read is a four-tap FIR over the line's last samples
    and the new ones, laid out contiguously in ``hb``: fixed taps, or, while
    a tune-out decays (tog S_TO), taps and integer delay computed per sample
    exactly as :func:`_bend_line` computes them (the same operations in the
    same order, each from its own sample's delay, so that the output does
    not depend on where chunks start)."""
    to = st[S_TO]
    if st[S_BD] != bdt:
        for i in range(n):
            yb[b + i] = _bend_line(yb[b + i], st, U, boff, blen, bdt, bds, tor, tog)
        return
    tm = st[S_TM]                 # the tension's modulation, in equal steps tmd over a chunk
    tmd = st[S_TMD]
    D = bdt + tog * to
    if tm != 0.0:
        D += tm
        if D < 1.0:
            D = 1.0
    iD = int(D)
    if to != 0.0 or tmd != 0.0:
        # the history covers the run's integer delays: each term's largest
        # over the run (the tune-out's and the modulation's are monotonic:
        # at their ends)
        a0 = tog * to
        a1 = tog * (to * tor ** n)
        m1 = tm + n * tmd
        E = bdt + (a0 if a0 > a1 else a1) + (tm if tm > m1 else m1)
        if E < 1.0:
            E = 1.0
        iE = int(E)
        if iE > iD:
            iD = iE
        iD += 1
        if iD > blen - 2:
            iD = blen - 2
    w = int(st[S_BW])
    H = iD + 2                    # history: the H samples before this run
    j = w - H
    if j < 0:
        j += blen
    _ring_get(U, boff, blen, j, hb[0:H], 1.0)
    y_ = yb[b:b + n]
    hn = hb[H:H + n]
    for i in range(n):
        hn[i] = y_[i]
    if to == 0.0 and tmd == 0.0:
        f = D - iD
        h0, h1, h2, h3 = _lagrange3(f)
        t0 = hb[3:3 + n]
        t1 = hb[2:2 + n]
        t2 = hb[1:1 + n]
        for i in range(n):
            y_[i] = h0 * t0[i] + h1 * t1[i] + h2 * t2[i] + h3 * hb[i]
    else:
        # a tune-out decaying or the tension's ramp (a sounding sitar
        # note's usual case: its tune-out lasts some 17 s): each sample's
        # delay by the per-sample recursions, into y_ (its input is in hn),
        # then the reads.  Split so that only the short mul and add chains
        # are recursions: in one loop with the reads, a sample took 4.2 ns,
        # split 1.7 (a 130-sample chunk in a numba loop, Zen 5 host build).
        # The same operations in the same order as _bend_line's, bit for bit
        # (the tune-out's products p run on unchecked, so that its chain is
        # one multiply: |p| only falls, and a tune-out is 0 or at least
        # TO_FLOOR when a run starts, so _bend_line's value, set to 0 once
        # under TO_FLOOR and 0 from then on, is p where |p| >= TO_FLOOR,
        # else 0)
        lo = np.inf
        hi = -np.inf
        p = to
        for i in range(n):
            tu = p
            if abs(p) < TO_FLOOR:
                tu = 0.0
            D = bdt
            D += tog * tu
            if tm != 0.0:
                D += tm
                if D < 1.0:
                    D = 1.0
            tm = tm + tmd
            p = p * tor
            y_[i] = D
            lo = D if D < lo else lo
            hi = D if D > hi else hi
        st[S_TO] = 0.0 if abs(p) < TO_FLOOR else p
        st[S_TM] = tm
        k0 = int(lo)
        if int(hi) == k0:
            # one integer part for the whole run (the usual case: the delay
            # moves by a small part of a sample a chunk): contiguous reads
            # with per-sample taps, which vectorises
            base = H - k0 + 1
            t0 = hb[base:base + n]
            t1 = hb[base - 1:base - 1 + n]
            t2 = hb[base - 2:base - 2 + n]
            t3 = hb[base - 3:base - 3 + n]
            for i in range(n):
                h0, h1, h2, h3 = _lagrange3(y_[i] - k0)
                out = h0 * t0[i]
                out += h1 * t1[i]
                out += h2 * t2[i]
                out += h3 * t3[i]
                y_[i] = out
        else:
            for i in range(n):
                D = y_[i]
                k = int(D)
                h0, h1, h2, h3 = _lagrange3(D - k)
                r = H + i - k + 1     # delay k - 1
                out = h0 * hb[r]
                out += h1 * hb[r - 1]
                out += h2 * hb[r - 2]
                out += h3 * hb[r - 3]
                y_[i] = out
    m = n if n < blen else blen   # the new samples go into the line (its last blen)
    _ring_put(U, boff, blen, (w + n - m) % blen, hb[H + n - m:H + n], 1.0)
    st[S_BW] = (w + n) % blen
