"""Waveguide string bank kernels (numba, nogil, no allocation).

Representation
--------------
Each string of N cells is one ring of P = 2N float64 samples: the loop
"right-going rail from x = 0 to L, then left-going rail back".  The
left-going rail is stored negated (``vl = -u_l``) so that the two ideal
reflections (``u_r(0) = -u_l(0)``, ``u_l(L) = -u_r(L)``) become plain
transport and cost nothing.  A sample at loop position q (q = n for
``u_r`` at grid point n, q = 2N - n for ``vl`` at n) at time index m lives at
ring index ``slot(q, m) = (m - q) mod P``: transport is the clock advancing,
no data moves.  Displacement ``u(n) = ring[slot(n)] - ring[slot(2N - n)]``.

Per time step, in the order of physics notes sections 1-3:
  1. transport (implicit);
  2. excitation at point k: outgoing = incoming + g(t) on both rails, so
     ``u_r(k) += g`` and ``vl(k) -= g``; then ``u(k) = u_r + u_l - g``;
  3. termination region, points n = 1..R: where ``side (u - U) > 0`` set
     ``u_r(n) = U(n) + vl(n)`` (= ``u_r += U - u``);
  4. far end x = L: identity (ideal) or the loss/tuning filter of a musical
     string, applied in place to the sample turning round at q = N.

When an excitation has ended, g stays constant (= G) forever.  Rather than
keep injecting +G and -G every sample, the change of variables ring' = ring
+ G on the loop positions 2N-k .. 2N-1, 0 .. k-1 (the segment through x = 0
that holds the termination region) is made once and injection stops.  It is
exact on every string, lossy or not, at any time (not only in a steady
state): a value crossing k on either rail changes segment exactly when it
would have been injected; both rails of every region point carry the same
offset, which cancels in u and commutes with the clamp; and the far-end
filter never sees it.  (The opposite segment, through the far end, must not
be used on a lossy string: the loop filter would see a step of G and strike
the string with a broadband transient.)  With no excitation running, the
excitation point is no operation point, so the fast path's chunks may be
longer (``I_CHUNK_FREE``).

Fast path (no probe; while an excitation runs, the termination region
entirely below the excitation point): the chunk of C samples is processed
operation by operation instead of sample by sample.  With C no longer than
the loop distance between any two operation points, no sample meets two
operations within one chunk, so this is exact.  The excitation is one of
them only while it runs (``I_CHUNK``; afterwards ``I_CHUNK_FREE``), and a
hammer steps inside the chunk like a pluck: the wave arriving at k during
the chunk was already in the ring at its start.  In the region each right-going characteristic (a ring slot)
leaves with ``min`` (side +1; ``max`` for side -1) of its entry value and
``U(n) + vl(n)`` along its path, the left-going values being untouched in
the chunk; the reduction runs point by point over contiguous scratch copies
and vectorises.  The per-sample path is the plain reference for it and
handles an excitation running inside or next to the region and
diagnostics (probe, contacts).

Parameter tables (columns below) are written by the voice layer at note-on;
the kernel only reads ``ipar``/``fpar`` and updates ``fst`` and the rings.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .config import JIT_OPTS

# ---- integer parameter columns (ipar[s, :]) ---------------------------------
I_OFF = 0        # ring offset in the flat ring array
I_N = 1          # cells N (ring length 2N)
I_POS = 2        # state: (time index of the last processed sample) mod 2N
I_K = 3          # excitation / pickup grid point k (1 .. N-1)
I_EXC = 4        # state: 0 none/ended, -1 ended (offset to cancel), 1 sitar g (eq. 1.13),
                 #   2 biwa g (eq. 1.11), 3 g from a table, 4 hammer 3-parameter felt
                 #   (eq. 1.5), 5 hammer 4-parameter felt (Pub. III eq. 3)
I_EXC_M = 5      # state: samples since excitation start (t = I_EXC_M * dt)
I_REG_OFF = 6    # offset of U(1..R) in the flat profile array
I_REG_N = 7      # R, points in the termination region (0: ideal rigid end)
I_SIDE = 8       # +1 obstacle above (u <= U), -1 below (u >= U)
I_FILT = 9       # 0 ideal far end, 1 loss + tuning filter
I_XDELAY = 10    # extra unit delay in the far-end filter (0 or 1)
I_OUT = 11       # output signal: 0 displacement u(k), 1 bridge force at x = L
I_PROBE = 12     # row in probe arrays, or -1
I_CHUNK = 13     # longest exact fast-path chunk (samples) while an excitation runs; 0: per-sample
I_EXC_END = 14   # first excitation sample with t > t0 (g constant from there);
                 #   g table: its length; hammer: latest end of the hammer's flight
I_GT_OFF = 15    # offset of the g table in the flat table array (kind 3)
I_HLAST = 16     # state: excitation sample of the hammer's last contact (-1: none yet)
I_NDISP = 17     # dispersion: number M of identical first-order allpass sections (0..MAX_DISP)
I_BOFF = 18      # offset of the pitch-bend delay line in the flat table array
I_BLEN = 19      # its length (0: no bend line)
I_CHUNK_FREE = 20  # the same with no excitation running (0 forces per-sample)
I_NI = 21

# ---- float parameter columns (fpar[s, :]) -----------------------------------
F_DT = 0         # time step dt (s)
F_A = 1          # pluck amplitude A (m)
F_T0 = 2         # pluck duration t0 (s)
F_ALPHA = 3      # biwa alpha (1/s)
F_B0 = 4         # one-pole b0
F_A1 = 5         # one-pole a1   (y = b0 x - a1 y1)
F_ETA = 6        # allpass coefficient
F_GAIN = 7       # output gain (signal units -> mix units)
F_TDX = 8        # T / dx (N/m), bridge force scale
F_HMC = 9        # hammer: 2T / (c m) (1/s): its deceleration per unit g (mass m, string T, c)
F_HV = 10        # hammer speed V at first contact (m/s)
F_HQ = 11        # felt stiffness Q0 (3-par) or F0 (4-par), N/mm^p
F_HP = 12        # felt exponent p
F_HA = 13        # 3-par: alpha (s); 4-par: gamma
F_HT = 14        # 4-par: tau0 (s)
F_HK = 15        # hammer: c / 2T (m per N s): g increment per unit felt impulse
F_HE = 16        # 4-par hammer: exp(-dt / tau0)
F_HREL = 17      # samples without contact after which the hammer is gone
F_ADISP = 18     # dispersion allpass coefficient a (string stiffness)
F_B0T = 19       # target of the loss filter's b0: dampers and releases glide there
F_B0S = 20       # glide rate per sample (1 - exp(-dt / 2 ms)); an instant change of the
                 #   end's loss would step the bridge force (u(L) = x - y) and click
F_BDT = 21       # pitch bend: target delay of the bend line (samples, >= 1)
F_BDS = 22       # its glide rate per sample (20 ms: a pitch wheel moves, it does not jump)
F_NF = 23

# ---- float state columns (fst[s, :]) ----------------------------------------
S_G = 0          # current g (m)
S_LP = 1         # one-pole state
S_APX = 2        # allpass x[n-1]
S_APY = 3        # allpass y[n-1]
S_XD = 4         # extra-delay register
S_PEAK = 5       # peak |gain * signal| since last reset (silence detection)
S_HZ = 6         # hammer position z (m)
S_HY = 7         # felt y = w_mm^p at the last step
S_HPHI = 8       # 4-par: memory integral Phi (mm^p s)
S_HW = 9         # felt compression w at the last step (m)
S_BD = 10        # pitch bend: current delay of the bend line (samples)
S_BW = 11        # its write position
S_HDG = 12       # hammer: g increment of the last step (Newton's predictor)
S_D0 = 13        # dispersion sections' states: x1, y1 per section
MAX_DISP = 16
S_HDG2 = S_D0 + 2 * MAX_DISP   # hammer: g increment of the step before the last
S_HDG3 = S_HDG2 + 1   # and the one before that
S_NS = S_HDG3 + 1

# ---- probe channels (probe[row, ch, n]) ---------------------------------------
P_U = 0          # u at the excitation point (m)
P_CONTACT = 1    # region points in contact with the termination
P_F = 2          # hammer force (N)
P_W = 3          # felt compression w (m)
P_Z = 4          # hammer position z (m)
P_G = 5          # outgoing wave g (m)
P_NCH = 6


@njit(**JIT_OPTS)
def _g_at(kind, e, dt, A, t0, alpha):
    """Outgoing wave g (m) at excitation sample e (t = e dt)."""
    if e < 0:
        return 0.0
    t = e * dt
    if kind == 1:
        if t > t0:
            return A
        r = t / t0
        return A * r * r * np.exp(2.0 * (1.0 - r))
    else:
        if t > t0:
            t = t0
        return A * (1.0 - (1.0 + alpha * t) * np.exp(-alpha * t))


@njit(**JIT_OPTS)
def _hammer_step(law, I1, g0, dt, fp, st):
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

    both are ``ca y1 + cb`` with ca > 0.  So the residual
    r(x) = x - K max(0, ca y(W0 - D x) + cb) is increasing (r' >= 1) and
    concave (y is convex in w, w linear in x): Newton's method converges
    from any start, monotonically from the left after its first step, with
    no bracket.  It starts from the last three steps' increments extrapolated
    quadratically, and stops when a correction changes w by less than 1e-7
    relative (the next error, ~ (p-1)/2 (D dx/w) dx, is below 1e-14 w) or
    x by less than 1e-13 of g: 1.0-1.5 iterations per step in the bass and
    middle, up to 3.4 at the top (measured over keys 24-96).  One pow per
    step (later iterates update w^p by a Taylor step).  A-stable (the stiff felt terms are integrated
    exactly), second order.  Returns (g1, F1, w1, contact).
    """
    V = fp[F_HV]
    mc = fp[F_HMC]
    z0 = st[S_HZ]
    y0 = st[S_HY]
    phi0 = st[S_HPHI]
    zc = z0 + dt * (V - mc * 0.5 * g0)      # z1 = zc - dz g1
    dz = 0.5 * dt * mc
    D = 1.0 + dz
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
        return g0, 0.0, W0, False
    Q = fp[F_HQ]
    p = fp[F_HP]
    A = fp[F_HA]
    tau0 = fp[F_HT]
    K = fp[F_HK]
    E = 0.0
    c1 = 0.0
    c0 = 0.0
    if law == 4:
        ca = Q * (0.5 * dt + A)
        cb = Q * (0.5 * dt - A) * y0
    else:
        E = fp[F_HE]
        h = dt / tau0
        qq = (1.0 - E) / h
        c1 = 1.0 - qq
        c0 = qq - E
        ca = Q * ((1.0 - A) * 0.5 * dt + A * tau0 * c1)
        cb = Q * ((1.0 - A) * 0.5 * dt * y0 + A * tau0 * c0 * y0 - A * (1.0 - E) * phi0)
    # predictor: the increments change slowly from one sample to the next
    x = 3.0 * (st[S_HDG] - st[S_HDG2]) + st[S_HDG3]
    if x < 0.0:
        x = 0.0
    y = 0.0
    wm_prev = -1.0
    y_prev = 0.0
    tol_g = 1e-13 * (abs(g0) + 1e-30)
    for it in range(60):
        w = W0 - D * x
        if w > 0.0:
            wm = 1000.0 * w
            e = (wm - wm_prev) / wm_prev if wm_prev > 0.0 else 1.0
            if -1e-4 < e < 1e-4:
                # a Newton correction: w^p by a third-order Taylor step from
                # the last point (error < 1e-16 relative), no pow
                y = y_prev * (1.0 + e * (p + e * (0.5 * p * (p - 1.0)
                                                  + e * (p * (p - 1.0) * (p - 2.0) / 6.0))))
            else:
                y = wm ** p
            wm_prev = wm
            y_prev = y
            imp = ca * y + cb
            if imp > 0.0:
                r = x - K * imp
                dr = 1.0 + K * ca * D * p * y / w
            else:
                r = x
                dr = 1.0
        else:
            y = 0.0
            imp = cb
            if imp > 0.0:
                r = x - K * imp
            else:
                r = x
            dr = 1.0
        dx = r / dr
        xn = x - dx
        if xn < 0.0:
            xn = 0.0                 # the root is >= 0 (r(0) <= 0)
        dx = x - xn
        x = xn
        if w <= 0.0:
            # r is linear where w <= 0: exact if the new point stays there
            if W0 - D * x <= 0.0:
                y = 0.0
                break
        elif D * abs(dx) <= 1e-7 * w:
            # converged: w^p at the final point by a second-order step
            ee = D * dx / w             # w_new = w + D dx
            y = y * (1.0 + ee * (p + ee * 0.5 * p * (p - 1.0)))
            break
        if abs(dx) <= tol_g:
            w = W0 - D * x
            y = (1000.0 * w) ** p if w > 0.0 else 0.0
            break
    st[S_HDG3] = st[S_HDG2]
    st[S_HDG2] = st[S_HDG]
    st[S_HDG] = x
    g1 = g0 + x
    # state update at t_{n+1}
    z1 = zc - dz * g1
    w1 = W0 - D * x
    y1 = y if w1 > 0.0 else 0.0
    if law == 4:
        F1 = Q * (y1 + A * (y1 - y0) / dt)
    else:
        phi1 = E * phi0 + tau0 * (c1 * y1 + c0 * y0)
        st[S_HPHI] = phi1
        F1 = Q * (y1 - A / tau0 * phi1)
    contact = x > 0.0
    if F1 < 0.0 or not contact:
        F1 = 0.0
    st[S_HZ] = z1
    st[S_HY] = y1
    st[S_HW] = w1
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
def _bend_line(y, st, U, boff, blen, bdt, bds):
    """Pitch-bend line: write y, read at the (gliding) delay with third-order
    Lagrange interpolation (taps at delays i-1 .. i+2)."""
    w = int(st[S_BW])
    U[boff + w] = y
    D = st[S_BD] + bds * (bdt - st[S_BD])
    st[S_BD] = D
    i = int(D)
    f = D - i
    h0 = -f * (f - 1.0) * (f - 2.0) / 6.0
    h1 = (f + 1.0) * (f - 1.0) * (f - 2.0) / 2.0
    h2 = -(f + 1.0) * f * (f - 2.0) / 2.0
    h3 = (f + 1.0) * f * (f - 1.0) / 6.0
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


