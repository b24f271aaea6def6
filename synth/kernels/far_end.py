"""The far end x = L: a string's loop filter and its force on the bridge (numba).

Step 4 of the scheme (:mod:`synth.kernels.strings`): the sample turning
round at loop position N goes through the loss glide and one-pole loss,
the first-order dispersion allpasses, the tuning allpass, the second-order
dispersion sections and (``I_BLEN`` > 0) the pitch-bend line of
:mod:`synth.kernels.bend`.  One sample at a time (:func:`_far_end`;
:func:`far_end_run` runs it over an array, for the hand-over between
grids), or over a fast-path chunk with the states in registers:
:func:`_far_filter` takes a head loop (:func:`_head`, :func:`_head_sos`)
and passes of sections (:func:`_sections`, :func:`_biquads`);
:func:`_far_write` writes the outputs back into the ring and adds the
bridge force to the mix (:func:`_force_out`); :func:`_far_chunk` is both,
with an external bridge's motion.  The lockstep form of the same filters
for a coupled group is :mod:`synth.kernels.coupled`.

May import: :mod:`~synth.kernels.config`, :mod:`~synth.kernels.lanes`,
:mod:`~synth.kernels.layout`, :mod:`~synth.kernels.ring`,
:mod:`~synth.kernels.bend`.
"""

from __future__ import annotations

from numba import njit

from .bend import _bend_chunk
from .config import JIT_OPTS, SERIAL_OPTS, VECTOR_REGS
from .lanes import abs4, load4, max4, splat4, store4
from .layout import (
    CPL_EXTERNAL, F_A1, F_ADISP, F_B0, F_B0S, F_B0T, F_BDS, F_BDT, F_ETA, F_GAIN, F_PAN, F_SOS,
    F_TDX, F_TOG, F_TOR, F_UBOD, I_BLEN, I_BOFF, I_BUS, I_CPL, I_N, I_NDISP, I_NSOS, I_OFF, I_OUT,
    I_POS, I_ROW, I_XDELAY, MAX_SOS, S_APX, S_APY, S_D0, S_LP, S_SOS, S_UBOFF, S_UBP, S_XD,
)
from .ring import _hmax4, _ring_get_in, _ring_put_in


@njit(**JIT_OPTS)
def _far_end(ring, off, P, N, pm, b0, a1, eta, xdel, nd, ad, st, nb, fsos):
    """One sample of the far-end filter at loop position N; returns (x, y, j)
    with j the ring index written.  (The caller glides b0 toward its target
    and, for a string with a pitch-bend line, passes y through
    :func:`_bend_line` and writes the result at j: kept apart, because with
    the bend code inside, this function stopped being inlined and every
    string-sample cost 35 ns instead of 10.)"""
    j = pm - N
    if j < 0:
        j += P
    x = ring[off + j]
    if xdel == 1:
        xin = st[S_XD]
        st[S_XD] = x
    else:
        xin = x
    lp = b0 * xin - a1 * st[S_LP]
    st[S_LP] = lp
    # string stiffness: M identical first-order allpasses (a + z^-1)/(1 + a z^-1)
    for d in range(nd):
        xo = st[S_D0 + 2 * d]
        yo = st[S_D0 + 2 * d + 1]
        yd = ad * lp + xo - ad * yo
        st[S_D0 + 2 * d] = lp
        st[S_D0 + 2 * d + 1] = yd
        lp = yd
    y = eta * lp + st[S_APX] - eta * st[S_APY]
    st[S_APX] = lp
    st[S_APY] = y
    # string stiffness: second-order allpasses, direct form I written so that
    # the recurrence on y1 is one multiply-add (as :func:`_biquads`)
    for b in range(nb):
        c1 = fsos[2 * b]
        c2 = fsos[2 * b + 1]
        q = S_SOS + 4 * b
        x1 = st[q]
        x2 = st[q + 1]
        y1 = st[q + 2]
        y2 = st[q + 3]
        t = c2 * (y - y2) + x2 + c1 * x1
        yb = t - c1 * y1
        st[q] = y
        st[q + 1] = x1
        st[q + 2] = yb
        st[q + 3] = y1
        y = yb
    ring[off + j] = y
    return x, y, j


