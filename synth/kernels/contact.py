"""The termination: contact along the region, the sub-cell contact, the reach (numba).

Step 3 of the scheme (:mod:`synth.kernels.strings`): where a point of the
termination region would pass its obstacle, the right-going wave is set so
that it touches it; on a string whose profile is curved from x = 0 (the
jawari), the first cell's sub-cell contact adds a delta to the wave
leaving x = 0 (:func:`_subcell_delta`, with :func:`_subcell_q`).  The
per-sample path of :mod:`synth.kernels.strings` does both sample by
sample; here is the fast path's form over a chunk: :func:`_region_chunk`
(the min along right-going characteristics, four points a pass:
:func:`_region_pass`, :func:`_region_edge`), the sub-cell contact over the
chunk (:func:`_subcell_chunk`, :func:`_subcell_ring`; :func:`_subcell_needed`
says where no delta can change a sample), the test that skips a chunk's
region step when no point can reach the obstacle (:func:`_out_of_reach`,
:func:`_pairs_below`), and :func:`_region_step`, the step as the drivers
call it.

May import: :mod:`~synth.kernels.config`, :mod:`~synth.kernels.lanes`,
:mod:`~synth.kernels.layout`, :mod:`~synth.kernels.ring`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .config import JIT_OPTS
from .lanes import abs4, lane, load4, max4, splat4
from .layout import F_CURV, F_REACH, I_N, I_OFF, I_POS, I_REG_N, I_REG_OFF, I_SIDE, S_U1P
from .ring import _hmax4, _ring_get, _ring_put


@njit(**JIT_OPTS)
def _subcell_q(r):
    """q(r) = 1 - sqrt(1 - r) = r / (1 + sqrt(1 - r)) for 0 <= r <= 1 (the
    first cell's tangent point over dx, :func:`_subcell_delta`); 0 below,
    1 above."""
    if not (r > 0.0):
        return 0.0
    if r >= 1.0:
        return 1.0
    return r / (1.0 + np.sqrt(1.0 - r))


@njit(**JIT_OPTS)
def _subcell_delta(ut, up, U1, G):
    """The first cell's sub-cell contact: delta (m), the string's virtual
    displacement at x = 0 at this sample, added to the wave leaving x = 0.
    Side-scaled: the obstacle above, ``U1`` = side U(1) > 0 (m), ``G`` =
    F_CURV U1 (m, 0 < G <= U1) the part of it due to the profile's
    curvature; ``ut`` = u(1) at the next sample as it would be without
    delta, ``up`` = u(1) at the last sample (m, side-scaled).  Returns
    delta <= 0 (side-scaled).

    Between x = 0 and the first grid point x = dx the profile is taken as
    U(x) = theta x + G (x / dx)^2 (theta dx = U1 - G; the jawari's
    theta x + x^2 / (2R), thesis eq. 1.15's ramp and parabola, exactly).
    A string whose slope at x = 0 exceeds theta towards the obstacle lies
    on it from x = 0 to the point x_c where it leaves it tangentially (a
    string under tension wraps a smooth obstacle), and its straight part,
    extended back to x = 0, is there at f = -G q^2, where q = x_c / dx =
    1 - sqrt(1 - r) and r = (u(1) - theta dx) / G is the share of point
    1's gap the string has crossed (f = 0 for r <= 0, -G for r >= 1, where
    point 1 touches and the grid's clamp takes over).  For small r, f =
    -(R / 2) a^2 with a = u(1) / dx the string's slope (theta = 0): the
    contact shrinks with the amplitude instead of ending when the string
    no longer reaches point 1's gap U(1) = dx^2 / (2R).

    Quasi-static in the cell (x_c < dx, a sixteenth of a wavelength at
    20 kHz on the 325 kHz grid), f is a nonlinear spring at the end: the
    work the string does on it is a potential, T / dx Phi, Phi = G^2
    Qi(r), Qi(r) = q^3 (2/3 - q/2) the integral of q^2 (r - 5/6 beyond
    1).  Taken explicitly, delta = f(u(1)) pumped energy into a lossless
    string (27 % in 0.7 s at a 0.5 mm pluck).  The kernel takes the
    discrete gradient instead: delta solves

        delta = -(Phi(ut + delta) - Phi(up)) / (ut + delta - up),

    so that the energy it gives the string at this sample, T/(2 dx)
    delta (u1(next) - u1(last)) (the CFL-1 scheme's energy, physics notes
    section 2, with u(1) changed by delta), is -T/(2 dx) (Phi(next) -
    Phi(last)): over a note it telescopes, the string's energy plus Phi
    at two samples never grows, and a clamp at point 1 in between only
    lowers it.  It equals f(u(1)) to first order.  In y = r(ut + delta)
    the right side, minus the secant slope of the convex Phi, makes
    delta + that slope increasing in y: one root, y <= r(ut).  Where it
    lies is read from the sign at y = 0 and y = 1; below 0 and beyond 1
    the equation is a quadratic (Qi is 0, or linear); between, with y =
    2a - a^2, a polynomial in a = q(y) without square roots (a cubic where
    0 < rp < 1): Halley's steps (Newton's where P P'' > P'^2), kept in
    their bracket, until one moves a by less than 1e-5 of it (the error
    is then below 1e-14 of a).  Where 0 < rp < 1 they start from the root
    of the same equation with the mean of q^2 over the step taken with a
    uniform weight in a (the potential's weight is 1 - a): a quadratic,
    exact where a = b, which on a fading sitar chord lies within 6e-6 of
    the root at the median and 6e-4 at the 90th percentile, so that 53 %
    of the solves take one step and 97 % at most two (1.5 on average;
    from a = q(r(ut)), where delta = 0, it took 3.1).  Elsewhere they
    start from q(r(ut)).  The solve is the sub-cell contact's whole cost:
    each step is a division on the loop-carried path (through u(1), the
    solve at one sample sets the one two samples later).  So the path
    holds no other division: b = q(rp) is taken as 1 - sqrt(1 - rp) and
    the first guess as the quadratic's root in the form without a
    division.  Both lose relative precision where they are small, not
    absolute: b enters the equation in sums with terms of order one and
    the guess is only where the steps start, so the delta keeps its
    absolute error of a few 1e-16 of G (the fading 32-voice sitar chord's
    kernel: 23.1-24.0 -> 21.1-22.7 ns a string-sample, alternated)."""
    base = U1 - G
    rt = (ut - base) / G
    rp = (up - base) / G
    if rp > 1.0:
        rp = 1.0                 # u(1) after its clamp: at most U(1) but for rounding
    if not (rt > 0.0) and not (rp > 0.0):
        return 0.0
    b = 0.0
    Qp = 0.0
    sq = 1.0
    if rp > 0.0:
        sq = np.sqrt(1.0 - rp)
        b = 1.0 - sq
        Qp = b * b * b * (2.0 / 3.0 - 0.5 * b)
        # the root at or below 0 (the string leaves the cell): there Qi = 0
        # and (y - rt)(rp - y) + Qp = 0; r(0) rp = Qp - rt rp >= 0
        if Qp - rt * rp >= 0.0:
            h = rt - rp
            y = 0.5 * ((rt + rp) - np.sqrt(h * h + 4.0 * Qp))
            return G * (y - rt)
    if rt > 1.0:
        # the root at or beyond 1 (point 1 touches): there Qi = y - 5/6 and
        # (y - rt)(y - rp) + y - 5/6 - Qp = 0, the larger root; r(1) <= 0.
        # In z = y - rp: z^2 + B z + k = 0, B = rp - rt + 1, k = rp - 5/6
        # - Qp <= 0.  Where rp > 0, with u = 1 - q(rp) (rp = 1 - u^2, Qp =
        # 1/6 - u^2 + 4/3 u^3 - u^4 / 2): k = -u^3 (4/3 - u/2), and r(1) <=
        # 0 is u^2 ((2 - rt) - u (4/3 - u/2)) <= 0, free of the
        # cancellation of rp - 5/6 - Qp (at rt = 2, rp = 1 the root is
        # double, and k's rounding cost sqrt(eps) of G: a hypothesis test
        # found -0.99999999 G for -G)
        if rp > 0.0:
            u = sq
            w = u * (4.0 / 3.0 - 0.5 * u)
            beyond = (2.0 - rt) - w <= 0.0
            k = -u * u * w
        else:
            beyond = (1.0 - rt) * (1.0 - rp) + 1.0 / 6.0 <= 0.0
            k = rp - 5.0 / 6.0
        if beyond:
            B = rp - rt + 1.0
            sq = np.sqrt(B * B - 4.0 * k)
            if B > 0.0:
                z = -2.0 * k / (B + sq)
            else:
                z = 0.5 * (sq - B)
            return G * (z + (rp - rt))
    # the root in 0 < y < 1, in a: P(a) has the sign of the equation's
    # residual (times (2 - a - b) or (y - rp), both > 0 there), and it is
    # positive for y >= rt: [0, 1] brackets the root
    lo = 0.0
    hi = 1.0
    a = -1.0
    if rp > 0.0 and rp < 1.0:
        # the first guess: the root of the equation with the mean of q^2 over
        # the step taken with a uniform weight in a instead of (1 - a),
        # 2a + (b^2 + a b - 2 a^2) / 3 = rt, exact where a = b (rt = 2a)
        b3 = b * (1.0 / 3.0)
        h = 2.0 + b3
        c = rt - b * b3
        dd = h * h - (8.0 / 3.0) * c
        if dd < 0.0:
            dd = 0.0
        ag = 0.75 * (h - np.sqrt(dd))
        if ag > 0.0 and ag < 1.0:
            a = ag
    if a < 0.0:
        hi = _subcell_q(rt)
        a = hi
    for it in range(64):
        y = a * (2.0 - a)
        e = y - rt
        if rp >= 1.0:
            P = e + a * (0.5 * a + 1.0 / 3.0) + 1.0 / 6.0
            dP = 2.0 - a + 1.0 / 3.0
            d2 = -1.0
        elif rp > 0.0:
            sb = 2.0 - a - b
            a2 = a * a
            b2 = b * b
            P = e * sb + (2.0 / 3.0) * (a2 + a * b + b2) - 0.5 * (a + b) * (a2 + b2)
            dP = ((2.0 - 2.0 * a) * sb - e + (4.0 * a + 2.0 * b) / 3.0
                  - 0.5 * (3.0 * a2 + 2.0 * a * b + b2))
            d2 = 3.0 * a + b - 20.0 / 3.0
        else:
            f = y - rp
            P = e * f + a * a * a * (2.0 / 3.0 - 0.5 * a)
            dP = (2.0 - 2.0 * a) * (e + f) + 2.0 * a * a * (1.0 - a)
            ea = 2.0 - 2.0 * a
            d2 = -2.0 * (e + f) + 2.0 * ea * ea + 4.0 * a - 6.0 * a * a
        if P > 0.0:
            hi = a
        elif P < 0.0:
            lo = a
        else:
            break
        if hi - lo <= 1e-15 * hi:
            break               # (delta = 0 within rounding: P(q(rt)) < 0 by an ulp)
        if dP > 0.0:
            # Halley's step (P'' = d2), Newton's where P P'' is large
            Pd = P * d2
            if abs(Pd) <= dP * dP:
                an = a - 2.0 * P * dP / (2.0 * dP * dP - Pd)
            else:
                an = a - P / dP
            # (a step onto an end of the bracket is allowed: the root may
            # lie within rounding of a point already evaluated)
            if an >= lo and an <= hi:
                if abs(an - a) <= 1e-5 * a:
                    # Halley's steps cube their error: the next would be
                    # below 1e-14 of a
                    a = an
                    break
                a = an
                continue
        a = 0.5 * (lo + hi)
    return G * (a * (2.0 - a) - rt)


@njit(**JIT_OPTS)
def _region_pass(src, dst, vw, W, C, R, n0, n1, n2, n3, U0, U1, U2, U3):
    """Four region points of the fast path's termination step, ``dst = src``
    with the points' constraints applied (min; see :func:`_region_chunk`).

    Element i of the window is the right-going characteristic that meets
    point n where R - n <= i < R - n + C, against the left-going value
    ``vw[i + 2n - R - 1]``.  Points n0 <= n1 <= n2 <= n3 (one may repeat:
    min is idempotent).  Reading ``src`` and writing the other buffer
    ``dst`` keeps the select a plain vector min: in place, LLVM turns
    "store min(x, a[i]) to a[i]" into a masked store of x, which AMD CPUs
    before Zen 4 run as microcode (vmaskmovpd: several times slower).
    """
    lo0 = R - n0
    lo1 = R - n1
    lo2 = R - n2
    lo3 = R - n3
    for i in range(lo3):
        dst[i] = src[i]
    s = src[lo0 + C:W]
    o = dst[lo0 + C:W]
    for t in range(W - lo0 - C):
        o[t] = s[t]
    d0 = 2 * n0 - R - 1
    d1 = 2 * n1 - R - 1
    d2 = 2 * n2 - R - 1
    d3 = 2 * n3 - R - 1
    i0 = lo0                      # every point's window holds [lo0, lo3 + C)
    i1 = lo3 + C
    if i1 > i0:
        m_ = i1 - i0
        s = src[i0:i1]
        o = dst[i0:i1]
        v0 = vw[i0 + d0:i1 + d0]
        v1 = vw[i0 + d1:i1 + d1]
        v2 = vw[i0 + d2:i1 + d2]
        v3 = vw[i0 + d3:i1 + d3]
        for t in range(m_):
            m = s[t]
            x = U0 + v0[t]
            m = x if x < m else m
            x = U1 + v1[t]
            m = x if x < m else m
            x = U2 + v2[t]
            m = x if x < m else m
            x = U3 + v3[t]
            m = x if x < m else m
            o[t] = m
        _region_edge(src, dst, vw, C, lo3, i0, lo0, lo1, lo2, lo3, d0, d1, d2, d3, U0, U1, U2, U3)
        _region_edge(src, dst, vw, C, i1, lo0 + C, lo0, lo1, lo2, lo3, d0, d1, d2, d3,
                     U0, U1, U2, U3)
    else:
        _region_edge(src, dst, vw, C, lo3, lo0 + C, lo0, lo1, lo2, lo3, d0, d1, d2, d3,
                     U0, U1, U2, U3)


@njit(**JIT_OPTS)
def _region_edge(src, dst, vw, C, ia, ib, lo0, lo1, lo2, lo3, d0, d1, d2, d3, U0, U1, U2, U3):
    """Elements ia .. ib-1 of a :func:`_region_pass`, which only some of
    the four windows hold (a few per pass)."""
    for i in range(ia, ib):
        m = src[i]
        if lo0 <= i < lo0 + C:
            x = U0 + vw[i + d0]
            m = x if x < m else m
        if lo1 <= i < lo1 + C:
            x = U1 + vw[i + d1]
            m = x if x < m else m
        if lo2 <= i < lo2 + C:
            x = U2 + vw[i + d2]
            m = x if x < m else m
        if lo3 <= i < lo3 + C:
            x = U3 + vw[i + d3]
            m = x if x < m else m
        dst[i] = m


@njit(**JIT_OPTS)
def _region_chunk(ring, off, P, m0, C, U, roff, R, side, acc, tmp, vw, curv, st):
    """Step 3 of the fast path: each right-going characteristic leaves the
    region with the min (side +1; max for side -1) of its entry value and
    U(n) + vl(n) along its path.  The values are multiplied by ``side`` on
    the way in and out, so one min serves both sides (max(a, b) =
    -min(-a, -b), exact); points where the profile is side * inf (no
    contact) are skipped; the points are taken four at a time
    (:func:`_region_pass`), ping-ponging between ``acc`` and ``tmp``.

    With ``curv`` > 0 (``F_CURV``) the first cell's sub-cell contact runs
    first, sample by sample (:func:`_subcell_chunk`): it adds to each
    characteristic's entry value its delta, which depends on the one
    before it through point 1; ``st`` is the string's state row
    (``S_U1P``)."""
    W = C + R - 1
    sc = float(side)
    b = m0 + 1 - R                 # first characteristic slot (unwrapped)
    if b < 0:
        b += P
    _ring_get(ring, off, P, b, acc[0:W], sc)
    jv = m0 + 2
    if jv >= P:
        jv -= P
    _ring_get(ring, off, P, jv, vw[0:W], sc)
    last = 0.0
    if curv > 0.0:
        last = _subcell_chunk(ring, off, P, m0, acc, vw, C, R, sc, sc * U[roff], curv, st)
    src = acc
    dst = tmp
    q = 0
    n0 = n1 = n2 = n3 = R - R       # (not the constant 0: see _ring_get)
    U0 = U1 = U2 = U3 = 0.0
    for r in range(R):
        Un = sc * U[roff + r]
        if Un == np.inf:
            continue
        nn = r + 1
        if q == 0:
            n0 = nn
            U0 = Un
        elif q == 1:
            n1 = nn
            U1 = Un
        elif q == 2:
            n2 = nn
            U2 = Un
        else:
            n3 = nn
            U3 = Un
        q += 1
        if q == 4:
            _region_pass(src, dst, vw, W, C, R, n0, n1, n2, n3, U0, U1, U2, U3)
            src, dst = dst, src
            q = 0
    if q > 0:
        if q < 2:
            n1 = n0
            U1 = U0
        if q < 3:
            n2 = n1
            U2 = U1
        n3 = n2
        U3 = U2
        _region_pass(src, dst, vw, W, C, R, n0, n1, n2, n3, U0, U1, U2, U3)
        src = dst
    _ring_put(ring, off, P, b, src[0:W], sc)
    if last != 0.0:
        # the delta of the chunk's last sample, on slot m0 + C: it enters
        # the region in the next chunk
        j = m0 + C
        if j >= P:
            j -= P
        ring[off + j] += sc * last


@njit(**JIT_OPTS)
def _subcell_needed(sm, vn, ut, up, base, lim):
    """Whether a fast-path chunk must solve the first cell's sub-cell
    contact at this sample (:func:`_subcell_chunk`, :func:`_subcell_ring`;
    side-scaled: ``sm`` the wave leaving x = 0 now, ``vn`` = vl(2), ``ut`` =
    sm - vn = u(1) at the next sample without delta, ``up`` u(1) at the last
    sample, ``base`` = U1 - G, ``lim`` = U1 + G).  Not when the delta can
    change no sample:

    * u(1) at neither sample past ``base`` (r <= 0 at both): the delta is 0
      (the first return of :func:`_subcell_delta`, the same test without
      its divisions);
    * ``ut`` past U1 + G by more than 1e-9 of the values: the delta lies in
      [-G, 0] (minus the secant slope of the potential, whose derivative
      G q^2 lies in [0, G]), so sm + delta stays past U1 + vn and point 1's
      clamp at the next sample replaces it by U1 + vn, whatever delta was
      (the fast path's clamp is ``min(sm + delta, U1 + vn)``: its result
      does not depend on the value it discards).  With the sitar played
      loud this is half the samples with a delta; the solve is the sub-cell
      contact's whole cost (leaving it out here took the sub-cell part of
      the region step from 25.8 to 19.2 ns a string-sample on loud sitar
      notes, host build, Zen 4)."""
    if not (ut > base or up > base):
        return False
    return not (ut - lim > 1e-9 * (abs(sm) + abs(vn) + lim))


@njit(**JIT_OPTS)
def _subcell_chunk(ring, off, P, m0, acc, vw, C, R, sc, U1, curv, st):
    """The first cell's sub-cell contact over a fast-path chunk, on the
    region's windows (side-scaled by ``sc``: ``U1`` = side U(1)).  At the
    chunk's sample t (time m = m0 + 1 + t) point 1 holds characteristic
    ``acc[R - 1 + t]`` against ``vw[t]``; its clamp (the region pass's
    min, which then repeats it exactly) gives u(1) now; u(1) at the next
    sample without delta is the characteristic leaving x = 0 now (slot m,
    ``acc[R + t]``) against ``vw[t + 1]``; u(1) at the last sample is the
    previous t's (``st[S_U1P]`` at t = 0).  :func:`_subcell_delta` gives
    the delta added to slot m, which passes point 1 at the next sample: a
    recursion, hence sample by sample.  Returns the last sample's delta
    (its slot m0 + C lies past the window; the caller adds it) and
    updates ``st[S_U1P]``."""
    W = C + R - 1
    last = 0.0
    i0 = R - 1
    if not (U1 > 0.0 and U1 < np.inf):
        # out of reach (a buzz of 0): no contact, u(1) kept for the state
        st[S_U1P] = sc * (acc[i0 + C - 1] - vw[C - 1])
        return 0.0
    G = curv * U1
    base = U1 - G
    lim = U1 + G
    up = sc * st[S_U1P]
    for t in range(C):
        v = vw[t]
        a = acc[i0 + t]
        x = U1 + v
        if x < a:
            a = x
            acc[i0 + t] = a
        if t < C - 1:
            sm = acc[i0 + t + 1]
        else:
            j = m0 + C
            if j >= P:
                j -= P
            sm = sc * ring[off + j]
        if t + 1 < W:
            vn = vw[t + 1]
        else:
            j = m0 + 3 + t
            if j >= P:
                j -= P
            vn = sc * ring[off + j]
        ut = sm - vn
        if _subcell_needed(sm, vn, ut, up, base, lim):
            dl = _subcell_delta(ut, up, U1, G)
            if dl != 0.0:
                if t < C - 1:
                    acc[i0 + t + 1] += dl
                else:
                    last = dl
        up = a - v
    st[S_U1P] = sc * up
    return last


@njit(**JIT_OPTS)
def _subcell_ring(ring, off, P, m0, C, sc, U1, curv, st, X):
    """The first cell's sub-cell contact over a fast-path chunk whose
    points 2..R are out of reach (their passes skipped): the same steps as
    :func:`_subcell_chunk` (point 1's clamp, delta, ``st[S_U1P]``) on the
    ring's slots m0 .. m0 + C + 2 alone, copied to ``X`` (C + 3 values,
    side-scaled by ``sc``; ``U1`` = side U(1)): at sample t point 1 holds
    ``X[t]`` against ``X[t + 2]``, and u(1) at the next sample without
    delta is ``X[t + 1] - X[t + 3]``, which no earlier step has changed."""
    j = m0
    _ring_get(ring, off, P, j, X, sc)
    if not (U1 > 0.0 and U1 < np.inf):
        st[S_U1P] = sc * (X[C - 1] - X[C + 1])
        return
    G = curv * U1
    base = U1 - G
    lim = U1 + G
    up = sc * st[S_U1P]
    for t in range(C):
        v = X[t + 2]
        a = X[t]
        x = U1 + v
        if x < a:
            a = x
            X[t] = a
        sm = X[t + 1]
        vn = X[t + 3]
        ut = sm - vn
        if _subcell_needed(sm, vn, ut, up, base, lim):
            dl = _subcell_delta(ut, up, U1, G)
            if dl != 0.0:
                X[t + 1] += dl
        up = a - v
    st[S_U1P] = sc * up
    _ring_put(ring, off, P, j, X[0:C + 1], sc)


@njit(inline="always", **JIT_OPTS)
def _pairs_below(r, n, th):
    """Whether |r[a] - r[a + 2]| < th for a = 0 .. n - 3: blocks of 64
    pairs, leaving at the first block with one at or over ``th`` (a NaN
    counts as over).  Inlined into :func:`_out_of_reach`."""
    a0 = 0
    while a0 < n - 2:
        a1 = a0 + 64
        if a1 > n - 2:
            a1 = n - 2
        x = r[a0:a1]
        y = r[a0 + 2:a1 + 2]
        # four running maxima of |x - y| in the lanes of a vector, and their
        # sum, which carries a NaN to the end (a NaN counts as over)
        k = a1 - a0
        k4 = k - k % 4
        m4 = splat4(0.0)
        z4 = splat4(0.0)
        for t in range(0, k4, 4):
            d = abs4(load4(x, t) - load4(y, t))
            m4 = max4(m4, d)
            z4 = z4 + d
        m = _hmax4(m4, 0.0)
        z = lane(z4, 0) + lane(z4, 1) + lane(z4, 2) + lane(z4, 3)
        if z != z:
            return False
        for t in range(k4, k):
            d = abs(x[t] - y[t])
            m = m if d <= m else d
        if not (m < th):
            return False
        a0 = a1
    return True


@njit(inline="always", **JIT_OPTS)
def _out_of_reach(ring, off, P, m0, C, R, B):
    """Whether no point of the termination region can touch the obstacle
    during the fast-path chunk of C samples after time m0, so that its
    step may be skipped (it would not change a sample).

    Within the chunk the values that pass the region are those now in the
    ring's slots m0 + 1 - R .. m0 + C + R (loop positions 2N - C - R ..
    2N + R - 1): the chunk's limits keep every other operation out of
    them.  On that window w, u(n) at any time of the chunk is w[a] -
    w[a + 2n] for some a, a sum of n steps w[b] - w[b + 2], so
    |u(n)| <= n max |w[b] - w[b + 2]|; with B = min over the points of
    side U(n) / n (``F_REACH``), max |w[b] - w[b + 2]| < B keeps every
    point strictly off its obstacle (side (u - U) < 0), and no clamp
    fires.  The threshold keeps 1e-12 of B and of the window's values
    (at most |w[0]| + |w[1]| + (C + 2R) B) for the rounding of the region
    pass's U + v.  B = 0: never skipped; B = inf (no point can be
    touched): always."""
    if not (B > 0.0):
        return False
    if B == np.inf:
        return True
    L = C + 2 * R
    j = m0 + 1 - R
    if j < 0:
        j += P
    j1 = j + 1
    if j1 >= P:
        j1 -= P
    V = abs(ring[off + j]) + abs(ring[off + j1]) + L * B
    th = B * (1.0 - 1e-12) - 1e-12 * V
    if not (th > 0.0):
        return False
    n1 = P - j                     # window values before the ring's wrap
    if n1 > L:
        n1 = L
    # the window's part before the wrap, then the part after it (none if
    # n1 = L), in one loop: the inlined test has one copy of the pairs' loop
    a0 = off + j
    k = n1
    for _ in range(2):
        if not _pairs_below(ring[a0:a0 + k], k, th):
            return False
        a0 = off
        k = L - n1
    if n1 == L:
        return True
    # the (at most two) pairs across the wrap
    for a in range(n1 - 2, n1):
        if a >= 0 and a + 2 < L:
            b = j + a
            if b >= P:
                b -= P
            c = j + a + 2
            if c >= P:
                c -= P
            d = abs(ring[off + b] - ring[off + c])
            if not (d < th):
                return False
    return True


@njit(inline="always", **JIT_OPTS)
def _region_step(s, ring, ipar, fpar, fst, U, C, w1, w2, w3):
    """Step 3 of the fast path over a chunk (the termination region),
    skipped when no point can reach the obstacle (:func:`_out_of_reach`)."""
    R = ipar[s, I_REG_N]
    if R > 0:
        off = ipar[s, I_OFF]
        P = 2 * ipar[s, I_N]
        m0 = ipar[s, I_POS]
        curv = fpar[s, F_CURV]
        if _out_of_reach(ring, off, P, m0, C, R, fpar[s, F_REACH]):
            # (with the sub-cell contact the reach is that of points 2..R:
            # point 1 and the first cell are stepped here; delta and point
            # 1's clamp only move the string away from the obstacle)
            if curv > 0.0:
                sc = float(ipar[s, I_SIDE])
                _subcell_ring(ring, off, P, m0, C, sc, sc * U[ipar[s, I_REG_OFF]], curv, fst[s],
                              w1[0:C + 3])
            return
        _region_chunk(ring, off, P, m0, C, U, ipar[s, I_REG_OFF], R, ipar[s, I_SIDE], w1, w2, w3,
                      curv, fst[s])