@njit(**JIT_OPTS)
def _far_end(ring, off, P, N, pm, b0, a1, eta, xdel, nd, ad, st):
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
    ring[off + j] = y
    return x, y, j


@njit(**JIT_OPTS)
def _render_per_sample(s, ring, ipar, fpar, fst, U, n, o0, mix, probe):
    """Plain per-sample scheme for string s over n samples, mixing into
    mix[o0:o0+n].  Reference for the fast path; also used when the
    excitation lies inside or next to the region (I_CHUNK = 0, e.g. the top
    keys' hammers on the capo bar) and for probes."""
    off = ipar[s, I_OFF]
    N = ipar[s, I_N]
    P = 2 * N
    k = ipar[s, I_K]
    R = ipar[s, I_REG_N]
    roff = ipar[s, I_REG_OFF]
    side = ipar[s, I_SIDE]
    filt = ipar[s, I_FILT]
    xdel = ipar[s, I_XDELAY]
    outm = ipar[s, I_OUT]
    prow = ipar[s, I_PROBE]
    goff = ipar[s, I_GT_OFF]
    fp = fpar[s]
    dt = fp[F_DT]
    A = fp[F_A]
    t0 = fp[F_T0]
    alpha = fp[F_ALPHA]
    b0 = fp[F_B0]
    a1 = fp[F_A1]
    eta = fp[F_ETA]
    gain = fp[F_GAIN]
    tdx = fp[F_TDX]
    hrel = int(fp[F_HREL])
    nd = ipar[s, I_NDISP]
    ad = fp[F_ADISP]
    b0t = fp[F_B0T]
    b0s = fp[F_B0S]
    boff = ipar[s, I_BOFF]
    blen = ipar[s, I_BLEN]
    bdt = fp[F_BDT]
    bds = fp[F_BDS]
    st = fst[s]
    pm = ipar[s, I_POS]
    exc = ipar[s, I_EXC]
    e = ipar[s, I_EXC_M]
    e_end = ipar[s, I_EXC_END]
    hlast = ipar[s, I_HLAST]
    g = st[S_G]
    peak = st[S_PEAK]
    for i in range(n):
        if exc == -1:
            # the excitation ended on the previous sample: fold its constant
            # g into the ring before this sample, where the fast path does
            _fold_offset(ring, off, P, pm, k, g)
            g = 0.0
            exc = 0
        pm += 1
        if pm == P:
            pm = 0
        # 2. excitation at k: outgoing = incoming + g on both rails
        j1 = pm - k
        if j1 < 0:
            j1 += P
        j2 = pm + k
        if j2 >= P:
            j2 -= P
        F = 0.0
        if exc != 0:
            if exc <= 2:
                g = _g_at(exc, e, dt, A, t0, alpha)
                if e >= e_end:
                    exc = -1
            elif exc == 3:
                g = U[goff + e]
                if e >= e_end - 1:
                    exc = -1
            else:
                I1 = ring[off + j1] - ring[off + j2]
                g, F, w, contact = _hammer_step(exc, I1, g, dt, fp, st)
                if contact:
                    hlast = e
                if e >= e_end or (hlast >= 0 and e - hlast > hrel and w < 0.0):
                    exc = -1          # the hammer is gone
            e += 1
        gt = g                        # injected at k this sample
        if gt != 0.0:
            ring[off + j1] += gt
            ring[off + j2] -= gt
        # 3. termination region
        ncont = 0
        for r in range(R):
            nn = r + 1
            ju = pm - nn
            if ju < 0:
                ju += P
            jv = pm + nn
            if jv >= P:
                jv -= P
            u = ring[off + ju] - ring[off + jv]
            if nn == k:
                u -= gt
            Ur = U[roff + r]
            if side * (u - Ur) > 0.0:
                ring[off + ju] += Ur - u
                ncont += 1
        # 4. far end
        if filt == 1:
            b0 += b0s * (b0t - b0)
            x, y, jn = _far_end(ring, off, P, N, pm, b0, a1, eta, xdel, nd, ad, st)
            if blen > 0:
                y = _bend_line(y, st, U, boff, blen, bdt, bds)
                ring[off + jn] = y
        else:
            x = 0.0
            y = 0.0
        # output
        uk = ring[off + j1] - ring[off + j2] - gt
        if outm == 0:
            sig = uk
        else:
            ja = pm - N + 1
            if ja < 0:
                ja += P
            jb = pm - N - 1
            if jb < 0:
                jb += P
            # u(N-1) - u(N); for the ideal end u(N) = 0 and vl(N-1) = ring[jb]
            sig = tdx * ((ring[off + ja] - ring[off + jb]) - (x - y))
        v = gain * sig
        mix[o0 + i] += v
        a = abs(v)
        if a > peak:
            peak = a
        if prow >= 0:
            probe[prow, P_U, o0 + i] = uk
            probe[prow, P_CONTACT, o0 + i] = ncont
            probe[prow, P_G, o0 + i] = gt
            probe[prow, P_F, o0 + i] = F
            probe[prow, P_W, o0 + i] = st[S_HW]
            probe[prow, P_Z, o0 + i] = st[S_HZ]
    ipar[s, I_POS] = pm
    ipar[s, I_EXC] = exc
    ipar[s, I_EXC_M] = e
    ipar[s, I_HLAST] = hlast
    fp[F_B0] = b0
    st[S_G] = g
    st[S_PEAK] = peak


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
    if exc != 0:
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
        if exc >= 4 and hlast >= 0 and st[S_HY] == 0.0 and st[S_HPHI] == 0.0:
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
                st[S_HDG2] = 0.0
                st[S_HDG3] = 0.0
                st[S_HDG] = 0.0
                if e - 1 >= e_end or (e - 1 - hlast > hrel and w < 0.0):
                    exc = -1         # the hammer is gone
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
            if exc > 0:
                # (the same dispatch as the per-sample path's, written out:
                # as a shared function returning a tuple it cost 35 % more
                # per string-sample in hammer contact, 76 -> 103 ns)
                if exc <= 2:
                    g = _g_at(exc, e, dt, A, t0, alpha)
                    if e >= e_end:
                        exc = -1     # ended: folded at the start of the next chunk
                elif exc == 3:
                    g = U[goff + e]
                    if e >= e_end - 1:
                        exc = -1
                else:
                    I1 = ring[off + j1] - ring[off + j2]
                    g, F, w, contact = _hammer_step(exc, I1, g, dt, fp, st)
                    if contact:
                        hlast = e
                    if e >= e_end or (hlast >= 0 and e - hlast > hrel and w < 0.0):
                        exc = -1     # the hammer is gone
                e += 1
            ring[off + j1] += g
            ring[off + j2] -= g
            gbuf[i] = g
        ipar[s, I_EXC] = exc
        ipar[s, I_EXC_M] = e
        ipar[s, I_HLAST] = hlast
        st[S_G] = g