@njit(**JIT_OPTS)
def far_end_run(st, fp, xdel, nd, nb, x, y, one):
    """The far-end filter chain of a string alone (:func:`_far_end`: the
    unit delay, the one-pole loss at ``fp[F_B0]``, held, the first-order
    and tuning allpasses, the second-order sections) from the state row
    ``st`` (an ``fst`` row, advanced in place) on the arriving waves ``x``:
    its outputs into ``y`` (no bridge, no bend line).  ``fp``: the
    string's ``fpar`` row; ``one``: one scratch value.  Used by the hand-over
    between grids (:func:`hand_over_loop`)."""
    b0 = fp[F_B0]
    a1 = fp[F_A1]
    eta = fp[F_ETA]
    ad = fp[F_ADISP]
    fsos = fp[F_SOS:F_SOS + 2 * MAX_SOS]
    for i in range(x.shape[0]):
        one[0] = x[i]
        _, yi, _ = _far_end(one, 0, 1, 0, 0, b0, a1, eta, xdel, nd, ad, st, nb, fsos)
        y[i] = yi


@njit(**SERIAL_OPTS)
def _sections(v_, n, st, cnt, s0, s1, s2, s3, c0, c1, c2, c3):
    """``cnt`` (1..4) first-order allpasses (c + z^-1)/(1 + c z^-1) in a row
    over v_[0:n], in place.  Section j has coefficient c_j and its state
    (x1, y1) at st[s_j], st[s_j + 1]; the states stay in registers for the
    run.  Written y = c x + x1 - c y1 and compiled without re-association,
    so the recurrence on y1 is one multiply-add (4 cycles a sample);
    re-associated to c (x - y1) + x1 it is a subtraction and a
    multiply-add."""
    x0 = st[s0]
    y0 = st[s0 + 1]
    # <generated: tools/gen_kernels.py _sections>
    if cnt == 1:
        for i in range(n):
            v = v_[i]
            y0 = c0 * v + x0 - c0 * y0
            x0 = v
            v_[i] = y0
    elif cnt == 2:
        x1 = st[s1]
        y1 = st[s1 + 1]
        for i in range(n):
            v = v_[i]
            y0 = c0 * v + x0 - c0 * y0
            x0 = v
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            v_[i] = y1
        st[s1] = x1
        st[s1 + 1] = y1
    elif cnt == 3:
        x1 = st[s1]
        y1 = st[s1 + 1]
        x2 = st[s2]
        y2 = st[s2 + 1]
        for i in range(n):
            v = v_[i]
            y0 = c0 * v + x0 - c0 * y0
            x0 = v
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            y2 = c2 * y1 + x2 - c2 * y2
            x2 = y1
            v_[i] = y2
        st[s1] = x1
        st[s1 + 1] = y1
        st[s2] = x2
        st[s2 + 1] = y2
    else:
        x1 = st[s1]
        y1 = st[s1 + 1]
        x2 = st[s2]
        y2 = st[s2 + 1]
        x3 = st[s3]
        y3 = st[s3 + 1]
        for i in range(n):
            v = v_[i]
            y0 = c0 * v + x0 - c0 * y0
            x0 = v
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            y2 = c2 * y1 + x2 - c2 * y2
            x2 = y1
            y3 = c3 * y2 + x3 - c3 * y3
            x3 = y2
            v_[i] = y3
        st[s1] = x1
        st[s1 + 1] = y1
        st[s2] = x2
        st[s2 + 1] = y2
        st[s3] = x3
        st[s3 + 1] = y3
    # </generated>
    st[s0] = x0
    st[s0 + 1] = y0


