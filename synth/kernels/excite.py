"""Excitation at the string's point k: plucks, g tables and felt hammers (numba).

Step 2 of the scheme (:mod:`synth.kernels.strings`): the outgoing wave g
is injected at k on both rails.  Here are the closed-form plucks
(:func:`_g_at`), the lumped felt hammer's step (:func:`_hammer_general`,
and its short steady-contact form :func:`_hammer_steady`), the fold of an
ended excitation's constant g into the ring (:func:`_fold_offset`), and
the fast path's excitation over a chunk, for one string
(:func:`_excite_chunk`) or for up to ``GROUP`` hammered strings with their
steps interleaved (:func:`_excite_group`).  The felt as a medium
(``EXC_FELT``) runs in the per-sample path of :mod:`synth.kernels.strings`,
from :mod:`synth.kernels.felt_layer`.

May import: :mod:`~synth.kernels.config`, :mod:`~synth.kernels.layout`,
:mod:`~synth.kernels.ring`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .config import EXACT_OPTS, JIT_OPTS, SERIAL_OPTS
from .layout import (
    EXC_BIWA, EXC_ENDED, EXC_GTABLE, EXC_HAMMER3, EXC_NONE, EXC_SITAR, F_A, F_ALPHA, F_DT, F_HB4,
    F_HC2, F_HC3, F_HD, F_HDTV, F_HDZ, F_HFA, F_HFB, F_HFPHI, F_HKCA, F_HKCBP, F_HKCBY, F_HKCD,
    F_HMC, F_HP, F_HP0, F_HP1, F_HPE, F_HREL, F_HTOL, F_HTOLG, F_HV, F_T0, GROUP, I_EXC, I_EXC_END,
    I_EXC_M, I_GT_OFF, I_HLAST, I_K, I_N, I_OFF, I_POS, S_G, S_HDG, S_HDG2, S_HDG3, S_HIW, S_HPHI,
    S_HW, S_HY, S_HZ, _GIB, _GROW,
)
from .ring import _ring_add, _ring_get


@njit(**JIT_OPTS)
def _g_at(kind, e, dt, A, t0, alpha):
    """Outgoing wave g (m) at excitation sample e (t = e dt)."""
    if e < 0:
        return 0.0
    t = e * dt
    if kind == EXC_SITAR:
        if t > t0:
            return A
        r = t / t0
        return A * r * r * np.exp(2.0 * (1.0 - r))
    else:
        if t > t0:
            t = t0
        return A * (1.0 - (1.0 + alpha * t) * np.exp(-alpha * t))


@njit(inline="always", **SERIAL_OPTS)
def _steady_end(st, fp, x, w1, y, e, g0, h1, h2, y0, phi0, zc, dz, p, c2, c3):
    """The end of :func:`_hammer_steady` at the increment ``x`` (``w1`` the
    compression there, ``y`` = w^p at the last iterate, ``e`` the last
    correction's relative change of w): w^p at ``x`` by its third-order
    step, the felt's force and memory, and the hammer's state.  Returns
    (g1, F1, w1, True)."""
    y1 = y * (1.0 + e * (p + e * (c2 + e * c3)))
    st[S_HDG3] = h2
    st[S_HDG2] = h1
    st[S_HDG] = x
    g1 = g0 + x
    phi1 = fp[F_HPE] * phi0 + fp[F_HP1] * y1 + fp[F_HP0] * y0
    F1 = fp[F_HFA] * y1 + fp[F_HFB] * y0 + fp[F_HFPHI] * phi1
    if F1 < 0.0:
        F1 = 0.0
    st[S_HPHI] = phi1
    st[S_HZ] = zc - dz * g1
    st[S_HY] = y1
    st[S_HW] = w1
    st[S_HIW] = 1.0 / w1
    return g1, F1, w1, True


@njit(inline="always", **SERIAL_OPTS)
def _hammer_steady(I1, g0, fp, st):
    """The hammer step (:func:`_hammer_general`) in steady contact, short
    and branch-free, or nothing.

    When the last three steps pressed the string, w^p is continued from the
    last step's w0 by its binomial series in e0 = w / w0 - 1 (to
    C(p, 10) e0^10: error < 1e-18 for |e0| < 0.05) instead of a power, and
    a Halley correction follows.  If it changed w by less than the
    solver's tolerance F_HTOL, the step ends there, by the general step's
    own test (Halley's next correction would be ~F_HTOL^3), with w^p at
    the final point by its third-order step.  That ending takes a grand
    chord's first block about 10 % less time than a second correction in
    every step did (keys 48-79: 717-823 against 768-865 us, one thread,
    alternated, 2-vCPU Zen 5); the samples moved by at most 1e-11 of a
    note's peak, as much as two solves at tolerance 1e-10 differ from each
    other.  Otherwise a second correction follows, with w^p by a
    fifth-order Taylor step (error < 1e-16 for a first correction below
    1e-3), and one test says whether the result is the solution to
    round-off (the second correction within F_HTOL); if not (contact
    starting or ending, a jump of the incoming wave), nothing has been
    written and the last return value is False: the caller takes the
    general step.  Kept small so that it inlines and the steps of several
    hammers overlap in the CPU (:func:`_excite_group`).  Returns
    (g1, F1, w1, done).
    """
    y0 = st[S_HY]
    h3 = st[S_HDG3]
    if not (h3 > 0.0 and y0 > 0.0):
        return g0, 0.0, 0.0, False
    dz = fp[F_HDZ]
    D = fp[F_HD]
    z0 = st[S_HZ]
    phi0 = st[S_HPHI]
    zc = z0 + fp[F_HDTV] - dz * g0
    W0 = zc - I1 - D * g0
    p = fp[F_HP]
    c2 = fp[F_HC2]
    c3 = fp[F_HC3]
    Kca = fp[F_HKCA]
    kcd = fp[F_HKCD]
    kh = kcd * D * (p - 1.0)
    Kcb = fp[F_HKCBY] * y0 + fp[F_HKCBP] * phi0
    h1 = st[S_HDG]
    h2 = st[S_HDG2]
    x = 3.0 * (h1 - h2) + h3
    w = W0 - D * x
    e0 = (w - st[S_HW]) * st[S_HIW]
    q = fp[F_HB4 + 6]
    q = q * e0 + fp[F_HB4 + 5]
    q = q * e0 + fp[F_HB4 + 4]
    q = q * e0 + fp[F_HB4 + 3]
    q = q * e0 + fp[F_HB4 + 2]
    q = q * e0 + fp[F_HB4 + 1]
    q = q * e0 + fp[F_HB4]
    q = q * e0 + c3
    q = q * e0 + c2
    q = q * e0 + p
    q = q * e0 + 1.0
    y = y0 * q
    imp = Kca * y + Kcb
    r = x - imp
    Aw = w + kcd * y
    inv = 1.0 / (2.0 * Aw * Aw + r * kh * y)
    x1 = x - 2.0 * r * w * Aw * inv
    e1 = 2.0 * D * r * Aw * inv
    w = W0 - D * x1
    etol = fp[F_HTOL]
    if (-0.05 < e0 < 0.05 and -etol < e1 < etol and imp > 0.0 and w > 0.0 and x1 > 0.0):
        # converged by the general step's own test (the correction just made
        # changed w by less than F_HTOL; Halley's next would be ~e1^3):
        # w^p at the final point by its third-order step, as it takes
        return _steady_end(st, fp, x1, w, y, e1, g0, h1, h2, y0, phi0, zc, dz, p, c2, c3)
    y = y * (1.0 + e1 * (p + e1 * (c2 + e1 * (c3 + e1 * (fp[F_HB4] + e1 * fp[F_HB4 + 1])))))
    imp2 = Kca * y + Kcb
    r = x1 - imp2
    Aw = w + kcd * y
    inv = 1.0 / (2.0 * Aw * Aw + r * kh * y)
    x2 = x1 - 2.0 * r * w * Aw * inv
    e2 = 2.0 * D * r * Aw * inv
    if (-0.05 < e0 < 0.05 and -1e-3 < e1 < 1e-3 and -etol < e2 < etol
            and imp > 0.0 and imp2 > 0.0 and w > 0.0 and x2 > 0.0):
        return _steady_end(st, fp, x2, W0 - D * x2, y, e2, g0, h1, h2, y0, phi0, zc, dz, p, c2,
                           c3)
    return g0, 0.0, 0.0, False


@njit(**SERIAL_OPTS)
def _hammer_general(I1, g0, fp, st):
    """Advance the hammer-string contact (eq. 1.4) by one step.

    Unknown: g1 = g(t_{n+1}), written g1 = g0 + x.  With the incoming
    displacement I1 at the strike point known (it arrives from the
    neighbours), z1 = z0 + dt (V - (2T/cm)(g0 + g1)/2), so the compression
    w1 = z1 - I1 - g1 = W0 - D x is linear in x (D = 1 + dt T/(cm)), and
    g1 = g0 + (c/2T) max(0, int F dt).  The felt impulse over the step, with
    y = w_mm^p linear in the step, is integrated exactly:

    law 4 (eq. 1.5):  int F = Q0 [dt (y0 + y1)/2 + alpha (y1 - y0)];
    law 5 (Pub. III eq. 3, recursive convolution):
        int F = F0 [(1 - gamma) dt (y0 + y1)/2 + gamma J - gamma (1 - E) Phi0],
        J = tau0 (c1 y1 + c0 y0), E = exp(-dt/tau0);

    both are ``ca y1 + cb`` with ca > 0, and the strike's constants (columns
    F_HDZ .. F_HC3, one form for both laws) are computed once per strike.
    So the residual r(x) = x - K max(0, ca y(W0 - D x) + cb) is increasing
    (r' >= 1) and concave (y is convex in w, w linear in x).  The solve
    starts from the last three steps' increments extrapolated
    quadratically and takes Halley steps (r'' costs three multiplies more
    than Newton's r' and makes the convergence cubic: 1.04-1.57 iterations
    per step over keys 36-76, against 1.2-2.1 with Newton), falling back to
    Newton's step, which converges from any start, monotonically from the
    left after its first step, with no bracket, where Halley's denominator
    says the iterate is far from the root.  It stops when a correction
    changes w by less than F_HTOL relative (1e-5 by default: the next would
    be ~1e-15) or x by less than F_HTOLG of g (1e-13).  One power per step, as exp(p ln w) (later
    iterates update w^p by a Taylor step in the relative change of w,
    which the step gives with its one division).  A-stable (the stiff felt
    terms are integrated exactly), second order.  Returns (g1, F1, w1,
    contact).
    """
    dz = fp[F_HDZ]
    D = fp[F_HD]
    z0 = st[S_HZ]
    y0 = st[S_HY]
    phi0 = st[S_HPHI]
    zc = z0 + fp[F_HDTV] - dz * g0          # z1 = zc - dz g1
    W0 = zc - I1 - D * g0                   # w1 if g1 = g0
    if W0 <= 0.0 and y0 == 0.0 and phi0 == 0.0:
        # in flight (law 4: cb = 0; law 5: no felt memory left): w < 0 for
        # every x >= 0 and no force, so x = 0
        st[S_HDG3] = st[S_HDG2]
        st[S_HDG2] = st[S_HDG]
        st[S_HDG] = 0.0
        st[S_HZ] = zc - dz * g0
        st[S_HY] = 0.0
        st[S_HW] = W0
        st[S_HIW] = 0.0
        return g0, 0.0, W0, False
    p = fp[F_HP]
    c2 = fp[F_HC2]
    c3 = fp[F_HC3]
    Kca = fp[F_HKCA]
    kcd = fp[F_HKCD]
    kh = kcd * D * (p - 1.0)
    Kcb = fp[F_HKCBY] * y0 + fp[F_HKCBP] * phi0
    # predictor: the increments change slowly from one sample to the next
    h1 = st[S_HDG]
    h2 = st[S_HDG2]
    h3 = st[S_HDG3]
    x = 3.0 * (h1 - h2) + h3
    if x < 0.0:
        x = 0.0
    y = 0.0
    e = 1.0              # relative change of w to this iterate (>= 1e-4: pow)
    etol = fp[F_HTOL]
    tol_g = fp[F_HTOLG] * (abs(g0) + 1e-30)
    for it in range(60):
        w = W0 - D * x
        if w > 0.0:
            if -1e-4 < e < 1e-4:
                # a correction: w^p by a third-order Taylor step from the
                # last point (error < 1e-16 relative), no pow
                y = y * (1.0 + e * (p + e * (c2 + e * c3)))
            else:
                # w_mm^p as exp(p ln w_mm): two short calls, faster than
                # pow's one here (38 vs 44 ns a step, AVX2 build, Zen 5)
                y = np.exp(p * np.log(1000.0 * w))
            imp = Kca * y + Kcb
            if imp > 0.0:
                # Halley's step (r' = Aw / w, r'' = -kh y / w^2): cubic, so
                # the predictor's error of ~1e-6 is gone in one step
                r = x - imp
                Aw = w + kcd * y
                den = 2.0 * Aw * Aw + r * kh * y
                if den > Aw * Aw:
                    inv = 1.0 / den
                    dx = 2.0 * r * w * Aw * inv
                    e = 2.0 * D * r * Aw * inv      # (w_next - w) / w
                else:                               # far from the root: Newton
                    inv = 1.0 / Aw
                    dx = r * w * inv
                    e = D * r * inv
            else:
                dx = x
                e = D * x / w
        else:
            y = 0.0
            dx = x - Kcb if Kcb > 0.0 else x
            e = 1.0
        xn = x - dx
        if xn < 0.0:
            xn = 0.0                 # the root is >= 0 (r(0) <= 0)
            dx = x
            e = D * dx / w if w > 0.0 else 1.0
        x = xn
        if w <= 0.0:
            # r is linear where w <= 0: exact if the new point stays there
            if W0 - D * x <= 0.0:
                y = 0.0
                break
        elif -etol <= e <= etol:
            # converged (the next step would change w by ~e^3: < 1e-15 at 1e-5):
            # w^p at the final point by a third-order step
            y = y * (1.0 + e * (p + e * (c2 + e * c3)))
            break
        if abs(dx) <= tol_g:
            w = W0 - D * x
            y = np.exp(p * np.log(1000.0 * w)) if w > 0.0 else 0.0
            break
    st[S_HDG3] = h2
    st[S_HDG2] = h1
    st[S_HDG] = x
    g1 = g0 + x
    # state update at t_{n+1}
    w1 = W0 - D * x
    y1 = y if w1 > 0.0 else 0.0
    phi1 = fp[F_HPE] * phi0 + fp[F_HP1] * y1 + fp[F_HP0] * y0
    F1 = fp[F_HFA] * y1 + fp[F_HFB] * y0 + fp[F_HFPHI] * phi1
    contact = x > 0.0
    if F1 < 0.0 or not contact:
        F1 = 0.0
    st[S_HPHI] = phi1
    st[S_HZ] = zc - dz * g1
    st[S_HY] = y1
    st[S_HW] = w1
    st[S_HIW] = 1.0 / w1 if w1 > 0.0 else 0.0
    return g1, F1, w1, contact


@njit(**JIT_OPTS)
def _fold_offset(ring, off, P, pm, k, G):
    """End a constant injection G at k: add G to the loop positions
    P-k .. P-1, 0 .. k-1 at the time whose position index is pm (slots
    (pm - q) mod P); see the module notes."""
    for q in range(-k, k):
        j = pm - q
        if j < 0:
            j += P
        elif j >= P:
            j -= P
        ring[off + j] += G


@njit(**JIT_OPTS)
def _excite_chunk(s, ring, ipar, fpar, fst, U, C, gbuf):
    """Step 2 of the fast path over a chunk of C samples: inject the
    excitation at k and record the injected g per sample in ``gbuf``.
    (Kept out of
    :func:`_chunk_fast`: with the hammer code inside it, the region's
    min/max loops ran 35 % slower.)"""
    off = ipar[s, I_OFF]
    N = ipar[s, I_N]
    P = 2 * N
    k = ipar[s, I_K]
    st = fst[s]
    m0 = ipar[s, I_POS]
    exc = ipar[s, I_EXC]
    # gbuf holds the injected g per sample.  Within a chunk the incoming
    # wave at k does not depend on this chunk's injections (they leave k and
    # come back after 2k samples through the region, or 2(N-k) through the
    # far end, both longer than the chunk), so a hammer runs here exactly as
    # in the per-sample path.  An excitation that ends inside the chunk
    # (a hammer gone) keeps its last g for the rest of it, as the per-sample
    # path does, until the next chunk folds it into the ring.
    if exc != EXC_NONE:
        fp = fpar[s]
        dt = fp[F_DT]
        A = fp[F_A]
        t0 = fp[F_T0]
        alpha = fp[F_ALPHA]
        hrel = int(fp[F_HREL])
        goff = ipar[s, I_GT_OFF]
        hlast = ipar[s, I_HLAST]
        e = ipar[s, I_EXC_M]
        e_end = ipar[s, I_EXC_END]
        pm = m0
        g = st[S_G]
        n_step = C               # samples left to step one by one
        if exc >= EXC_HAMMER3 and hlast >= 0 and st[S_HY] == 0.0 and st[S_HPHI] == 0.0:
            # a hammer in free flight after a contact (felt relaxed): if its
            # compression w = z - u(k) stays <= 0 over the whole chunk, no
            # step touches the string and the chunk is a constant injection
            # (the incoming u(k) of every sample is in the ring already)
            vz = fp[F_HV] - fp[F_HMC] * g
            z0 = st[S_HZ]
            j1 = (m0 + 1 - k) % P
            j2 = (m0 + 1 + k) % P
            wmax = -np.inf
            w = 0.0
            for i in range(C):
                w = z0 + (i + 1) * dt * vz - (ring[off + j1] - ring[off + j2]) - g
                wmax = max(wmax, w)
                j1 += 1
                if j1 == P:
                    j1 = 0
                j2 += 1
                if j2 == P:
                    j2 = 0
            if wmax <= 0.0:
                gt = g
                j1 = (m0 + 1 - k) % P
                j2 = (m0 + 1 + k) % P
                for i in range(C):
                    ring[off + j1] += gt
                    ring[off + j2] -= gt
                    gbuf[i] = gt
                    j1 += 1
                    if j1 == P:
                        j1 = 0
                    j2 += 1
                    if j2 == P:
                        j2 = 0
                e += C
                st[S_HZ] = z0 + C * dt * vz
                st[S_HW] = w
                st[S_HIW] = 0.0
                st[S_HDG2] = 0.0
                st[S_HDG3] = 0.0
                st[S_HDG] = 0.0
                if e - 1 >= e_end or (e - 1 - hlast > hrel and w < 0.0):
                    exc = EXC_ENDED         # the hammer is gone
                n_step = 0
        for i in range(n_step):   # the caller ends the chunk at e_end at the latest
            pm += 1
            if pm == P:
                pm = 0
            j1 = pm - k
            if j1 < 0:
                j1 += P
            j2 = pm + k
            if j2 >= P:
                j2 -= P
            if exc > EXC_NONE:
                # (the same dispatch as the per-sample path's, written out:
                # as a shared function returning a tuple it cost 35 % more
                # per string-sample in hammer contact, 76 -> 103 ns)
                if exc <= EXC_BIWA:
                    g = _g_at(exc, e, dt, A, t0, alpha)
                    if e >= e_end:
                        exc = EXC_ENDED     # ended: folded at the start of the next chunk
                elif exc == EXC_GTABLE:
                    g = U[goff + e]
                    if e >= e_end - 1:
                        exc = EXC_ENDED
                else:
                    I1 = ring[off + j1] - ring[off + j2]
                    g1, F, w, contact = _hammer_steady(I1, g, fp, st)
                    if not contact:
                        g1, F, w, contact = _hammer_general(I1, g, fp, st)
                    g = g1
                    if contact:
                        hlast = e
                    if e >= e_end or (hlast >= 0 and e - hlast > hrel and w < 0.0):
                        exc = EXC_ENDED     # the hammer is gone
                e += 1
            ring[off + j1] += g
            ring[off + j2] -= g
            gbuf[i] = g
        ipar[s, I_EXC] = exc
        ipar[s, I_EXC_M] = e
        ipar[s, I_HLAST] = hlast
        st[S_G] = g


@njit(**JIT_OPTS)
def _excite_group(ring, ipar, fpar, fst, C, mem, G, scratch, ist):
    """Step 2 of the fast path for G (<= GROUP) strings struck by hammers,
    over the same C samples, their hammer steps interleaved.

    A hammer step is a chain of dependent operations (a power or a series,
    divisions, a Newton or Halley solve: ~100 cycles); stepping several
    independent hammers in one loop lets the CPU overlap their chains.  The
    incoming displacement at k over the chunk is in the ring at its start
    (see :func:`_excite_chunk`), so it is gathered first; the injections
    follow as whole windows.  Member m's g per sample goes to
    ``scratch[m * _GROW:][:C]``; ``ist`` holds the members' integer
    state during the loop.
    """
    GC = _GROW                        # member m: g row at m GC, I1 row at ib0 + m GC
    ib0 = _GIB
    gm0 = _GIB + GROUP * _GROW        # current g per member
    for m in range(G):
        s = mem[m]
        off = ipar[s, I_OFF]
        P = 2 * ipar[s, I_N]
        k = ipar[s, I_K]
        m0 = ipar[s, I_POS]
        j1 = m0 + 1 - k
        if j1 < 0:
            j1 += P
        j2 = m0 + 1 + k
        if j2 >= P:
            j2 -= P
        # I1_i = u_r(k) + u_l(k) before the injection at sample i
        _ring_get(ring, off, P, j1, scratch[ib0 + m * GC:ib0 + m * GC + C], 1.0)
        _ring_get(ring, off, P, j2, scratch[m * GC:m * GC + C], 1.0)
        row = scratch[ib0 + m * GC:ib0 + m * GC + C]
        tmp = scratch[m * GC:m * GC + C]
        for i in range(C):
            row[i] -= tmp[i]
        st = fst[s]
        fp = fpar[s]
        g = st[S_G]
        scratch[gm0 + m] = g
        e = ipar[s, I_EXC_M]
        hlast = ipar[s, I_HLAST]
        e_end = ipar[s, I_EXC_END]
        hrel = int(fp[F_HREL])
        run = 1
        if hlast >= 0 and st[S_HY] == 0.0 and st[S_HPHI] == 0.0:
            # free flight after a contact (felt relaxed): if w = z - u(k) - g
            # stays <= 0 over the chunk, nothing touches the string
            vz = fp[F_HV] - fp[F_HMC] * g
            z0 = st[S_HZ]
            dt = fp[F_DT]
            wmax = -np.inf
            w = 0.0
            for i in range(C):
                w = z0 + (i + 1) * dt * vz - row[i] - g
                wmax = w if w > wmax else wmax
            if wmax <= 0.0:
                run = 0
                gr = scratch[m * GC:m * GC + C]
                for i in range(C):
                    gr[i] = g
                e += C
                st[S_HZ] = z0 + C * dt * vz
                st[S_HW] = w
                st[S_HIW] = 0.0
                st[S_HDG2] = 0.0
                st[S_HDG3] = 0.0
                st[S_HDG] = 0.0
                if e - 1 >= e_end or (e - 1 - hlast > hrel and w < 0.0):
                    ipar[s, I_EXC] = EXC_ENDED      # the hammer is gone
        ist[m] = run
        ist[GROUP + m] = e
        ist[2 * GROUP + m] = hlast
        ist[3 * GROUP + m] = e_end
        ist[4 * GROUP + m] = hrel
    # the interleaved steps
    for i in range(C):
        for m in range(G):
            if ist[m] != 0:
                s = mem[m]
                st = fst[s]
                fp = fpar[s]
                I1 = scratch[ib0 + m * GC + i]
                g = scratch[gm0 + m]
                g1, F, w, contact = _hammer_steady(I1, g, fp, st)
                if not contact:
                    g1, F, w, contact = _hammer_general(I1, g, fp, st)
                scratch[gm0 + m] = g1
                e = ist[GROUP + m]
                if contact:
                    ist[2 * GROUP + m] = e
                hl = ist[2 * GROUP + m]
                if e >= ist[3 * GROUP + m] or (hl >= 0 and e - hl > ist[4 * GROUP + m]
                                               and w < 0.0):
                    ist[m] = 0               # the hammer is gone: g stays
                    ipar[s, I_EXC] = EXC_ENDED
                ist[GROUP + m] = e + 1
                scratch[m * GC + i] = g1
            elif ipar[mem[m], I_EXC] == EXC_ENDED:
                scratch[m * GC + i] = scratch[gm0 + m]
    # state back, and the injections: outgoing = incoming + g on both rails
    for m in range(G):
        s = mem[m]
        ipar[s, I_EXC_M] = ist[GROUP + m]
        ipar[s, I_HLAST] = ist[2 * GROUP + m]
        fst[s, S_G] = scratch[gm0 + m]
        off = ipar[s, I_OFF]
        P = 2 * ipar[s, I_N]
        k = ipar[s, I_K]
        m0 = ipar[s, I_POS]
        j1 = m0 + 1 - k
        if j1 < 0:
            j1 += P
        j2 = m0 + 1 + k
        if j2 >= P:
            j2 -= P
        _ring_add(ring, off, P, j1, scratch[m * GC:m * GC + C], 1.0)
        _ring_add(ring, off, P, j2, scratch[m * GC:m * GC + C], -1.0)


@njit(**EXACT_OPTS)
def start_hammers(ring, ipar, fpar, fst, clean, slots, n, hcols, hvals, qcols, laws, e_ends,
                  dts, V, factors, stiff):
    """Strike strings ``slots[0:n]`` with their felt hammers from their next
    sample: what :meth:`synth.dsp.bank.StringBank.start_hammer_from` does for
    one string, for a unison in one call (a chord's note-ons in the audio
    thread: 5.5 us of Python a string).

    String j's hammer has the template values ``hvals[j]`` at fpar columns
    ``hcols``, law ``laws[j]``, flight ``e_ends[j]`` samples, time step
    ``dts[j]`` (s); its speed is ``V factors[j]`` (m/s) and its felt
    stiffness (columns ``qcols``) is scaled by ``stiff``.  A running
    excitation is ended first (its constant g folded into the ring); the
    hammer starts where the string is at its point k (0 for a ``clean``
    slot, at rest).  The caller validates the speeds and the factor.
    Returns -1, or the first j whose slot's time step is not ``dts[j]``
    (then nothing is written).  IEEE arithmetic (``EXACT_OPTS``): the same
    values as the Python method, to the bit."""
    for j in range(n):
        if fpar[slots[j], F_DT] != dts[j]:
            return j
    for j in range(n):
        s = slots[j]
        off = ipar[s, I_OFF]
        P = 2 * ipar[s, I_N]
        k = ipar[s, I_K]
        pm = ipar[s, I_POS]
        if ipar[s, I_EXC] != EXC_NONE:
            # end it: its constant g onto the loop through x = 0
            G = fst[s, S_G]
            if G != 0.0:
                _fold_offset(ring, off, P, pm, k, G)
            fst[s, S_G] = 0.0
            ipar[s, I_EXC] = EXC_NONE
        u = 0.0
        if not clean[s]:
            u = ring[off + (pm - k) % P] - ring[off + (pm + k) % P] - fst[s, S_G]
        for c in range(hcols.shape[0]):
            fpar[s, hcols[c]] = hvals[j, c]
        sp = V * factors[j]
        dtv = dts[j] * sp
        fpar[s, F_HV] = sp
        fpar[s, F_HDTV] = dtv
        if stiff != 1.0:
            for c in range(qcols.shape[0]):
                fpar[s, qcols[c]] *= stiff
        fst[s, S_HZ] = u - dtv
        fst[s, S_HY] = 0.0
        fst[s, S_HPHI] = 0.0
        fst[s, S_HW] = 0.0
        fst[s, S_HDG] = 0.0
        fst[s, S_HDG2] = 0.0
        fst[s, S_HDG3] = 0.0
        fst[s, S_HIW] = 0.0
        ipar[s, I_EXC] = laws[j]
        ipar[s, I_EXC_M] = 0
        ipar[s, I_EXC_END] = e_ends[j]
        ipar[s, I_HLAST] = -1
    return -1