@njit(**JIT_OPTS)
def _chunk_fast(s, ring, ipar, fpar, fst, U, C, o0, mix, scratch):
    """C samples of string s, operation by operation (C <= ipar[s, I_CHUNK]
    while an excitation runs, else <= ipar[s, I_CHUNK_FREE])."""
    off = ipar[s, I_OFF]
    N = ipar[s, I_N]
    P = 2 * N
    k = ipar[s, I_K]
    R = ipar[s, I_REG_N]
    st = fst[s]
    m0 = ipar[s, I_POS]
    gbuf = scratch[0:C]
    exc = ipar[s, I_EXC]
    if exc == -1:
        # the excitation ended on the last sample of the previous chunk: fold
        # its constant g into the ring now, between chunks
        _fold_offset(ring, off, P, m0, k, st[S_G])
        st[S_G] = 0.0
        exc = 0
        ipar[s, I_EXC] = 0
    # ---- 2. excitation -------------------------------------------------------
    plucking = exc != 0
    if plucking:
        _excite_chunk(s, ring, ipar, fpar, fst, U, C, gbuf)
    # ---- 3. termination region: min/max along right-going characteristics --
    if R > 0:
        roff = ipar[s, I_REG_OFF]
        side = ipar[s, I_SIDE]
        W = C + R - 1
        acc = scratch[C:C + W]
        vwin = scratch[C + W:C + 2 * W]
        b = m0 + 1 - R          # first characteristic slot (unwrapped)
        j = b % P
        for a in range(W):       # gather entry values and left-going window
            acc[a] = ring[off + j]
            j += 1
            if j == P:
                j = 0
        j = (m0 + 2) % P
        for a in range(W):
            vwin[a] = ring[off + j]
            j += 1
            if j == P:
                j = 0
        for r in range(R):
            nn = r + 1
            Un = U[roff + r]
            if side > 0:
                if Un == np.inf:
                    continue
                lo = R - nn
                sh = 2 * nn - R - 1
                # slice views: no aliasing doubt, so LLVM vectorises the select
                av = acc[lo:lo + C]
                vv = vwin[lo + sh:lo + sh + C]
                for a in range(C):
                    x = Un + vv[a]
                    y = av[a]
                    av[a] = x if x < y else y
            else:
                if Un == -np.inf:
                    continue
                lo = R - nn
                sh = 2 * nn - R - 1
                # slice views: no aliasing doubt, so LLVM vectorises the select
                av = acc[lo:lo + C]
                vv = vwin[lo + sh:lo + sh + C]
                for a in range(C):
                    x = Un + vv[a]
                    y = av[a]
                    av[a] = x if x > y else y
        j = b % P
        for a in range(W):
            ring[off + j] = acc[a]
            j += 1
            if j == P:
                j = 0
    # ---- 4. far end, and the output ----------------------------------------
    gain = fpar[s, F_GAIN]
    peak = st[S_PEAK]
    outm = ipar[s, I_OUT]
    if ipar[s, I_FILT] == 1:
        b0 = fpar[s, F_B0]
        a1 = fpar[s, F_A1]
        eta = fpar[s, F_ETA]
        xdel = ipar[s, I_XDELAY]
        tdx = fpar[s, F_TDX]
        nd = ipar[s, I_NDISP]
        ad = fpar[s, F_ADISP]
        b0t = fpar[s, F_B0T]
        b0s = fpar[s, F_B0S]
        boff = ipar[s, I_BOFF]
        blen = ipar[s, I_BLEN]
        bdt = fpar[s, F_BDT]
        bds = fpar[s, F_BDS]
        pm = m0
        for i in range(C):
            pm += 1
            if pm == P:
                pm = 0
            b0 += b0s * (b0t - b0)
            x, y, jn = _far_end(ring, off, P, N, pm, b0, a1, eta, xdel, nd, ad, st)
            if blen > 0:
                y = _bend_line(y, st, U, boff, blen, bdt, bds)
                ring[off + jn] = y
            if outm == 1:
                ja = pm - N + 1
                if ja < 0:
                    ja += P
                jb = pm - N - 1
                if jb < 0:
                    jb += P
                v = gain * tdx * ((ring[off + ja] - ring[off + jb]) - (x - y))
                mix[o0 + i] += v
                if abs(v) > peak:
                    peak = abs(v)
        fpar[s, F_B0] = b0
    elif outm == 1:
        tdx = fpar[s, F_TDX]
        ja = (m0 + 1 - N + 1) % P
        jb = (m0 + 1 - N - 1) % P
        for i in range(C):
            v = gain * tdx * (ring[off + ja] - ring[off + jb])
            mix[o0 + i] += v
            if abs(v) > peak:
                peak = abs(v)
            ja += 1
            if ja == P:
                ja = 0
            jb += 1
            if jb == P:
                jb = 0
    if outm == 0:
        j1 = (m0 + 1 - k) % P
        j2 = (m0 + 1 + k) % P
        for i in range(C):
            gi = gbuf[i] if plucking else 0.0
            v = gain * (ring[off + j1] - ring[off + j2] - gi)
            mix[o0 + i] += v
            if abs(v) > peak:
                peak = abs(v)
            j1 += 1
            if j1 == P:
                j1 = 0
            j2 += 1
            if j2 == P:
                j2 = 0
    st[S_PEAK] = peak
    ipar[s, I_POS] = (m0 + C) % P