@njit(**SERIAL_OPTS)
def _biquads(v_, n, st, fp, j0, cnt):
    """Second-order allpass sections j0 .. j0+cnt-1 (cnt 1..4) of the
    string's dispersion, (c2 + c1 z^-1 + z^-2) / (1 + c1 z^-1 + c2 z^-2),
    over v_[0:n] in place, states in registers for the run.  Direct form I,
    written y = (c2 (x - y2) + x2 + c1 x1) - c1 y1 and compiled without
    re-association, so that the recurrence on y1 is one multiply-add (the
    rest waits on values of earlier samples); a cascade's section j+1
    takes section j's output, so the sections of one pass overlap across
    samples."""
    q0 = S_SOS + 4 * j0
    a0 = fp[F_SOS + 2 * j0]
    b0 = fp[F_SOS + 2 * j0 + 1]
    x10 = st[q0]
    x20 = st[q0 + 1]
    y10 = st[q0 + 2]
    y20 = st[q0 + 3]
    # <generated: tools/gen_kernels.py _biquads>
    if cnt == 1:
        for i in range(n):
            x = v_[i]
            y = (b0 * (x - y20) + x20 + a0 * x10) - a0 * y10
            x20 = x10
            x10 = x
            y20 = y10
            y10 = y
            v_[i] = y
    elif cnt == 2:
        q1 = q0 + 4
        a1 = fp[F_SOS + 2 * j0 + 2]
        b1 = fp[F_SOS + 2 * j0 + 3]
        y11 = st[q1 + 2]
        y21 = st[q1 + 3]
        for i in range(n):
            x = v_[i]
            y = (b0 * (x - y20) + x20 + a0 * x10) - a0 * y10
            x20 = x10
            x10 = x
            z = (b1 * (y - y21) + y20 + a1 * y10) - a1 * y11
            y20 = y10
            y10 = y
            y21 = y11
            y11 = z
            v_[i] = z
        st[q1] = y10
        st[q1 + 1] = y20
        st[q1 + 2] = y11
        st[q1 + 3] = y21
    elif cnt == 3:
        q1 = q0 + 4
        q2 = q0 + 8
        a1 = fp[F_SOS + 2 * j0 + 2]
        b1 = fp[F_SOS + 2 * j0 + 3]
        a2 = fp[F_SOS + 2 * j0 + 4]
        b2 = fp[F_SOS + 2 * j0 + 5]
        y11 = st[q1 + 2]
        y21 = st[q1 + 3]
        y12 = st[q2 + 2]
        y22 = st[q2 + 3]
        for i in range(n):
            x = v_[i]
            y = (b0 * (x - y20) + x20 + a0 * x10) - a0 * y10
            x20 = x10
            x10 = x
            z = (b1 * (y - y21) + y20 + a1 * y10) - a1 * y11
            y20 = y10
            y10 = y
            w = (b2 * (z - y22) + y21 + a2 * y11) - a2 * y12
            y21 = y11
            y11 = z
            y22 = y12
            y12 = w
            v_[i] = w
        st[q1] = y10
        st[q1 + 1] = y20
        st[q1 + 2] = y11
        st[q1 + 3] = y21
        st[q2] = y11
        st[q2 + 1] = y21
        st[q2 + 2] = y12
        st[q2 + 3] = y22
    else:
        q1 = q0 + 4
        q2 = q0 + 8
        q3 = q0 + 12
        a1 = fp[F_SOS + 2 * j0 + 2]
        b1 = fp[F_SOS + 2 * j0 + 3]
        a2 = fp[F_SOS + 2 * j0 + 4]
        b2 = fp[F_SOS + 2 * j0 + 5]
        a3 = fp[F_SOS + 2 * j0 + 6]
        b3 = fp[F_SOS + 2 * j0 + 7]
        y11 = st[q1 + 2]
        y21 = st[q1 + 3]
        y12 = st[q2 + 2]
        y22 = st[q2 + 3]
        y13 = st[q3 + 2]
        y23 = st[q3 + 3]
        for i in range(n):
            x = v_[i]
            y = (b0 * (x - y20) + x20 + a0 * x10) - a0 * y10
            x20 = x10
            x10 = x
            z = (b1 * (y - y21) + y20 + a1 * y10) - a1 * y11
            y20 = y10
            y10 = y
            w = (b2 * (z - y22) + y21 + a2 * y11) - a2 * y12
            y21 = y11
            y11 = z
            u = (b3 * (w - y23) + y22 + a3 * y12) - a3 * y13
            y22 = y12
            y12 = w
            y23 = y13
            y13 = u
            v_[i] = u
        st[q1] = y10
        st[q1 + 1] = y20
        st[q1 + 2] = y11
        st[q1 + 3] = y21
        st[q2] = y11
        st[q2 + 1] = y21
        st[q2 + 2] = y12
        st[q2 + 3] = y22
        st[q3] = y12
        st[q3 + 1] = y22
        st[q3 + 2] = y13
        st[q3 + 3] = y23
    # </generated>
    st[q0] = x10
    st[q0 + 1] = x20
    st[q0 + 2] = y10
    st[q0 + 3] = y20


@njit(**SERIAL_OPTS)
def _head(xin, yo, n, st, fp, cnt, s0, s1, s2, s3, c0, c1, c2, c3):
    """The far end's first pass over a chunk: the loss glide
    (b0 <- gk b0 + gc, toward F_B0T), the one-pole loss
    y = b0 x - a1 y1, then ``cnt`` (1..4) allpass sections as in
    :func:`_sections`, from xin[0:n] into yo[0:n]."""
    b0 = fp[F_B0]
    gk = 1.0 - fp[F_B0S]
    gc = fp[F_B0S] * fp[F_B0T]
    a1 = fp[F_A1]
    lp = st[S_LP]
    x0 = st[s0]
    y0 = st[s0 + 1]
    # <generated: tools/gen_kernels.py _head>
    if cnt == 1:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            yo[i] = y0
    elif cnt == 2:
        x1 = st[s1]
        y1 = st[s1 + 1]
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            yo[i] = y1
        st[s1] = x1
        st[s1 + 1] = y1
    elif cnt == 3:
        x1 = st[s1]
        y1 = st[s1 + 1]
        x2 = st[s2]
        y2 = st[s2 + 1]
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            y2 = c2 * y1 + x2 - c2 * y2
            x2 = y1
            yo[i] = y2
        st[s1] = x1
        st[s1 + 1] = y1
        st[s2] = x2
        st[s2 + 1] = y2
    else:
        x1 = st[s1]
        y1 = st[s1 + 1]
        x2 = st[s2]
        y2 = st[s2 + 1]
        x3 = st[s3]
        y3 = st[s3 + 1]
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            y2 = c2 * y1 + x2 - c2 * y2
            x2 = y1
            y3 = c3 * y2 + x3 - c3 * y3
            x3 = y2
            yo[i] = y3
        st[s1] = x1
        st[s1 + 1] = y1
        st[s2] = x2
        st[s2 + 1] = y2
        st[s3] = x3
        st[s3 + 1] = y3
    # </generated>
    st[s0] = x0
    st[s0 + 1] = y0
    st[S_LP] = lp
    fp[F_B0] = b0


#: biquads the scalar head loop (:func:`_head_sos`) takes all of, with the
#: loss and first-order sections: four where the vector registers are 32
#: (AVX-512), three where they are 16 (AVX2, SSE2: a head of four kept its
#: states on the stack).  With more, the head takes one (16 registers) or
#: what passes of four leave (32), the rest run in passes (microbenchmark:
#: ``python tools/bench.py heads``; docs/benchmarks.md, "One change, one
#: loop")
_HEAD_SOS = 4 if VECTOR_REGS >= 32 else 3