@njit(**JIT_OPTS)
def render_bank(ring, ipar, fpar, fst, U, active, n_active, n, o0, mix,
                probe, scratch):
    """Render ``n`` internal samples of every active string into
    ``mix[o0:o0+n]`` (accumulating).

    ring : float64[:]        all rings, concatenated
    ipar, fpar, fst : 2-D     parameter and state tables (columns above)
    U : float64[:]            all region profiles and g tables, concatenated
    active : int64[:]         string indices; the first ``n_active`` are used
    probe : 3-D               per-sample diagnostics [row, channel P_*, n] for
                              strings with ``ipar[s, I_PROBE] >= 0``
    scratch : float64[:]      >= 3 * (max chunk + max R) samples
    """
    for a in range(n_active):
        s = active[a]
        exc = ipar[s, I_EXC]
        cmax = ipar[s, I_CHUNK] if exc > 0 else ipar[s, I_CHUNK_FREE]
        if ipar[s, I_PROBE] >= 0 or cmax <= 0:
            _render_per_sample(s, ring, ipar, fpar, fst, U, n, o0, mix, probe)
        else:
            done = 0
            while done < n:
                C = n - done
                if C > cmax:
                    C = cmax
                if ipar[s, I_EXC] > 0:
                    left = ipar[s, I_EXC_END] - ipar[s, I_EXC_M] + 1
                    if C > left:
                        C = left
                _chunk_fast(s, ring, ipar, fpar, fst, U, C, o0 + done, mix, scratch)
                done += C
                if ipar[s, I_EXC] <= 0:
                    cmax = ipar[s, I_CHUNK_FREE]