@njit(**SERIAL_OPTS)
def _head_sos(xin, yo, n, st, fp, ns, s0, s1, c0, c1, cnt):
    """The far end's first pass over a chunk for a string with second-order
    dispersion: the loss glide and the one-pole loss, ``ns`` (1 or 2)
    first-order allpass sections (as :func:`_head`), then the first ``cnt``
    (1..4) biquads (as :func:`_biquads`), from xin[0:n] into yo[0:n], in one
    loop.  Each stage's recurrence waits on one multiply-add of the sample
    before; in one loop the stages of successive samples overlap, where in
    separate passes each pass waits on its own chain (measured with
    ``python tools/bench.py heads``).  Compiled without
    re-association, as :func:`_biquads`."""
    b0 = fp[F_B0]
    gk = 1.0 - fp[F_B0S]
    gc = fp[F_B0S] * fp[F_B0T]
    a1 = fp[F_A1]
    lp = st[S_LP]
    x0 = st[s0]
    y0 = st[s0 + 1]
    x1 = st[s1]
    y1 = st[s1 + 1]
    q0 = S_SOS
    x10 = st[q0]
    x20 = st[q0 + 1]
    ca0 = fp[F_SOS + 0] if cnt > 0 else 0.0
    cb0 = fp[F_SOS + 1] if cnt > 0 else 0.0
    y10 = st[q0 + 2] if cnt > 0 else 0.0
    y20 = st[q0 + 3] if cnt > 0 else 0.0
    ca1 = fp[F_SOS + 2] if cnt > 1 else 0.0
    cb1 = fp[F_SOS + 3] if cnt > 1 else 0.0
    y11 = st[q0 + 6] if cnt > 1 else 0.0
    y21 = st[q0 + 7] if cnt > 1 else 0.0
    ca2 = fp[F_SOS + 4] if cnt > 2 else 0.0
    cb2 = fp[F_SOS + 5] if cnt > 2 else 0.0
    y12 = st[q0 + 10] if cnt > 2 else 0.0
    y22 = st[q0 + 11] if cnt > 2 else 0.0
    ca3 = fp[F_SOS + 6] if cnt > 3 else 0.0
    cb3 = fp[F_SOS + 7] if cnt > 3 else 0.0
    y13 = st[q0 + 14] if cnt > 3 else 0.0
    y23 = st[q0 + 15] if cnt > 3 else 0.0
    # <generated: tools/gen_kernels.py _head_sos>
    if ns == 1 and cnt == 1:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            h = y0
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            y20 = y10
            y10 = o0
            yo[i] = o0
    elif ns == 1 and cnt == 2:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            h = y0
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            y21 = y11
            y11 = o1
            yo[i] = o1
    elif ns == 1 and cnt == 3:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            h = y0
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            y22 = y12
            y12 = o2
            yo[i] = o2
    elif ns == 1 and cnt == 4:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            h = y0
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            o3 = (cb3 * (o2 - y23) + y22 + ca3 * y12) - ca3 * y13
            y22 = y12
            y12 = o2
            y23 = y13
            y13 = o3
            yo[i] = o3
    elif ns == 2 and cnt == 1:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            h = y1
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            y20 = y10
            y10 = o0
            yo[i] = o0
    elif ns == 2 and cnt == 2:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            h = y1
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            y21 = y11
            y11 = o1
            yo[i] = o1
    elif ns == 2 and cnt == 3:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            h = y1
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            y22 = y12
            y12 = o2
            yo[i] = o2
    elif ns == 2 and cnt == 4:
        for i in range(n):
            b0 = gk * b0 + gc
            lp = b0 * xin[i] - a1 * lp
            y0 = c0 * lp + x0 - c0 * y0
            x0 = lp
            y1 = c1 * y0 + x1 - c1 * y1
            x1 = y0
            h = y1
            o0 = (cb0 * (h - y20) + x20 + ca0 * x10) - ca0 * y10
            x20 = x10
            x10 = h
            o1 = (cb1 * (o0 - y21) + y20 + ca1 * y10) - ca1 * y11
            y20 = y10
            y10 = o0
            o2 = (cb2 * (o1 - y22) + y21 + ca2 * y11) - ca2 * y12
            y21 = y11
            y11 = o1
            o3 = (cb3 * (o2 - y23) + y22 + ca3 * y12) - ca3 * y13
            y22 = y12
            y12 = o2
            y23 = y13
            y13 = o3
            yo[i] = o3
    # </generated>
    st[s0] = x0
    st[s0 + 1] = y0
    if ns == 2:
        st[s1] = x1
        st[s1 + 1] = y1
    st[S_LP] = lp
    fp[F_B0] = b0
    st[q0] = x10
    st[q0 + 1] = x20
    if cnt > 0:
        st[q0 + 2] = y10
        st[q0 + 3] = y20
    if cnt > 1:
        st[q0 + 4] = y10
        st[q0 + 5] = y20
        st[q0 + 6] = y11
        st[q0 + 7] = y21
    if cnt > 2:
        st[q0 + 8] = y11
        st[q0 + 9] = y21
        st[q0 + 10] = y12
        st[q0 + 11] = y22
    if cnt > 3:
        st[q0 + 12] = y12
        st[q0 + 13] = y22
        st[q0 + 14] = y13
        st[q0 + 15] = y23


@njit(inline="always", **JIT_OPTS)
def _io(ipar, s):
    """Where a string's filter input starts in its far-end window: 0 with
    the extra unit delay (the register S_XD first), else 1."""
    return 0 if ipar[s, I_XDELAY] == 1 else 1


@njit(inline="always", **JIT_OPTS)
def _far_prep(s, ring, ipar, fst, C, xb, yb):
    """The far end's windows of a chunk: xb[1:C+2] gets the samples arriving
    at x = L (contiguous ring slots j0 .. j0+C), xb[0] the extra-delay
    register, yb[0] the previous chunk's last output.  Returns where the
    filter's input starts in xb (:func:`_io`)."""
    off = ipar[s, I_OFF]
    N = ipar[s, I_N]
    P = 2 * N
    m0 = ipar[s, I_POS]
    j0 = m0 + 1 - N
    if j0 < 0:
        j0 += P
    # xb[1 + i] = x_i, the sample arriving at x = L at the chunk's sample i,
    # for i = 0..C (x_C: its right neighbour at the last sample, u_r(N-1));
    # xb[0] = the extra-delay register, so the filter's input is
    # xb[i] (with the unit delay) or xb[1 + i] (without)
    xb[0] = fst[s, S_XD]
    _ring_get_in(ring, off, P, j0, xb[1:C + 2], 1.0)
    jp = j0 - 1
    if jp < 0:
        jp += P
    yb[0] = ring[off + jp]          # the previous chunk's last output, vl(N-1)
    return _io(ipar, s)


@njit(**JIT_OPTS)
def _far_filter(s, ring, ipar, fpar, fst, U, C, xb, yb, hb):
    """Step 4 of the fast path over a chunk, first half: the far-end filter
    on the C samples turning round at x = L (contiguous ring slots j0 ..
    j0+C-1), its state in registers, into yb[1:C+1] (not yet written back);
    xb[1:C+2] gets the arriving samples x_0 .. x_C and yb[0] the previous
    output.  :func:`_far_write` finishes the step."""
    st = fst[s]
    fp = fpar[s]
    io = _far_prep(s, ring, ipar, fst, C, xb, yb)
    xin = xb[io:io + C]             # the filter's input
    yo = yb[1:1 + C]                # its output
    # the allpass sections (dispersion, then tuning): the first four run in
    # the loss's pass, the rest four per pass (states in registers)
    nd = ipar[s, I_NDISP]
    ad = fp[F_ADISP]
    eta = fp[F_ETA]
    ns = nd + 1
    cnt = ns if ns < 4 else 4
    # section j: state column and coefficient (the nd dispersion sections,
    # then the tuning allpass)
    s0 = S_D0 if 0 < nd else S_APX
    c0 = ad if 0 < nd else eta
    s1 = S_D0 + 2 if 1 < nd else S_APX
    c1 = ad if 1 < nd else eta
    s2 = S_D0 + 4 if 2 < nd else S_APX
    c2 = ad if 2 < nd else eta
    s3 = S_D0 + 6 if 3 < nd else S_APX
    c3 = ad if 3 < nd else eta
    nb = ipar[s, I_NSOS]
    j = 0
    if nb > 0 and ns <= 2:
        # loss, first-order sections and the first biquads in one loop: all
        # of them up to _HEAD_SOS, else one (16 vector registers) or what
        # passes of four leave (32)
        if nb <= _HEAD_SOS:
            j = nb
        elif VECTOR_REGS >= 32:
            j = (nb - 1) % 4 + 1
        else:
            j = 1
        _head_sos(xin, yo, C, st, fp, ns, s0, s1, c0, c1, j)
        cnt = ns
    else:
        _head(xin, yo, C, st, fp, cnt, s0, s1, s2, s3, c0, c1, c2, c3)
    jb = j
    j = cnt
    while j < ns:
        cnt = ns - j
        if cnt > 4:
            cnt = 4
        s0 = S_D0 + 2 * j if j < nd else S_APX
        c0 = ad if j < nd else eta
        s1 = S_D0 + 2 * j + 2 if j + 1 < nd else S_APX
        c1 = ad if j + 1 < nd else eta
        s2 = S_D0 + 2 * j + 4 if j + 2 < nd else S_APX
        c2 = ad if j + 2 < nd else eta
        s3 = S_D0 + 2 * j + 6 if j + 3 < nd else S_APX
        c3 = ad if j + 3 < nd else eta
        _sections(yo, C, st, cnt, s0, s1, s2, s3, c0, c1, c2, c3)
        j += cnt
    j = jb
    while j < nb:
        # the rest in passes as even as passes of at most four allow (a
        # pass of one biquad waits on its own recurrence)
        left = nb - j
        passes = (left + 3) // 4
        cnt = (left + passes - 1) // passes
        _biquads(yo, C, st, fp, j, cnt)
        j += cnt
    if io == 0:
        st[S_XD] = xb[C]
    blen = ipar[s, I_BLEN]
    if blen > 0:
        _bend_chunk(yb, 1, C, st, U, ipar[s, I_BOFF], blen, fp[F_BDT], fp[F_BDS], fp[F_TOR],
                    fp[F_TOG], hb)