def max_fast_chunk(N: int, k: int, R: int, out_mode: int) -> int:
    """Longest chunk (samples) for which the fast path is exact, or 0 when it
    does not apply (excitation inside or next to the region).

    No sample may meet two operation points within one chunk: the loop
    distances region-excitation (k - R), excitation-far end (N - k) and,
    for the bridge-force pickup next to x = L, region-far end (N - R).
    """
    if R > 0 and k <= R + 1:
        return 0
    c = min(k - R, N - k, N - R) - 1
    if out_mode == 1:
        c = min(c, N - R - 2)
    return max(c, 0)


def max_free_chunk(N: int, k: int, R: int, out_mode: int) -> int:
    """Longest exact chunk with no excitation running: the excitation point
    is then no operation point, except as the pickup of ``out_mode`` 0 (u
    at k is read after the chunk's region and far-end steps)."""
    if out_mode == 0:
        if R > 0 and k <= R + 1:
            return 0
        c = min(k - R, N - k, N - R) - 1
    else:
        c = N - R - 2
    return max(c, 0)


@njit(**JIT_OPTS)
def scan_silence(active, n_active, ipar, fst, quiet, last_peak, n_in, level, min_quiet, done):
    """Per-block bookkeeping of the active strings, without allocation.

    For each active string: remember its block peak in ``last_peak`` and
    reset it; add ``n_in`` to its quiet count if its peak stayed below
    ``level`` and no excitation runs, else reset the count; list in ``done``
    the strings quiet for max(4 periods, ``min_quiet``) samples.  Returns
    how many were listed.
    """
    nd = 0
    for a in range(n_active):
        s = active[a]
        pk = fst[s, S_PEAK]
        last_peak[s] = pk
        fst[s, S_PEAK] = 0.0
        if pk < level and ipar[s, I_EXC] == 0:
            quiet[s] += n_in
        else:
            quiet[s] = 0
        need = 4 * ipar[s, I_N]
        if need < min_quiet:
            need = min_quiet
        if quiet[s] >= need:
            done[nd] = s
            nd += 1
    return nd