@njit(inline="always", **JIT_OPTS)
def _force_out(yo, yp, un, up, has_ub, m0, m1, two, g0, g1, C):
    """The bridge force of a chunk, v = 2 (yo - yp) (+ (un - up) if
    ``has_ub``), added to the buses (g0 v to m0 and, if ``two``, g1 v to
    m1); returns max |v| (from 0).  Four samples to a vector (the running
    maximum is a reduction LLVM does not vectorise without no-NaN
    fast-math; :func:`synth.kernels.lanes.max4` keeps its NaN rule), the
    same operations per sample as the scalar loop.

    Inlined into its callers (``inline="always"``, saving a call that
    passes six slices as their fields).  Its arithmetic keeps the serial
    kernels' fast-math flags (no re-association) whatever the caller's:
    the vector loops' is the lanes' (``synth.kernels.lanes``), which carry
    them, and the C % 4 samples after the last full vector go through
    :func:`_force_one`, a ``SERIAL_OPTS`` function (the same samples as
    one ``SERIAL_OPTS`` function, not inlined, for the whole block)."""
    two4 = splat4(2.0)
    g04 = splat4(g0)
    g14 = splat4(g1)
    p4 = splat4(0.0)
    n4 = C - C % 4
    if has_ub and two:
        for i in range(0, n4, 4):
            v = two4 * (load4(yo, i) - load4(yp, i)) + (load4(un, i) - load4(up, i))
            store4(m0, i, load4(m0, i) + g04 * v)
            store4(m1, i, load4(m1, i) + g14 * v)
            p4 = max4(p4, abs4(v))
    elif has_ub:
        for i in range(0, n4, 4):
            v = two4 * (load4(yo, i) - load4(yp, i)) + (load4(un, i) - load4(up, i))
            store4(m0, i, load4(m0, i) + g04 * v)
            p4 = max4(p4, abs4(v))
    elif two:
        for i in range(0, n4, 4):
            v = two4 * (load4(yo, i) - load4(yp, i))
            store4(m0, i, load4(m0, i) + g04 * v)
            store4(m1, i, load4(m1, i) + g14 * v)
            p4 = max4(p4, abs4(v))
    else:
        for i in range(0, n4, 4):
            v = two4 * (load4(yo, i) - load4(yp, i))
            store4(m0, i, load4(m0, i) + g04 * v)
            p4 = max4(p4, abs4(v))
    peak = _hmax4(p4, 0.0)
    for i in range(n4, C):
        v, a0, a1 = _force_one(yo[i], yp[i], un[i], up[i], has_ub, m0[i], m1[i], g0, g1)
        m0[i] = a0
        if two:
            m1[i] = a1
        a = abs(v)
        peak = a if a > peak else peak
    return peak


@njit(**SERIAL_OPTS)
def _force_one(yo, yp, un, up, has_ub, m0, m1, g0, g1):
    """One sample of :func:`_force_out` after its last full vector: v and
    the buses' m0 + g0 v, m1 + g1 v, in the serial kernels' fast-math flags
    (a function of its own, not inlined by numba: inlined, its arithmetic
    would take the caller's flags; LLVM may still inline it, keeping each
    instruction's own).  The same samples as a scalar loop of
    ``SERIAL_OPTS`` arithmetic (not always those of the vector loop's
    lanes: written in lane 0 of vectors, the last bit of some samples
    differed)."""
    if has_ub:
        v = 2.0 * (yo - yp) + (un - up)
    else:
        v = 2.0 * (yo - yp)
    return v, m0 + g0 * v, m1 + g1 * v


@njit(inline="always", **JIT_OPTS)
def _far_write(s, ring, ipar, fpar, C, yb, mix, o0, ubw, has_ub):
    """Step 4, second half: write the far end's outputs yb[1:C+1] back into
    the ring and, for the bridge-force output (``I_OUT`` 1), add the output
    to the mix's buses (rows ``I_ROW`` and ``I_ROW`` + 1 of mix[:, o0:o0+C],
    split by ``F_PAN`` as :func:`_bus_add`), in the same pass.  Returns the
    chunk's peak output.

    The force on the bridge.  The loop filter (loss, dispersion, tuning)
    stands for the whole string but acts at x = L; read as sitting just
    before the end, the wave that reaches the end is its output z, and the
    end reflects it at once: the force is Z (v_in - v_out) = T/dx (dz + dy)
    with y = z - u_b the wave leaving (u_b the bridge's displacement: 0 on
    a rigid bridge), i.e. T/dx (2 dy + du_b), each d a step's difference
    (yb[0] = the last chunk's y; ubw[0:C+1] = u_b of the sample before the
    chunk and of its C samples, if ``has_ub``).  (Taking u(N-1) - u(N) of
    the grid instead, with the filter's input arriving at N, adds the
    incoming wave before the filter to the wave after it: for a dispersive
    loop, whose filter delays partial n by a phase phi_n, that is a comb
    |cos(phi_n / 2)| over the partials, -10 to -60 dB on some of them.)"""
    off = ipar[s, I_OFF]
    N = ipar[s, I_N]
    P = 2 * N
    j0 = ipar[s, I_POS] + 1 - N
    if j0 < 0:
        j0 += P
    _ring_put_in(ring, off, P, j0, yb[1:C + 1], 1.0)
    peak = 0.0
    if ipar[s, I_OUT] == 1:
        sc = fpar[s, F_GAIN] * fpar[s, F_TDX]
        r0 = ipar[s, I_ROW]
        two = ipar[s, I_BUS] == 1 and mix.shape[0] > r0 + 1
        pan = fpar[s, F_PAN]
        g0 = sc * (1.0 - pan) if two else sc
        g1 = sc * pan
        m0 = mix[r0, o0:o0 + C]
        m1 = mix[r0 + 1 if two else r0, o0:o0 + C]
        peak = _force_out(yb[1:1 + C], yb[0:C], ubw[1:1 + C], ubw[0:C], has_ub, m0, m1, two,
                          g0, g1, C)
        peak *= abs(sc)
    return peak


@njit(**JIT_OPTS)
def _far_chunk(s, ring, ipar, fpar, fst, U, C, xb, yb, hb, mix, ubx, o0):
    """Step 4 of the fast path over a chunk (:func:`_far_filter`, then
    :func:`_far_write`); a string on an external bridge (``I_CPL`` =
    ``CPL_EXTERNAL``) has the bridge's displacement ubx[o0:o0+C] subtracted
    from its outgoing wave (u(L) = that of the loop filter + u_b).
    Returns the chunk's peak output."""
    _far_filter(s, ring, ipar, fpar, fst, U, C, xb, yb, hb)
    if ipar[s, I_CPL] == CPL_EXTERNAL:
        yo = yb[1:1 + C]
        ubw = hb[0:C + 1]           # (no bend line on a bridge: hb is free)
        ubw[0] = fst[s, S_UBP]
        ub = ubx[o0:o0 + C]
        un = ubw[1:1 + C]
        eo = fst[s, S_UBOFF]
        if eo != 0.0:
            # the offset the string eases off since it joined the bridge
            dk = fpar[s, F_UBOD]
            for i in range(C):
                un[i] = ub[i] - eo
                eo *= dk
            fst[s, S_UBOFF] = eo if abs(eo) > 1e-30 else 0.0
        else:
            for i in range(C):
                un[i] = ub[i]
        for i in range(C):
            yo[i] -= un[i]
        fst[s, S_UBP] = un[C - 1]
        return _far_write(s, ring, ipar, fpar, C, yb, mix, o0, ubw, True)
    return _far_write(s, ring, ipar, fpar, C, yb, mix, o0, hb, False)
